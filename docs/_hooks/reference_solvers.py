"""The table of solver back ends on science/solvers.md, from `param_specs.science.BACKENDS`."""
from __future__ import annotations

import reference_md as md

from uav_insar_planner.param_specs.science import BACKENDS


def backends_table() -> str:
    """The back ends as declared (its `<!-- generated: solver back ends -->` line)."""
    lines = ["Each back end is declared once, in `param_specs.science.BACKENDS`: the `solver` "
             "parameter's choices, the dispatcher (`solver.solve`), the rule of which objective "
             "runs where (`params.objective_problems`) and this table read it.", ""]
    lines += md.table(("`solver`", "Objectives", "Certified", "What it is", "`nav_error_m` > 0",
                       "Solve function"), (
        [md.code(b.name), ", ".join(md.code(o) for o in b.objectives),
         "yes" if b.certified else "no", md.text(b.summary + (f"; {b.why}" if b.why else "")),
         md.text(f"refused: {b.nominal_only}") if b.nominal_only else "yes (robust plans)",
         md.code(b.entry)] for b in BACKENDS))
    return "\n".join(lines) + "\n"
