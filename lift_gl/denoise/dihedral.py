"""The mirror images of an (N, C, H, W) array for a test-time self-ensemble: the 8 symmetries of
the square (rotations by 90 degrees and flips of the image plane), as (forward, inverse) pairs.

The network was trained with these as augmentation (train.py) and its guides are world-space
normals, which a flip of the image plane leaves as they are, so every channel is simply
rearranged. Ensembles of 2 and 4 keep H and W in place (flips only); 8 adds the transposes.
"""
from __future__ import annotations

import numpy as np

ENSEMBLE_SIZES = (1, 2, 4, 8)


def _flip(a, axes):
    return np.flip(a, axis=axes) if axes else a


def _transform(transpose: bool, axes: tuple):
    """(forward, inverse): flip `axes`, then swap H and W if `transpose`."""
    if transpose:
        return (lambda a: _flip(a, axes).swapaxes(2, 3)), (lambda a: _flip(a.swapaxes(2, 3), axes))
    return (lambda a: _flip(a, axes)), (lambda a: _flip(a, axes))


# identity, horizontal flip, vertical flip, 180 degrees; then the same after a transpose
_ALL = [_transform(t, axes) for t in (False, True) for axes in ((), (3,), (2,), (2, 3))]


def ensemble_transforms(size: int):
    """The first `size` (1, 2, 4 or 8) of the 8 symmetries, identity first."""
    if size not in ENSEMBLE_SIZES:
        raise ValueError(f"ensemble must be one of {ENSEMBLE_SIZES}, not {size!r}")
    return _ALL[:size]


def ensemble_mean(run, x: np.ndarray, size: int) -> np.ndarray:
    """The mean over the first `size` symmetries of inverse(run(forward(x))), in float64 then
    float32; `run` maps an (N, C, H, W) input to an (N, C', H, W) output of the same H and W."""
    total = None
    for forward, inverse in ensemble_transforms(size):
        y = inverse(run(np.ascontiguousarray(forward(x)))).astype(np.float64)
        total = y if total is None else total + y
    return (total / size).astype(np.float32)


def sidecar_ensemble(meta: dict) -> int:
    """The model sidecar's default number of passes, `inference.ensemble` (1 where absent)."""
    n = int(meta.get("inference", {}).get("ensemble", 1))
    if n not in ENSEMBLE_SIZES:
        raise ValueError(f"inference.ensemble must be one of {ENSEMBLE_SIZES}, not {n}")
    return n
