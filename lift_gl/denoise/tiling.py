"""Running a fully convolutional network on an image too large for one pass: tiles on a grid
aligned to the network's multiple, each run with `overlap` pixels of real context around it.
When the overlap covers the network's receptive radius, the tiled result equals the untiled
one (to float rounding): every output pixel sees exactly the inputs it would see untiled.
"""
from __future__ import annotations

from typing import Callable

import numpy as np


def pad_to_multiple(x: np.ndarray, multiple: int) -> np.ndarray:
    """Pad (N, C, H, W) at the bottom and right, repeating the edge, to multiples of `multiple`."""
    h, w = x.shape[2:]
    ph, pw = -h % multiple, -w % multiple
    if ph == 0 and pw == 0:
        return x
    return np.pad(x, ((0, 0), (0, 0), (0, ph), (0, pw)), mode="edge")


def run_tiled(run: Callable[[np.ndarray], np.ndarray], x: np.ndarray, tile: int, overlap: int) -> np.ndarray:
    """run() on (N, C, H, W) tiles of at most `tile` (plus overlap) a side; H, W, tile and
    overlap must be multiples of the network's multiple (x already padded)."""
    n, _, h, w = x.shape
    if h <= tile and w <= tile:
        return run(x)
    out = None
    for y0 in range(0, h, tile):
        y1 = min(y0 + tile, h)
        for x0 in range(0, w, tile):
            x1 = min(x0 + tile, w)
            ey0, ey1, ex0, ex1 = max(0, y0 - overlap), min(h, y1 + overlap), max(0, x0 - overlap), min(w, x1 + overlap)
            y = run(np.ascontiguousarray(x[:, :, ey0:ey1, ex0:ex1]))
            if out is None:
                out = np.empty((n, y.shape[1], h, w), dtype=y.dtype)
            out[:, :, y0:y1, x0:x1] = y[:, :, y0 - ey0:y1 - ey0, x0 - ex0:x1 - ex0]
    return out
