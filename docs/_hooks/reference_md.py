"""Markdown pieces shared by the generated reference pages (reference.py): table cells that
survive any text the code holds, anchors and the notice that a page is generated."""
from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable, Sequence

# Inside a table cell, outside code spans: `|` ends the cell, `<` may open an HTML tag,
# `*`, `_`, `[` and `]` may turn into emphasis or links.
_SPECIAL = re.compile(r"([\\|*_\[\]])")


def text(value: str) -> str:
    """`value` as Markdown text on one line: its code spans kept, the rest escaped."""
    parts = " ".join(value.split()).split("`")
    if len(parts) % 2 == 0:  # an unpaired backtick: no code span at all
        return "\\`".join(_escaped(p) for p in parts)
    return "".join(code(p) if i % 2 else _escaped(p) for i, p in enumerate(parts))


def _escaped(value: str) -> str:
    return _SPECIAL.sub(r"\\\1", value).replace("<", "&lt;")


def code(value: str) -> str:
    """`value` as an inline code span."""
    return f"`{value}`"


def anchor(anchor_id: str) -> str:
    """An empty HTML anchor: a target for `page.md#anchor_id` anywhere on a line."""
    return f'<a id="{anchor_id}"></a>'


def heading_id(title: str) -> str:
    """The id MkDocs' toc extension gives heading `title` (its first occurrence): Python-
    Markdown's `slugify`, restated so the builders need no Markdown package."""
    value = unicodedata.normalize("NFKD", title.replace("`", ""))
    value = re.sub(r"[^\w\s-]", "", value.encode("ascii", "ignore").decode("ascii"))
    return re.sub(r"[-\s]+", "-", value.strip().lower())


def table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """A Markdown table; cells are Markdown already (see `text`)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def generated_from(*sources: str) -> str:
    """The notice at the top of a generated page, naming the code it comes from."""
    named = ", ".join(code(s) for s in sources)
    return (f'!!! note "Generated from the code"\n    This page is written at build time by '
            f"`docs/_hooks/reference.py` from {named}; change the code, not the page.")
