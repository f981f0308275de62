"""MkDocs hook (mkdocs.yml `hooks:`): the reference pages, generated from the code at each
build so they cannot drift from it. Each builder returns the page's Markdown (pure, for
test/test_docs_reference.py); `on_files` adds the pages, which are never files in docs/.
`on_page_markdown` fills the generated parts of hand-written pages (INSERTS): each a marker
line in the page, replaced by its builder's Markdown.

MkDocs puts this folder on sys.path while it loads the hook; the builders live beside it."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from reference_commands import commands_page
from reference_exit_codes import exit_codes_page
from reference_launch import launch_files
from reference_layout import folder_imports
from reference_parameters import parameters_page
from reference_solvers import backends_table
from reference_topics import recorded_topics, topics_page

PAGES: dict[str, Callable[[], str]] = {
    "reference/parameters.md": parameters_page,
    "reference/topics.md": topics_page,
    "reference/commands.md": commands_page,
    "reference/exit-codes.md": exit_codes_page,
}
#: Hand-written page -> {its marker line: the builder of what replaces it}.
INSERTS: dict[str, dict[str, Callable[[], str]]] = {
    "recording.md": {"<!-- generated: recorded topics -->": recorded_topics},
    "layout.md": {"<!-- generated: folder imports -->": folder_imports},
    "science/solvers.md": {"<!-- generated: solver back ends -->": backends_table},
    "ros/launch.md": {"<!-- generated: launch files -->": launch_files},
}


def on_files(files: Any, config: Any) -> Any:
    """Add each generated page to MkDocs' `files` (in place of a file of the same path)."""
    from mkdocs.structure.files import File  # only MkDocs calls this; the builders need none

    for path, build in PAGES.items():
        stale = files.get_file_from_path(path)
        if stale is not None:
            files.remove(stale)
        files.append(File.generated(config, path, content=build()))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """`markdown` with each marker of INSERTS for this page replaced by its builder's text;
    a marker missing from its page is an error (the build must not drop the part silently)."""
    for marker, build in INSERTS.get(page.file.src_uri, {}).items():
        if marker not in markdown:
            raise ValueError(f"{page.file.src_uri}: the line {marker!r} is missing")
        markdown = markdown.replace(marker, build().rstrip("\n"))
    return markdown
