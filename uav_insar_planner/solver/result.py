"""What a solver back end hands back before the independent check turns it into a Plan."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SolverResult:
    """formation: (num_uavs, 2) rows (x_k, z_k), NaN for a UAV the scheme does not fly; p_com:
    (num_uavs, N) W.

    feasible False means the back end proved (global) or concluded (paper-ao) that no point
    satisfies C1..C11; `blocking` then names the constraints that block it, e.g. ["C8", "C10"].
    lower_bound / gap: the certificate of the global back end (NaN for paper-ao).
    """

    feasible: bool
    formation: np.ndarray
    p_com: np.ndarray
    iterations: int
    blocking: list[str] = field(default_factory=list)
    lower_bound: float = float("nan")
    gap: float = float("nan")
    certificate: str = ""
    message: str = ""
    #: Figures only the back end knows (the tomographic objective's bound), merged into the
    #: plan's metrics beside the checker's.
    metrics: dict = field(default_factory=dict)
