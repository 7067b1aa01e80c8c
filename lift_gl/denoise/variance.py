"""The variance guide of the denoisers, in one place so that its source can change.

Now: the accumulation's two half-buffers (lift_gl/error_estimate.py) give, per pixel, an
unbiased estimate of the variance of the mean with one degree of freedom. When the
accumulation keeps moments and a history (temporal accumulation), replace the body of these
two functions (and shaders/passes/denoise_variance.glsl, the same on the GPU).
"""
from __future__ import annotations

import numpy as np

from ..error_estimate import halves

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def luminance_variance(totals: np.ndarray, half_difference: np.ndarray, divisor=None) -> np.ndarray:
    """(H, W) float32 variance of each pixel's mean luminance; NaN where a half is empty.
    Taken on the luminance of the halves' gap, so the colour channels' correlation counts.
    With `divisor` (H, W, 3: demodulate.safe_albedo), of the demodulated mean's luminance, as
    the GPU path computes it (shaders/passes/denoise_variance.glsl)."""
    sum_a, n_a, sum_b, n_b = halves(totals, half_difference)
    n = n_a + n_b
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = sum_a / n_a - sum_b / n_b
        gap = (gap if divisor is None else gap / divisor) @ LUMINANCE
        variance = gap * gap * (n_a * n_b / (n * n))[..., 0]
    return np.where((n_a[..., 0] > 0) & (n_b[..., 0] > 0), variance, np.nan).astype(np.float32)


def renderer_variance(renderer) -> np.ndarray:
    """The luminance variance of a Renderer's mean image, row 0 = top (image order)."""
    acc = renderer.accumulate
    return np.ascontiguousarray(luminance_variance(acc.read_totals(), acc.read_half_difference())[::-1])
