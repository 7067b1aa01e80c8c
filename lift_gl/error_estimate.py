"""The error of a render without a reference, from the two half-buffers of the accumulation.

The accumulation sends each frame to one of two halves, at random (passes/accumulate.py), so
each pixel has two independent means, A (of n_a samples) and B (of n_b samples); the render's mean is M = (n_a A + n_b B) / n with n = n_a + n_b. For
independent samples of variance s^2, E[(A - B)^2] = s^2 (1/n_a + 1/n_b) and Var(M) = s^2 / n,
so

    (A - B)^2 * n_a * n_b / n^2

is an unbiased estimate of the variance of the pixel's mean: one degree of freedom per pixel
and channel, noisy for one pixel, accurate for an image of many.

For the image, the estimated relMSE is the mean over pixels and channels of
Var(M) / (M^2 + eps), the same normalisation as lift_gl.metrics.rel_mse: it predicts the
relMSE of this render against the noise-free image of the same estimator. It sees variance
only: a biased estimator (a short max_depth, a clamp) is not caught by it — compare against a
reference for that (`lift-gl compare`). It assumes frames are independent, as the host's
seeding makes them (every frame hashes its own random numbers). The subpixel jitter is a
Halton sequence, not independent from frame to frame: with frames sent to the halves at
random, each half sees a random subset of it, so at edges the estimate counts the jitter as
Monte Carlo noise and errs on the high side.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .metrics import REL_MSE_EPS


@dataclass(frozen=True)
class ErrorEstimate:
    rel_mse: float  # estimated relMSE of the mean image (variance part)
    pixels: int     # pixels whose both halves hold samples (those the estimate averages)

    @property
    def rel_std_error(self) -> float:
        """Relative standard error of the image: sqrt of the estimated relMSE."""
        return math.sqrt(self.rel_mse)

    def as_dict(self) -> dict:
        return {"estimated_rel_mse": self.rel_mse, "estimated_rel_std_error": self.rel_std_error,
                "estimate_pixels": self.pixels}


def halves(totals: np.ndarray, difference: np.ndarray):
    """(sum_a, n_a, sum_b, n_b) of the two halves, from the accumulation's totals and half
    difference, (..., 4) arrays of (rgb sums, sample count)."""
    totals = np.asarray(totals, np.float64)
    difference = np.asarray(difference, np.float64)
    a = (totals + difference) / 2
    b = (totals - difference) / 2
    # Counts are whole numbers; float32 storage keeps them exact below 2^24 samples.
    return a[..., :3], np.rint(a[..., 3:4]), b[..., :3], np.rint(b[..., 3:4])


def variance_of_mean(totals: np.ndarray, difference: np.ndarray) -> np.ndarray:
    """Per pixel and channel, the estimated variance of the mean radiance: (..., 3) float64,
    NaN where one half has no sample."""
    sum_a, n_a, sum_b, n_b = halves(totals, difference)
    n = n_a + n_b
    valid = (n_a > 0) & (n_b > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = sum_a / n_a - sum_b / n_b
        variance = gap * gap * n_a * n_b / (n * n)
    return np.where(valid, variance, np.nan)


def variance_of_mean_rgby(totals: np.ndarray, difference: np.ndarray) -> np.ndarray:
    """variance_of_mean for R, G, B and luminance Y, (..., 4) float64: Y's needs the channels'
    covariances, which the halves hold (Y is linear in them)."""
    from .consistency import LUMINANCE

    def with_y(a):
        a = np.asarray(a, np.float64)
        return np.concatenate([a[..., :3], (a[..., :3] @ LUMINANCE)[..., None], a[..., 3:4]], axis=-1)

    t, d = with_y(totals), with_y(difference)
    rgb = variance_of_mean(t[..., [0, 1, 2, 4]], d[..., [0, 1, 2, 4]])
    y = variance_of_mean(t[..., [3, 3, 3, 4]], d[..., [3, 3, 3, 4]])[..., :1]
    return np.concatenate([rgb, y], axis=-1)


def estimate_error(totals: np.ndarray, difference: np.ndarray, eps: float = REL_MSE_EPS) -> ErrorEstimate | None:
    """The image's estimated relMSE; None before both halves hold samples (one frame)."""
    variance = variance_of_mean(totals, difference)
    totals = np.asarray(totals, np.float64)
    count = totals[..., 3:4]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = totals[..., :3] / count
        relative = variance / (mean * mean + eps)
    known = np.isfinite(relative).all(axis=-1)
    if not known.any():
        return None
    return ErrorEstimate(rel_mse=float(relative[known].mean()), pixels=int(known.sum()))
