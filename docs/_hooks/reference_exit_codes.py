"""The exit-codes page: the table of uav_insar_planner/exit_codes.py."""
from __future__ import annotations

import reference_md as md

from uav_insar_planner.exit_codes import EXIT_CODE_TABLE


def exit_codes_page() -> str:
    """The Markdown of reference/exit-codes.md."""
    lines = ["# Exit codes", "", md.generated_from("uav_insar_planner/exit_codes.py"), "",
             "Every command and node of the suite (`uav-insar`, the demo, "
             "`uav-insar-vehicle`, `planner`, `agent`, `mavlink_bridge`) ends with one of "
             "these codes.", ""]
    lines += md.table(("Code", "Name", "Meaning"),
                      ([f'{md.anchor(f"exit-{code}")}{code}', md.code(name), md.text(meaning)]
                       for name, code, meaning in EXIT_CODE_TABLE))
    return "\n".join(lines) + "\n"
