"""Albedo demodulation: the denoisers filter irradiance (radiance / first-hit albedo), which
is smooth across textures, and multiply the albedo back afterwards.

Where a channel's albedo is below `eps` (black surfaces, the background, emitters whose
G-buffer albedo is zero) that channel is not demodulated: its divisor is 1, so nothing is
divided by zero and `remodulate(demodulate(c, a), a)` gives `c` back (to float rounding).
"""
from __future__ import annotations

import numpy as np

EPS = 1e-3  # below this albedo a channel keeps its radiance as it is


def safe_albedo(albedo: np.ndarray, eps: float = EPS) -> np.ndarray:
    """The divisor used for each pixel and channel: the albedo, or 1 where it is below eps."""
    albedo = np.asarray(albedo, dtype=np.float32)
    return np.where(albedo >= eps, albedo, np.float32(1.0)).astype(np.float32)


def demodulate(radiance: np.ndarray, albedo: np.ndarray, eps: float = EPS) -> np.ndarray:
    """Irradiance-like image: radiance / safe_albedo (H, W, 3 float32)."""
    return (np.asarray(radiance, dtype=np.float32) / safe_albedo(albedo, eps)).astype(np.float32)


def remodulate(irradiance: np.ndarray, albedo: np.ndarray, eps: float = EPS) -> np.ndarray:
    """The inverse of demodulate with the same albedo and eps."""
    return (np.asarray(irradiance, dtype=np.float32) * safe_albedo(albedo, eps)).astype(np.float32)
