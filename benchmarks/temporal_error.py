"""Temporal error of an image sequence against its converged reference sequence.

The change of a sequence at frame f (f >= 1) is the mean absolute difference between frames f
and f-1, over pixels and channels, in linear radiance. Under camera motion the content itself
changes, so the output's change is set beside the reference sequence's: their difference is the
change the motion does not explain (flicker, or above 0; a denoiser that smears motion scores
below 0). The references' own noise adds to theirs, so a perfect output scores slightly below 0.
"""
from __future__ import annotations

import numpy as np


def frame_changes(images) -> list[float]:
    """Mean |image[f] - image[f-1]| for f = 1 .. len(images)-1."""
    return [float(np.abs(np.asarray(b, np.float64) - np.asarray(a, np.float64)).mean())
            for a, b in zip(images, images[1:])]


def mean_ratio(image, reference) -> float:
    """Mean of the image over the reference's (1: the energy kept; a denoiser may lose some)."""
    return float(np.mean(image, dtype=np.float64) / max(np.mean(reference, dtype=np.float64), 1e-12))


BRIGHT_OVER_MEAN = 8.0  # "bright": reference luminance (the mean of R, G, B) above this many times the image's


def mean_split(image, reference) -> dict:
    """Where the energy a denoiser keeps or loses lies: mean over the reference's on the bright
    pixels (reference luminance above BRIGHT_OVER_MEAN x its mean: lights seen directly, a few
    pixels that can hold much of the image's energy) and on the rest, with the bright pixels'
    share of the pixels and of the reference's energy. None for a part with no pixels."""
    image = np.asarray(image, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    lum = reference.mean(axis=-1)
    bright = lum > BRIGHT_OVER_MEAN * max(lum.mean(), 1e-12)

    def ratio(mask):
        return float(image[mask].mean() / max(reference[mask].mean(), 1e-12)) if mask.any() else None

    return {"bright": ratio(bright), "rest": ratio(~bright), "bright_pixels": float(bright.mean()),
            "bright_energy": float(reference[bright].sum() / max(reference.sum(), 1e-12))}


def temporal_error(images, references) -> dict:
    """Per frame and averaged: the output's change, the references', their difference, relMSE
    and mean/ref. The change lists start at frame 1; relMSE and mean/ref cover every frame."""
    from lift_gl.metrics import rel_mse

    if len(images) != len(references) or len(images) < 2:
        raise ValueError(f"need two sequences of the same length (at least 2), got {len(images)} and {len(references)}")
    change, ref_change = frame_changes(images), frame_changes(references)
    difference = [c - r for c, r in zip(change, ref_change)]
    per_frame = {"change": change, "reference_change": ref_change, "difference": difference,
                 "relmse": [rel_mse(i, r) for i, r in zip(images, references)],
                 "mean_ratio": [mean_ratio(i, r) for i, r in zip(images, references)]}
    mean = {k: float(np.mean(v)) for k, v in per_frame.items()}
    return {"per_frame": per_frame, "mean": mean}
