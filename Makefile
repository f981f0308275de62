# Two commands do all the set-up: `make demo` and `make test` (see README);
# `make docs` builds the documentation site into site/.
PY ?= python3
# pytest workers of `make test`: most of the suite waits on processes, radios and simulators
# in real time, so two workers on a 2-core machine take about half as long as one (measured:
# 14.6 instead of 27.5 minutes). The modules that fly swarms in real time run on one of them,
# one after the other (test/conftest.py's REAL_TIME_MODULES).
TEST_WORKERS ?= 2
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test docs venv lint bench clean

$(STAMP): setup.py package.xml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[ros,test,docs]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m uav_insar_planner.demo

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS)

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)
	$(BIN)/python benchmarks/solve_time.py

clean:
	rm -rf $(VENV) build install log site *.egg-info
