"""How the viewer shows a G-buffer channel (Renderer.aov): float data -> 8-bit display values.

- albedo: the sRGB encoding of the albedo clipped to [0, 1] (it is a reflectance colour);
- normal: n * 0.5 + 0.5 per axis (world space, the usual normal-map colours); background black;
- depth: view depth divided by the largest depth in view, as grey; background black.

Views of the accumulation (docs/temporal.md):
- history: history length (samples) divided by the longest in view, as grey: black where a
  reprojection restarted it;
- rejection: the last reprojection's rejected bilinear weight, red = depth, green = normal,
  blue = off screen or no surface; black where the history was kept whole;
- variance: the standard deviation of a frame's luminance over its 99th percentile, as grey;
- irradiance: radiance / albedo, tone-mapped (ACES) and sRGB-encoded.
"""
from __future__ import annotations

import numpy as np

from ..tonemap import srgb_encode, tonemap

GBUFFER_VIEWS = ("albedo", "normal", "depth")
ACCUMULATION_VIEWS = ("history", "rejection", "variance", "irradiance")  # change with every frame
AOV_VIEWS = GBUFFER_VIEWS + ACCUMULATION_VIEWS


def aov_to_display(name: str, data: np.ndarray) -> np.ndarray:
    """uint8 (H, W, 3), row 0 = top, from Renderer.aov(name)'s float32 (H, W, 3)."""
    data = np.nan_to_num(np.asarray(data, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if name == "albedo":
        shown = srgb_encode(np.clip(data, 0.0, 1.0))
    elif name == "normal":
        background = ~np.any(data != 0.0, axis=-1, keepdims=True)
        shown = np.where(background, 0.0, data * 0.5 + 0.5)
    elif name in ("depth", "history"):
        value = data[..., :1]
        top = float(value.max())
        shown = np.repeat(value / top if top > 0 else value, 3, axis=-1)
    elif name == "rejection":
        shown = data
    elif name == "variance":
        sigma = np.sqrt(np.maximum(data[..., :1], 0.0))
        top = float(np.percentile(sigma, 99)) if sigma.size else 0.0
        shown = np.repeat(sigma / top if top > 0 else sigma, 3, axis=-1)
    elif name == "irradiance":
        shown = srgb_encode(tonemap(data))
    else:
        raise ValueError(f"unknown AOV {name!r}; choose one of {', '.join(AOV_VIEWS)}")
    return np.clip(np.rint(np.clip(shown, 0.0, 1.0) * 255.0), 0, 255).astype(np.uint8)
