"""Comparing two sets of independent renders: Welch's t per pixel block."""
from __future__ import annotations

import numpy as np


def welch_t(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """t statistics of mean(a) - mean(b) along axis 0 (independent renders). Where neither
    set varies (pure background, a light seen directly) the means must agree exactly: 0
    where they do, inf where they do not."""
    se = np.sqrt(a.var(ddof=1, axis=0) / len(a) + b.var(ddof=1, axis=0) / len(b))
    diff = a.mean(axis=0) - b.mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(se > 0, diff / se, np.where(np.abs(diff) < 1e-6, 0.0, np.inf))


def block_means(images: np.ndarray, block: int = 4) -> np.ndarray:
    """(K, H, W, C) renders -> (K, H / block, W / block) means over blocks and channels."""
    k, h, w, c = images.shape
    return images.reshape(k, h // block, block, w // block, block, c).mean(axis=(2, 4, 5))
