"""Tone mapping and the sRGB transfer function, in numpy.

This module is the reference for the GLSL tonemap pass: the shader mirrors these formulas
and constants one for one, so each step is a small function of its own.

The display pipeline, per pixel and per channel (no cross-channel operations):

    linear radiance x (scene-referred, >= 0)
      -> sanitise:   NaN and negative -> 0, +Inf and huge -> MAX_INPUT      (sanitise)
      -> exposure:   x * 2**exposure                                         (apply_exposure)
      -> operator:   ACES fit | Reinhard | clamp, result in [0, 1]           (tonemap)
      -> sRGB OETF:  exact piecewise curve (IEC 61966-2-1)                   (srgb_encode)
                     or, when a display gamma g is asked for, x^(1/g)        (gamma_encode)
      -> 8 bit:      round(255 * v)                                          (to_srgb8)

ACES variant: Krzysztof Narkowicz's rational fit of the ACES filmic curve (RRT + ODT),
from his blog post "ACES Filmic Tone Mapping Curve" (2016):

    aces(x) = clamp( x (a x + b) / (x (c x + d) + e), 0, 1 )
    a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14

applied per channel to the exposure-scaled input, with no extra input scale (some copies of
this fit pre-multiply by 0.6; lift-gl does not — use ``exposure`` instead).

Reinhard: the simple per-channel form x / (1 + x) (Reinhard et al. 2002, eq. 3), no white
point. Clamp: min(max(x, 0), 1).
"""
from __future__ import annotations

import numpy as np

# ---- constants (the GLSL pass uses the same values) ---------------------------------------

# Narkowicz's ACES fit.
ACES_A = 2.51
ACES_B = 0.03
ACES_C = 2.43
ACES_D = 0.59
ACES_E = 0.14

# sRGB transfer function (IEC 61966-2-1).
SRGB_LINEAR_THRESHOLD = 0.0031308  # linear value where the curve switches
SRGB_ENCODED_THRESHOLD = 0.04045  # the same point, encoded (12.92 * 0.0031308 ~ 0.040450)
SRGB_LINEAR_SLOPE = 12.92
SRGB_GAMMA = 2.4
SRGB_A = 0.055  # offset: encoded = (1 + a) x^(1/2.4) - a

# Inputs are clipped here before tone mapping so that x*x cannot overflow to Inf (Inf/Inf is
# NaN); every operator already maps this value to 1 (Reinhard to 0.9999).
MAX_INPUT = 1.0e4

OPERATORS = ("aces", "reinhard", "clamp")


# ---- steps ---------------------------------------------------------------------------------

def sanitise(linear) -> np.ndarray:
    """float32 copy with NaN and negatives set to 0 and values above MAX_INPUT clipped."""
    x = np.asarray(linear, dtype=np.float32)
    x = np.nan_to_num(x, nan=0.0, posinf=MAX_INPUT, neginf=0.0)
    return np.clip(x, 0.0, MAX_INPUT)


def apply_exposure(linear, exposure: float = 0.0) -> np.ndarray:
    """Scale by 2**exposure (exposure in stops)."""
    return np.asarray(linear, dtype=np.float32) * np.float32(2.0 ** float(exposure))


def aces_narkowicz(x) -> np.ndarray:
    """Narkowicz's ACES filmic fit, clamped to [0, 1]. Input: exposed linear, >= 0."""
    x = np.asarray(x, dtype=np.float32)
    mapped = (x * (ACES_A * x + ACES_B)) / (x * (ACES_C * x + ACES_D) + ACES_E)
    return np.clip(mapped, 0.0, 1.0).astype(np.float32)


def reinhard(x) -> np.ndarray:
    """x / (1 + x). Input: exposed linear, >= 0."""
    x = np.asarray(x, dtype=np.float32)
    return (x / (1.0 + x)).astype(np.float32)


def clamp01(x) -> np.ndarray:
    """min(max(x, 0), 1)."""
    return np.clip(np.asarray(x, dtype=np.float32), 0.0, 1.0)


_OPERATOR_FUNCTIONS = {"aces": aces_narkowicz, "reinhard": reinhard, "clamp": clamp01}


def tonemap(linear, exposure: float = 0.0, operator: str = "aces") -> np.ndarray:
    """Scene-referred linear RGB -> display-referred linear values in [0, 1] (float32).

    The result is still linear: encode it with ``srgb_encode`` for display or 8-bit files.
    """
    try:
        curve = _OPERATOR_FUNCTIONS[operator]
    except KeyError:
        raise ValueError(
            f"unknown tone-mapping operator {operator!r}; choose one of {', '.join(OPERATORS)}"
        ) from None
    exposed = apply_exposure(sanitise(linear), exposure)
    return curve(np.clip(exposed, 0.0, MAX_INPUT))


def srgb_encode(linear) -> np.ndarray:
    """Exact sRGB OETF: linear [0, 1] -> encoded [0, 1] (float32).

    Negative inputs give 0; inputs above 1 follow the power branch (not clipped).
    """
    x = np.maximum(np.asarray(linear, dtype=np.float32), 0.0)
    low = SRGB_LINEAR_SLOPE * x
    high = (1.0 + SRGB_A) * np.power(x, 1.0 / SRGB_GAMMA) - SRGB_A
    return np.where(x <= SRGB_LINEAR_THRESHOLD, low, high).astype(np.float32)


def srgb_decode(encoded) -> np.ndarray:
    """Exact inverse of ``srgb_encode``: encoded [0, 1] -> linear [0, 1] (float32)."""
    v = np.maximum(np.asarray(encoded, dtype=np.float32), 0.0)
    low = v / SRGB_LINEAR_SLOPE
    high = np.power((v + SRGB_A) / (1.0 + SRGB_A), SRGB_GAMMA)
    return np.where(v <= SRGB_ENCODED_THRESHOLD, low, high).astype(np.float32)


def gamma_encode(linear, gamma: float) -> np.ndarray:
    """A plain display gamma instead of the sRGB curve: x^(1/gamma) for x in [0, 1] (float32)."""
    x = np.clip(np.asarray(linear, dtype=np.float32), 0.0, 1.0)
    return np.power(x, np.float32(1.0 / gamma)).astype(np.float32)


def to_srgb8(linear, exposure: float = 0.0, operator: str = "aces", gamma: float | None = None) -> np.ndarray:
    """Scene-referred linear RGB -> 8-bit sRGB (uint8): tonemap, encode, round to nearest.

    ``gamma`` None encodes with the sRGB curve; a number encodes with x^(1/gamma) instead.
    """
    mapped = tonemap(linear, exposure=exposure, operator=operator)
    encoded = srgb_encode(mapped) if gamma is None else gamma_encode(mapped, gamma)
    return np.clip(np.rint(encoded * 255.0), 0, 255).astype(np.uint8)
