"""Images as the notebook shows them: tone-mapped sRGB PNG (lift_gl/tonemap.py).

    from lift_gl.notebook import Image
    Image(renderer.render(spp=64), exposure=1)   # the cell's output is the picture

A `Renderer` is shown the same way (Renderer._repr_png_: its image so far, tone-mapped on the
GPU); `show(image)` displays an array from the middle of a cell.
"""
from __future__ import annotations

import io

import numpy as np


def png_bytes(srgb8: np.ndarray) -> bytes:
    """uint8 (H, W, 3) as PNG file bytes."""
    from PIL import Image as PILImage

    buffer = io.BytesIO()
    PILImage.fromarray(np.ascontiguousarray(srgb8, dtype=np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def jpeg_bytes(srgb8: np.ndarray, quality: int = 90) -> bytes:
    """uint8 (H, W, 3) as JPEG file bytes (the widget's frames: smaller than PNG)."""
    from PIL import Image as PILImage

    buffer = io.BytesIO()
    PILImage.fromarray(np.ascontiguousarray(srgb8, dtype=np.uint8)).save(buffer, format="JPEG", quality=quality)
    return buffer.getvalue()


class Image:
    """A linear float image (H, W, 3) that Jupyter shows tone-mapped; `.array` is the data."""

    def __init__(self, array, exposure: float = 0.0, tonemap: str = "aces", scale: int = 1):
        self.array = np.asarray(array, dtype=np.float32)
        if self.array.ndim != 3 or self.array.shape[2] != 3:
            raise ValueError(f"an image is (H, W, 3), not {self.array.shape}")
        self.exposure, self.tonemap, self.scale = float(exposure), tonemap, int(scale)

    def srgb8(self) -> np.ndarray:
        from ..tonemap import to_srgb8

        image = to_srgb8(self.array, self.exposure, self.tonemap)
        if self.scale > 1:  # small renders shown larger, pixels kept sharp
            image = image.repeat(self.scale, axis=0).repeat(self.scale, axis=1)
        return image

    def _repr_png_(self) -> bytes:
        return png_bytes(self.srgb8())

    def __repr__(self) -> str:
        h, w = self.array.shape[:2]
        return f"<lift_gl Image {w}x{h}, exposure {self.exposure:g}, {self.tonemap}>"


def show(image, exposure: float = 0.0, tonemap: str = "aces", scale: int = 1) -> None:
    """Display a linear image (or a Renderer's image so far) in the notebook now."""
    from IPython.display import display

    display(image if hasattr(image, "_repr_png_") else Image(image, exposure, tonemap, scale))


def renderer_png(renderer) -> bytes | None:
    """A Renderer's image so far, tone-mapped as `display()` does; None before any sample
    (the notebook then shows its text form)."""
    if renderer.stats.spp == 0:
        return None
    return png_bytes(renderer.display())
