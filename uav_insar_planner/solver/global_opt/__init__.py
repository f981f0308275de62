"""The certified global back end (solver="global"): the proven optimum of (P) or its bound.

`optimum.solve_global` searches the ray model of solver/rays.py with the branch and bound of
`branch_bound`, whose inner problem (the slaves' ranges for given angles) `slave_ranges` solves
exactly; `infeasibility` explains an infeasible scenario. It imports nothing from the AO back
end (solver/ao/); study/band.py, a study over `solve_global`, gives the spread over the bound's
minimisers.
"""
