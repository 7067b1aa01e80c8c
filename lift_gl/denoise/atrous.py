"""The à-trous denoiser at the numpy level: the same GLSL filter as the renderer's GPU path
(lift_gl/passes/atrous.py), with the images uploaded to textures and read back.

`variance`, when given, is the variance of each pixel's mean luminance of `color` (as the
accumulation's half-buffers estimate it, lift_gl/denoise/variance.py); it is carried over to
the demodulated image by dividing by the luminance of the albedo squared (exact for grey
albedo). Without it the filter estimates the variance spatially, as SVGF does on its first
frames.
"""
from __future__ import annotations

import numpy as np

from ..passes.atrous import AtrousFilter, AtrousSettings
from .demodulate import EPS, demodulate, remodulate, safe_albedo
from .variance import LUMINANCE


class AtrousDenoiser:
    name = "atrous"

    def __init__(self, ctx=None, settings: AtrousSettings | None = None, backend: str = "auto", **options):
        if ctx is None:
            from ..gl.context import create_context

            ctx = create_context(backend)
        self.ctx = ctx
        self.settings = settings or AtrousSettings(**options)
        self._filter = None
        self._inputs = None

    def _textures(self, size):
        if self._filter is None or self._filter.size != size:
            self.release()
            self._filter = AtrousFilter(self.ctx, size, self.settings)
            self._inputs = [self.ctx.texture(size, 4, dtype="f4") for _ in range(2)]
        return self._filter, self._inputs

    def denoise(self, color, albedo, normal, depth=None, variance=None) -> np.ndarray:
        color = _image(color, "color")
        albedo, normal = _image(albedo, "albedo", color.shape), _image(normal, "normal", color.shape)
        normal = unit_normals(normal)
        h, w = color.shape[:2]
        irradiance = demodulate(color, albedo, EPS)
        if variance is None:
            var = np.full((h, w), -1.0, np.float32)  # unknown: estimated spatially (atrous_prepare.comp)
        else:
            var = np.asarray(variance, np.float32).reshape(h, w) / np.square(safe_albedo(albedo, EPS) @ LUMINANCE)
            var = np.where(np.isfinite(var), np.maximum(var, 0.0), -1.0).astype(np.float32)
        z = np.ones((h, w), np.float32) if depth is None else np.asarray(depth, np.float32).reshape(h, w)
        settings = self.settings
        if depth is None and settings.sigma_depth:
            from dataclasses import replace

            settings = replace(settings, sigma_depth=0.0)
        atrous, (irradiance_tex, guide_tex) = self._textures((w, h))
        atrous.settings = settings
        irradiance_tex.write(np.dstack([irradiance, var]).astype(np.float32).tobytes())
        guide_tex.write(np.dstack([normal, z]).astype(np.float32).tobytes())
        result = atrous.filter(irradiance_tex, guide_tex)
        filtered = np.frombuffer(result.read(), np.float32).reshape(h, w, 4)[..., :3]
        atrous.settings = self.settings
        return remodulate(filtered, albedo, EPS)

    def release(self) -> None:
        if self._filter is not None:
            self._filter.release()
            for t in self._inputs:
                t.release()
        self._filter = self._inputs = None


def unit_normals(normal: np.ndarray) -> np.ndarray:
    """Normals scaled to length 1 (0 stays 0: no surface). Another renderer's normal AOV is
    averaged over a pixel's samples, shorter than 1 at edges, and the normal stop's
    (n_p . n_q)^128 of two normals of length 0.7 underflows to 0 even at the centre tap."""
    normal = np.nan_to_num(normal)
    length = np.linalg.norm(normal, axis=-1, keepdims=True)
    return np.where(length > 1e-6, normal / np.maximum(length, 1e-6), 0.0).astype(np.float32)


def _image(array, name: str, shape=None) -> np.ndarray:
    a = np.asarray(array, np.float32)
    if a.ndim != 3 or a.shape[2] != 3 or (shape is not None and a.shape != shape):
        want = "(H, W, 3)" if shape is None else f"{shape} like color"
        raise ValueError(f"denoiser input {name} must be a float32 array of shape {want}, not {a.shape}")
    return np.ascontiguousarray(a)
