"""MkDocs hook (mkdocs.yml `hooks:`): the reference pages, generated from the code at each
build so they cannot drift from it. Each builder returns the page's Markdown (pure, for
test/test_docs_reference.py); `on_files` adds the pages, which are never files in docs/.

MkDocs puts this folder on sys.path while it loads the hook; the builders live beside it."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from reference_commands import commands_page
from reference_exit_codes import exit_codes_page
from reference_parameters import parameters_page
from reference_topics import topics_page

PAGES: dict[str, Callable[[], str]] = {
    "reference/parameters.md": parameters_page,
    "reference/topics.md": topics_page,
    "reference/commands.md": commands_page,
    "reference/exit-codes.md": exit_codes_page,
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
