"""The variance guide of the denoisers, in one place so that its source can change.

Now: the accumulation's two half-buffers (lift_gl/error_estimate.py) give, per pixel, an
unbiased estimate of the variance of the mean with one degree of freedom. When the
accumulation keeps moments and a history (temporal accumulation), replace the body of this
function (and shaders/passes/denoise_variance.glsl, the same on the GPU).
"""
from __future__ import annotations

import numpy as np

from ..error_estimate import halves
from ..scene.envmap import LUMINANCE  # Rec. 709 weights, as shaders/passes/denoise_variance.glsl


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

