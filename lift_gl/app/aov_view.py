"""How the viewer shows a G-buffer channel (Renderer.aov): float data -> 8-bit display values.

- albedo: the sRGB encoding of the albedo clipped to [0, 1] (it is a reflectance colour);
- normal: n * 0.5 + 0.5 per axis (world space, the usual normal-map colours); background black;
- depth: view depth divided by the largest depth in view, as grey; background black.
"""
from __future__ import annotations

import numpy as np

from ..tonemap import srgb_encode

AOV_VIEWS = ("albedo", "normal", "depth")


def aov_to_display(name: str, data: np.ndarray) -> np.ndarray:
    """uint8 (H, W, 3), row 0 = top, from Renderer.aov(name)'s float32 (H, W, 3)."""
    data = np.nan_to_num(np.asarray(data, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if name == "albedo":
        shown = srgb_encode(np.clip(data, 0.0, 1.0))
    elif name == "normal":
        background = ~np.any(data != 0.0, axis=-1, keepdims=True)
        shown = np.where(background, 0.0, data * 0.5 + 0.5)
    elif name == "depth":
        depth = data[..., :1]
        far = float(depth.max())
        shown = np.repeat(depth / far if far > 0 else depth, 3, axis=-1)
    else:
        raise ValueError(f"unknown AOV {name!r}; choose one of {', '.join(AOV_VIEWS)}")
    return np.clip(np.rint(np.clip(shown, 0.0, 1.0) * 255.0), 0, 255).astype(np.uint8)
