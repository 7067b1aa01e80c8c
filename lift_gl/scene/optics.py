"""Fresnel reflectance in numpy, for what the host precomputes for the shaders (plastic's
internal diffuse reflectance) and what importers convert (a specular F0 to an index).

The shader side is shaders/lift/fresnel.glsl; `fresnel_dielectric` here follows the same
convention: eta = n(side the normal points away from) / n(side the normal points into),
cos_i < 0 means the light arrives from the other side.
"""
from __future__ import annotations

import functools

import numpy as np


def fresnel_dielectric(cos_i, eta: float):
    """Unpolarised Fresnel reflectance of a smooth dielectric interface; 1 under total
    internal reflection."""
    cos_i = np.clip(np.asarray(cos_i, dtype=np.float64), -1.0, 1.0)
    eta = np.where(cos_i < 0, 1.0 / eta, eta)
    cos_i = np.abs(cos_i)
    sin2_t = (1.0 - cos_i ** 2) / eta ** 2
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return np.where(tir, 1.0, 0.5 * (r_par ** 2 + r_perp ** 2))


@functools.lru_cache(maxsize=256)
def internal_diffuse_reflectance(ior: float) -> float:
    """Fraction of diffuse (cosine-distributed) light inside a medium of index `ior` that
    its boundary to air reflects back: 2 * integral over mu in [0, 1] of F(mu) mu, with F
    seen from inside (total internal reflection beyond the critical angle included).

    Gauss-Legendre on each side of the critical cosine, where F has a kink: exact to
    float64 rounding for any index.
    """
    ior = float(ior)
    if ior == 1.0:
        return 0.0
    nodes, weights = np.polynomial.legendre.leggauss(200)
    # Seen from inside, the relative index is 1 / ior; light is totally reflected when
    # sin(theta) > 1 / ior for ior > 1.
    mu_c = np.sqrt(max(0.0, 1.0 - 1.0 / ior ** 2)) if ior > 1.0 else 0.0
    total = 0.0
    for a, b in ((0.0, mu_c), (mu_c, 1.0)):
        if b <= a:
            continue
        mu = 0.5 * (b - a) * nodes + 0.5 * (a + b)
        total += 0.5 * (b - a) * np.sum(weights * fresnel_dielectric(mu, 1.0 / ior) * mu)
    return float(2.0 * total)


def ior_from_f0(f0: float) -> float:
    """The dielectric index whose normal-incidence reflectance is f0 (F0 = ((n-1)/(n+1))^2)."""
    r = np.sqrt(np.clip(f0, 0.0, 0.999))
    return float((1.0 + r) / (1.0 - r))
