"""The paper-faithful back end (solver="paper-ao"): Algorithm 2 of Lahmeri et al.

`algorithm2.solve_ao` alternates (P.0) (`master`, Algorithm 1) and (P.1)/(P.2) (`slave`), each a
CVXPY + Clarabel programme (`convex`) with its UAV's C9-C11 (`comm_constraints`) and the closed
forms of `closed_forms`. It starts from the shared start grid (solver/start_grid.py). It imports
nothing from the global back end (solver/global_opt/).
"""
