"""Command-line values checked where they are parsed, and output paths checked before any
work: a bad value is argparse's one-line usage error (exit 2), an output that cannot be
written is a LiftError (exit 2) before a scene is loaded or a frame rendered.

Used by every command's parser (render, compare, bench, grade, view, warptest, lab).
"""
from __future__ import annotations

import argparse
import math
import os
import tempfile
from pathlib import Path

from .errors import LiftError

MAX_SEED = 2 ** 32 - 1  # seeds are 32-bit unsigned on the GPU


def size(text: str) -> tuple[int, int]:
    """WxH, both positive."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WxH, e.g. 256x256, not {text!r}") from None
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"size must be positive, not {text!r}")
    return w, h


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, not {text!r}") from None


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, not {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, not {text!r}")
    return value


def positive_int(text: str) -> int:
    """A count of at least 1 (samples per pixel, frames, seeds, jobs...)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {value}")
    return value


def natural_int(text: str) -> int:
    """A count of at least 0 (0: off, where the option says so)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, not {value}")
    return value


def seed(text: str) -> int:
    value = _integer(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed is a whole number in [0, {MAX_SEED}], not {value}")
    return value


def finite(text: str) -> float:
    """Any finite number (exposure in stops, ...)."""
    return _number(text)


def positive(text: str) -> float:
    """A finite number above 0 (seconds, tolerances, scales)."""
    value = _number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be above 0, not {text!r}")
    return value


def non_negative(text: str) -> float:
    """A finite number of 0 or more (0: off, where the option says so)."""
    value = _number(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, not {text!r}")
    return value


def probability(text: str) -> float:
    """A finite number strictly between 0 and 1 (a test's alpha)."""
    value = _number(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, not {text!r}")
    return value


# ---- output paths: checked before the work that fills them --------------------------------

def _existing_ancestor(path: Path) -> Path:
    for folder in path.parents:
        if folder.exists():
            return folder
    return Path(".")


def _check_writable_folder(folder: Path, option: str, path) -> None:
    """`folder` (or, where it does not exist yet, the nearest existing folder above it, in
    which the missing ones will be made) must be a folder where a file can be made: tried by
    making (and removing) one, which permissions alone do not tell (a read-only file system,
    a root user)."""
    target = folder if folder.exists() else _existing_ancestor(folder)
    if not target.is_dir():
        raise LiftError(f"{option}: {target} is a file, not a folder", path)
    try:
        fd, probe = tempfile.mkstemp(prefix=".lift-gl-probe-", dir=target)
    except OSError as exc:
        raise LiftError(f"{option}: cannot write in the folder {target} ({exc.strerror or exc})", path) from None
    os.close(fd)
    os.unlink(probe)


def check_output_file(path, option: str = "--out", suffixes=None) -> Path:
    """A file to be written: not a folder, its folder writable (or creatable), and, where
    `suffixes` is given, one of those extensions."""
    path = Path(path)
    if path.is_dir():
        raise LiftError(f"{option}: this is a folder; give a file name", path)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise LiftError(f"{option}: unknown file type {path.suffix or '(no extension)'!r}; use one of "
                        f"{', '.join(suffixes)}", path)
    _check_writable_folder(path.parent, option, path)
    return path


def check_output_folder(path, option: str = "--out") -> Path:
    """A folder to be filled: not a file, writable (or creatable)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise LiftError(f"{option}: this is a file, not a folder", path)
    _check_writable_folder(path, option, path)
    return path


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse's parser, its errors one line (the usage is in --help): `lift-gl render: error:
    argument --spp: must be at least 1, not 0`, exit 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")
