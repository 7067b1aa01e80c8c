"""Does each configuration of a comparison converge to the reference's image? The bias test
of lift_gl/consistency.py on a comparison's runs: each run's final image with the variance of
each pixel's mean (its two halves), pooled over seeds, or the seeds' spread where that is
larger, against the reference's (its halves too, when it was rendered; a file's noise is not
known and it is taken as exact)."""
from __future__ import annotations

import numpy as np

from ..consistency import BIAS_TOLERANCE, Blocks, Estimate, compare_estimates

BLOCK = 8          # pixels on a block's side


def pixel_variance(renderer) -> np.ndarray:
    """The estimated variance of each pixel's mean so far, R, G, B and luminance: (H, W, 4),
    row 0 = top, as the images are (the accumulation's buffers keep row 0 at the bottom)."""
    from ..error_estimate import variance_of_mean_rgby

    acc = renderer.accumulate
    return np.ascontiguousarray(variance_of_mean_rgby(acc.read_totals(), acc.read_half_difference())[::-1])
ALPHA = 1e-3       # chance that a consistent configuration is called biased


def consistency_of_runs(finals: dict, reference, alpha: float = ALPHA, tolerance: float = BIAS_TOLERANCE,
                        block: int = BLOCK) -> dict:
    """finals: label -> [(image, variance (H, W, 4), spp), one per seed]. Returns label ->
    Consistency, or None where no run has a variance estimate (a half of its frames empty)."""
    h, w = reference.image.shape[:2]
    known = np.ones((h, w), bool)
    if reference.variance is not None:
        known &= np.isfinite(reference.variance).all(axis=-1)
    usable = {label: [r for r in runs if np.isfinite(r[1]).all(axis=-1).any()] for label, runs in finals.items()}
    for runs in usable.values():
        for _, variance, _ in runs:
            known &= np.isfinite(variance).all(axis=-1)
    blocks = Blocks.grid(h, w, block, mask=known)
    if reference.variance is not None:
        ref = Estimate.from_pixel_variance(reference.image, reference.variance, blocks,
                                           float(reference.info.get("spp", np.nan)))
    else:
        ref = Estimate.exact(reference.image, blocks)
    out = {}
    for label, runs in usable.items():
        if not runs or not known.any():
            out[label] = None
            continue
        estimate = Estimate.combine([Estimate.from_pixel_variance(image, variance, blocks, spp)
                                     for image, variance, spp in runs])
        if len(runs) >= 2:  # the seeds' spread too: it sees the rare large samples one run's halves missed
            spread = Estimate.from_seeds(np.stack([image for image, _, _ in runs]), blocks,
                                         float(np.mean([spp for _, _, spp in runs])))
            estimate = estimate.with_larger_variance(spread)
        out[label] = compare_estimates(estimate, ref, alpha, tolerance)
    return out


def as_json(c) -> dict:
    if c is None:
        return {"consistent_with_reference": None, "bias_z": None, "why": "no run has a variance estimate"}
    return {"consistent_with_reference": bool(c.consistent), "bias_z": c.z, "bias": c.bias,
            "resolution": c.resolution, "where": c.where, "alpha": c.alpha, "tolerance": c.tolerance,
            "tests": [{"name": t.name, "p": t.p, "level": t.level, "detail": t.detail} for t in c.tests]}
