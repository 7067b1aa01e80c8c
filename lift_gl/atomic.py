"""Output files appear whole or not at all.

Every file lift-gl writes (images, the render's JSON record, compare's and grade's reports)
is written to a temporary name beside it and renamed over the final name once complete
(`os.replace`, atomic on one file system). An error or Ctrl-C while writing removes the
temporary file and leaves any earlier file of that name as it was.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path


def temporary_name(path: Path) -> Path:
    """A name in the same folder (so the rename stays on one file system) that keeps the
    extension: pillow, OpenEXR, numpy and matplotlib choose the format from it."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")


@contextmanager
def atomic_path(path):
    """Yield a temporary path to write; on success it is renamed to `path`, else removed.
    Missing parent folders are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_name(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:  # KeyboardInterrupt included: no half-written file stays behind
        tmp.unlink(missing_ok=True)
        raise


def write_text(path, text: str) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_bytes(path, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
