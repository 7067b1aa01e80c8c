"""Intel Open Image Denoise through pyoidn (the optional `oidn` extra), for comparison.

OIDN takes the radiance with albedo and normal guides (it demodulates inside its network);
depth and variance are not among its inputs. pyoidn is imported when the denoiser is made,
so its absence is one clear error, not an ImportError at start-up.
"""
from __future__ import annotations

import numpy as np

from ..errors import DenoiserError

INSTALL = "pip install 'lift-gl[oidn]' (the pyoidn package, Intel Open Image Denoise)"


class OidnDenoiser:
    name = "oidn"

    def __init__(self, quality: str = "high"):
        try:
            import pyoidn
        except ImportError as exc:
            raise DenoiserError(f"the oidn denoiser needs pyoidn, which is not installed ({exc}): {INSTALL}") from None
        self._pyoidn = pyoidn
        self.quality = quality

    def denoise(self, color, albedo, normal, depth=None, variance=None) -> np.ndarray:
        color = np.ascontiguousarray(np.nan_to_num(np.maximum(color, 0.0)), np.float32)
        albedo = np.ascontiguousarray(np.clip(albedo, 0.0, 1.0), np.float32)
        normal = np.ascontiguousarray(np.clip(normal, -1.0, 1.0), np.float32)
        # The G-buffer's guides come from one unjittered raster sample: noise-free.
        return self._pyoidn.denoise(color, albedo, normal, hdr=True, clean_aux=True, quality=self.quality)
