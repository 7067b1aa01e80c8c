"""Checks that a finished render is not silently wrong: an image with no light in it, negative
or non-finite values, or many samples dropped as NaN/Inf. `lift-gl render` prints what they
find as warning lines and writes it into the render's JSON record; the grader and other Python
callers get the same findings from `check_image` (an image and its statistics) or
`check_render` (a Renderer after render(), which adds what the plugin's source shows).

    from lift_gl.image_checks import check_image
    for warning in check_image(image, renderer.stats):
        print("warning:", warning)

This module imports numpy only.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# More than this fraction of samples dropped as NaN/Inf is warned about: a few in a million
# are a rounding corner case, one in a thousand is a bug that darkens the image (the mean of
# the samples kept is not the pixel's expectation).
DROPPED_FRACTION_LIMIT = 1e-3


@dataclass(frozen=True)
class RenderWarning:
    """One finding. `check`: which check found it (all_zero, negative, non_finite,
    dropped_samples, zero_division); `message`: one line for a person."""

    check: str
    message: str

    def __str__(self) -> str:
        return self.message

    def as_dict(self) -> dict:
        return {"check": self.check, "message": self.message}


def _stat(stats, name: str):
    """A statistic from a RenderStats or from a mapping (a render's JSON record)."""
    if stats is None:
        return None
    if isinstance(stats, dict):
        return stats.get(name)
    return getattr(stats, name, None)


def dropped_fraction(stats, pixels: int) -> float | None:
    """The fraction of a render's samples dropped as NaN/Inf: stats' dropped_samples over spp
    samples in each of `pixels` (None where the stats do not say)."""
    dropped, spp = _stat(stats, "dropped_samples"), _stat(stats, "spp")
    if dropped is None or not spp or not pixels:
        return None
    # (at most 1: the reduced trace pass of a hybrid plugin draws, and may drop, samples of its own)
    return min(1.0, int(dropped) / (int(spp) * pixels))


def check_image(image: np.ndarray, stats=None) -> list[RenderWarning]:
    """What is wrong with a linear H x W x C radiance image (`stats`: the render's RenderStats,
    or a mapping with its spp and dropped_samples; None checks the image alone). An empty list
    when nothing is."""
    image = np.asarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3 or image.size == 0:
        raise ValueError(f"check_image expects an H x W x C image, got shape {image.shape}")
    rgb = image[..., :3]
    found = []
    finite = np.isfinite(rgb)
    bad_pixels = int(np.count_nonzero(~finite.all(axis=-1)))
    if bad_pixels:
        found.append(RenderWarning("non_finite", f"{bad_pixels} of {rgb.shape[0] * rgb.shape[1]} pixels are NaN or "
                                                 "infinite"))
    values = rgb[finite]
    negative = values < 0
    if negative.any():
        pixels = int(np.count_nonzero(((rgb < 0) & finite).any(axis=-1)))
        found.append(RenderWarning("negative", f"{pixels} pixels have negative values (least {values.min():.4g}): "
                                               "radiance is never negative"))
    if not np.any(values):
        found.append(RenderWarning("all_zero", "the image is all zero (black): no light reached the camera, or "
                                               "every sample was dropped or lost"))
    fraction = dropped_fraction(stats, rgb.shape[0] * rgb.shape[1])
    if fraction is not None and fraction > DROPPED_FRACTION_LIMIT:
        found.append(RenderWarning("dropped_samples",
                                   f"dropped {100 * fraction:.1f}% of samples as NaN/Inf "
                                   f"({int(_stat(stats, 'dropped_samples'))} of "
                                   f"{int(_stat(stats, 'spp')) * rgb.shape[0] * rgb.shape[1]}): the image is "
                                   "the mean of the samples kept, which is biased"))
    return found


def check_render(renderer, image: np.ndarray | None = None) -> list[RenderWarning]:
    """check_image on a Renderer's image (its last render() unless `image` is given) and
    stats, and the divisions by a constant zero in the plugin's own shader files, whose value
    GLSL leaves unspecified (lift_gl.shaders.constant_zero_divisions)."""
    from .shaders import constant_zero_divisions

    found = check_image(renderer.image() if image is None else image, renderer.stats)
    trace = getattr(renderer, "trace", None)
    source = getattr(trace, "source", None)
    if source is not None:
        for path, line in constant_zero_divisions(source):
            found.append(RenderWarning("zero_division", f"{path}:{line}: divides by a constant zero; GLSL leaves "
                                                        "the result unspecified (on llvmpipe it is undefined and "
                                                        "may reach the image as any value, not as NaN/Inf)"))
    return found
