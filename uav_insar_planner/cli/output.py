"""Output files of `uav-insar sweep` and `map` written whole or not at all: each is written
under a hidden temporary name beside its path and renamed onto it once complete (a rename
within one folder is atomic), so a Ctrl-C or a crash while writing leaves the path as it was,
missing or the previous file, never half a file."""
from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def whole_file(path: str | Path) -> Iterator[Path]:
    """A temporary path beside `path`, with its suffix (matplotlib picks the format by it), to
    write into; renamed onto `path` when the block ends, removed when it raises."""
    path = Path(path)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        # mkstemp makes the file private (0600); the output gets a new file's usual mode
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
