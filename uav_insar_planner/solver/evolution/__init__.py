"""A metaheuristic baseline back end (solver="evolution"): differential evolution.

The field's follow-up work plans UAV-InSAR formations with evolutionary algorithms (arXiv
2507.11284) and particle swarms; this back end is that kind of baseline, on
scipy.optimize.differential_evolution. `problem` states (P) over a continuous decision
vector with C1-C11 from model.py (and the station disk of solver/power.py); `algorithm` runs
the seeded search and a local polish; `result` turns the answer into a SolverResult. It
carries no certificate (lower_bound NaN) and imports nothing of the other back ends.
"""
