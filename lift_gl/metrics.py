"""Image error metrics for comparing a render with a reference.

Conventions (those of the Mitsuba references in the shared refs folder and of the Lift paper):
- ``rel_mse``, ``mse``, ``rmse`` work on linear RGB, averaged over pixels and channels;
  relMSE = mean((x - ref)^2 / (ref^2 + eps)), eps = 1e-2.
- ``ssim`` works on sRGB-encoded values clipped to [0, 1] (no tone mapping), scikit-image's
  ``structural_similarity`` with ``channel_axis=-1, data_range=1`` and its default 7x7
  uniform window; ``dssim = 1 / ssim - 1`` as the Lift paper reports it.
- ``flip`` (optional, the ``flip-evaluator`` package) is mean HDR-FLIP on linear RGB.
Images are H x W x C float arrays of equal shape; use ``box_downsample`` or ``resize_to``
first when a reference has a higher resolution.
"""
from __future__ import annotations

import numpy as np

from .tonemap import srgb_encode

REL_MSE_EPS = 1e-2


def _pair(img, ref) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(img, dtype=np.float64)
    r = np.asarray(ref, dtype=np.float64)
    if x.shape != r.shape:
        raise ValueError(
            f"image and reference differ in shape: {x.shape} vs {r.shape} "
            "(resize one with box_downsample or resize_to)"
        )
    return x, r


def mse(img, ref) -> float:
    """Mean squared error, over all pixels and channels."""
    x, r = _pair(img, ref)
    return float(np.mean((x - r) ** 2))


def rmse(img, ref) -> float:
    """Root mean squared error."""
    return float(np.sqrt(mse(img, ref)))


def rel_mse(img, ref, eps: float = REL_MSE_EPS) -> float:
    """Relative MSE on linear RGB: mean((x - ref)^2 / (ref^2 + eps))."""
    x, r = _pair(img, ref)
    return float(np.mean((x - r) ** 2 / (r * r + eps)))


def _display(img) -> np.ndarray:
    """Linear RGB -> sRGB-encoded, clipped to [0, 1], float64 (what SSIM compares)."""
    return np.clip(srgb_encode(img).astype(np.float64), 0.0, 1.0)


def ssim(img, ref) -> float:
    """Structural similarity on sRGB-encoded values clipped to [0, 1] (scikit-image).

    Needs scikit-image (``pip install 'lift-gl[report]'``). Images of H x W x 3.
    """
    try:
        from skimage.metrics import structural_similarity
    except ImportError as exc:  # an optional dependency: say how to get it
        raise ImportError(
            "lift_gl.metrics.ssim needs scikit-image: pip install 'lift-gl[report]'"
        ) from exc
    x, r = _pair(img, ref)
    if x.ndim != 3:
        raise ValueError(f"ssim expects H x W x C images, got shape {x.shape}")
    return float(structural_similarity(_display(x), _display(r), channel_axis=-1, data_range=1.0))


def dssim(img, ref) -> float:
    """1 / SSIM - 1: 0 for identical images, growing without bound as SSIM falls to 0.

    Infinite when SSIM <= 0 (unrelated or anti-correlated images).
    """
    return dssim_from_ssim(ssim(img, ref))


def dssim_from_ssim(s: float) -> float:
    """1 / SSIM - 1 of an SSIM already computed; infinite when SSIM <= 0."""
    return float("inf") if s <= 0.0 else 1.0 / s - 1.0


def flip(img, ref) -> float:
    """Mean HDR-FLIP error (NVIDIA's perceptual metric) of linear RGB images: 0 identical.

    Optional: needs the ``flip-evaluator`` package (``pip install 'lift-gl[flip]'``). HDR-FLIP
    chooses its exposure range from the reference alone, so errors of one reference compare.
    """
    try:
        import flip_evaluator
    except ImportError as exc:
        raise ImportError("lift_gl.metrics.flip needs NVIDIA's FLIP: pip install 'lift-gl[flip]'") from exc
    x, r = _pair(img, ref)
    if x.ndim != 3 or x.shape[2] != 3:
        raise ValueError(f"flip expects H x W x 3 images, got shape {x.shape}")
    _, mean_error, _ = flip_evaluator.evaluate(np.maximum(r, 0).astype(np.float32), np.maximum(x, 0).astype(np.float32),
                                               "HDR", applyMagma=False)
    return float(mean_error)


def finite_fraction(img) -> float:
    """Fraction of the array's values that are finite (not NaN or +-Inf)."""
    arr = np.asarray(img)
    if arr.size == 0:
        return 1.0
    return float(np.count_nonzero(np.isfinite(arr)) / arr.size)


def box_downsample(img, factor: int) -> np.ndarray:
    """Average non-overlapping factor x factor blocks. H and W must be multiples of factor."""
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
        raise ValueError(f"box_downsample factor must be a positive integer, got {factor!r}")
    arr = np.asarray(img)
    h, w = arr.shape[:2]
    if h % factor or w % factor:
        raise ValueError(f"image of {h}x{w} (HxW) does not divide into {factor}x{factor} blocks")
    f = int(factor)
    blocks = arr.reshape(h // f, f, w // f, f, *arr.shape[2:])
    out = blocks.astype(np.float64).mean(axis=(1, 3))
    return out.astype(arr.dtype if np.issubdtype(arr.dtype, np.floating) else np.float32)


def resize_to(img, shape) -> np.ndarray:
    """Box-downsample to ``shape`` = (height, width); both must divide the image's by the
    same integer factor (e.g. a 1024x1024 reference to 256x256)."""
    arr = np.asarray(img)
    h, w = arr.shape[:2]
    th, tw = (int(s) for s in shape[:2])
    if (th, tw) == (h, w):
        return arr.copy()
    if th <= 0 or tw <= 0 or h % th or w % tw or h // th != w // tw:
        raise ValueError(
            f"cannot box-resize {h}x{w} to {th}x{tw}: needs the same integer factor on both axes"
        )
    return box_downsample(arr, h // th)
