"""The launch files' arguments on ros/launch.md, from `ros.launch_files.LAUNCH_FILES`: the table
the launch files declare their arguments from, so the page lists what `--show-args` shows."""
from __future__ import annotations

import reference_md as md

from uav_insar_planner.ros.launch_files import LAUNCH_FILES, PACKAGE


def launch_files() -> str:
    """One section per launch file: what it starts, then its arguments (the page's
    `<!-- generated: launch files -->` line)."""
    lines = []
    for name, spec in LAUNCH_FILES.items():
        lines += [f"### `{name}`", "", f"`ros2 launch {PACKAGE} {name}`: "
                  f"{md.text(spec.starts)}.", ""]
        lines += md.table(("argument", "default", "choices", "what it sets"), (
            [md.code(a.name),
             "required" if a.default is None else md.code(a.default) if a.default else "empty",
             ", ".join(md.code(c) for c in a.choices) or "-", md.text(a.description)]
            for a in spec.args))
        lines.append("")
    return "\n".join(lines)
