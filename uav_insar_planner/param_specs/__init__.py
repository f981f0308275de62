"""Every parameter of the suite, described once: `ParamSpec` (here) holds a parameter's name,
type, default, allowed range and why it stops there, unit (` [unit]` in its description),
description, and how its value becomes SI and which attribute holds it.

- `science`: the scenario's table (PARAM_SPECS, Table I); `params` validates values against it
  and builds `Params` from it.
- `nodes`: every node's own table and which node takes which (NODE_SPECS, `nodes_taking`);
  `ros/parameters.py` declares them, `mavlink/config.py` builds `BridgeConfig` from
  BRIDGE_SPECS, and the command line and the demo know from here, without ROS, every name a
  params file may hold.

Plain data: nothing here imports ROS or MAVLink, so the science may read every table.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ParamSpec:
    """One user-facing parameter. `length` > 0 means a list of that many numbers; `per_uav` a
    list of one number per UAV (num_uavs of them, checked against num_uavs by `params`).

    Its value in SI is `to_si` of the value as given (of each item of a list; None: the value
    is SI as given), held in the attribute `attribute` (`si_name`, or the parameter's name).

    `paper`: the paper's value where `default` is a field-only one, a departure from the
    paper's Table I and problem (P) made for flying (`--paper` and `load_params(paper=True)`
    set it back); None where the default is the paper's or the paper has none."""

    name: str
    kind: type  # int, float or str
    default: Any
    description: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    length: int = 0
    choices: tuple[str, ...] = ()
    hi_open: bool = False
    why: str = ""  # why the range stops where it does (shown with a value outside it)
    per_uav: bool = False
    si_name: str = ""
    to_si: Callable[[float], float] | None = None
    paper: Any = None

    @property
    def attribute(self) -> str:
        """The name of the attribute that holds the SI value (in Params, BridgeConfig)."""
        return self.si_name or self.name

    def si_value(self, value: Any) -> Any:
        """A checked value (in the parameter's unit) in SI; a list as a tuple."""
        convert = self.to_si or (lambda v: v)
        if isinstance(value, (list, tuple)):
            return tuple(convert(v) for v in value)
        return convert(value)

    def allowed(self) -> str:
        """What the parameter allows, in words (node descriptors, errors, the docs)."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        if self.kind is bool:
            return "true or false"
        if self.kind is list:
            return "a non-empty list of " + ("strings" if isinstance(self.default[0], str)
                                             else "integers")
        what = {int: "an integer", float: "a finite number", str: "a string"}[self.kind]
        if self.length:
            what = f"a list of {self.length} finite numbers"
        if self.per_uav:
            what = "a list of num_uavs finite numbers (one per UAV, U0 first)"
        # %g would write an integer bound such as 2**31 - 1 as 2.14748e+09
        num = (lambda v: str(int(v))) if self.kind is int else (lambda v: f"{v:g}")
        if self.lo is not None and self.hi is not None:
            rng = (f"{'(' if self.lo_open else '['}{num(self.lo)}, {num(self.hi)}"
                   f"{')' if self.hi_open else ']'}")
            return f"{what} in {rng}"
        if self.lo is not None:
            return f"{what} {'>' if self.lo_open else '>='} {num(self.lo)}"
        return what
