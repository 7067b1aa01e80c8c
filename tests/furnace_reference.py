"""Reference values for white furnace tests of the GGX BRDF, in numpy, independent of the GLSL.

The directional albedo of a GGX reflector with Fresnel = 1,

    E(mu_o, alpha) = integral over the upper hemisphere of f(wo, wi) cos(theta_i) d(wi),
    f = D(h) G2(wo, wi) / (4 cos(theta_o) cos(theta_i)),

with the GGX (Trowbridge-Reitz) D and the height-correlated Smith G2, is what a conductor with
F0 = 1 reflects in a white furnace; 1 - E is the energy lost to single scattering.

It is computed by quadrature, not by sampling. Integrating over wi directly needs a grid finer
than the lobe, which is narrow for small alpha, so the integral is taken over the half vector
h instead (d(wi) = 4 (wo.h) d(h)), and h is parametrised by the inverse of the GGX cumulative
distribution in theta_h: tan^2(theta_h) = alpha^2 xi / (1 - xi) makes D(h) cos(theta_h) d(h) =
d(xi) d(phi) / (2 pi). What is left,

    E = integral over xi in [0, 1), phi in [0, 2 pi) of
        G2(wo, wi) (wo.h) / (mu_o cos(theta_h)) [wo.h > 0] [wi.z > 0] d(xi) d(phi) / (2 pi),

is smooth but for kinks where G2 or wo.h reach 0, and Gauss-Legendre converges on it for any
alpha. wo lies in the xz-plane, so the integrand is even in phi and phi runs over [0, pi].
"""
from __future__ import annotations

import functools

import numpy as np


def ggx_D(cos_h: np.ndarray, alpha: float) -> np.ndarray:
    """GGX normal distribution as a function of cos(theta_h)."""
    cos2 = cos_h ** 2
    a2 = alpha * alpha
    return np.where(cos_h > 0.0, a2 / (np.pi * (cos2 * (a2 - 1.0) + 1.0) ** 2), 0.0)


def ggx_lambda(cos_theta, alpha: float):
    """Smith Lambda of GGX: (sqrt(1 + alpha^2 tan^2(theta)) - 1) / 2 (isotropic: only the
    polar angle matters)."""
    cos2 = np.asarray(cos_theta, dtype=np.float64) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        tan2 = np.where(cos2 > 0.0, (1.0 - cos2) / cos2, np.inf)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


def ggx_G2(cos_o, cos_i, alpha: float):
    """Height-correlated Smith masking-shadowing, 1 / (1 + Lambda(wo) + Lambda(wi))."""
    return 1.0 / (1.0 + ggx_lambda(cos_o, alpha) + ggx_lambda(cos_i, alpha))


@functools.lru_cache(maxsize=None)
def _legendre(n: int):
    return np.polynomial.legendre.leggauss(n)  # O(n^3): computed once per n


def _nodes(n: int, lo: float, hi: float):
    x, w = _legendre(n)
    return lo + 0.5 * (hi - lo) * (x + 1.0), 0.5 * (hi - lo) * w


def ggx_directional_albedo(mu_o: float, alpha: float, n_theta: int = 1024, n_phi: int = 512) -> float:
    """E(mu_o, alpha) with F = 1, by Gauss-Legendre quadrature over (xi, phi) of the half vector."""
    if not (0.0 < mu_o <= 1.0) or alpha <= 0.0:
        raise ValueError("need 0 < mu_o <= 1 and alpha > 0")
    sin_o = np.sqrt(max(0.0, 1.0 - mu_o * mu_o))  # wo = (sin_o, 0, mu_o)
    xi, w_xi = _nodes(n_theta, 0.0, 1.0)
    phi, w_phi = _nodes(n_phi, 0.0, np.pi)
    tan_h = alpha * np.sqrt(xi / (1.0 - xi))
    cos_h = (1.0 / np.sqrt(1.0 + tan_h ** 2))[:, None]
    sin_h = tan_h[:, None] * cos_h
    wo_h = sin_o * sin_h * np.cos(phi)[None, :] + mu_o * cos_h
    cos_i = 2.0 * wo_h * cos_h - mu_o  # wi = 2 (wo.h) h - wo
    valid = (wo_h > 0.0) & (cos_i > 0.0)
    integrand = np.where(valid, ggx_G2(mu_o, np.where(valid, cos_i, 1.0), alpha) * wo_h / (mu_o * cos_h), 0.0)
    # phi over [0, pi] doubled for the other half, divided by 2 pi.
    return float(w_xi @ integrand @ w_phi / np.pi)


def ggx_directional_albedo_direct(mu_o: float, alpha: float, n_theta: int = 1024, n_phi: int = 512) -> float:
    """The same integral taken over wi in (cos theta_i, phi_i): only accurate for wide lobes
    (alpha >~ 0.3), used to check the change of variables above."""
    sin_o = np.sqrt(max(0.0, 1.0 - mu_o * mu_o))
    mu_i, w_mu = _nodes(n_theta, 0.0, 1.0)
    phi, w_phi = _nodes(n_phi, 0.0, np.pi)
    sin_i = np.sqrt(1.0 - mu_i ** 2)[:, None]
    wo_wi = sin_o * sin_i * np.cos(phi)[None, :] + mu_o * mu_i[:, None]
    cos_h = (mu_i[:, None] + mu_o) / np.sqrt(2.0 + 2.0 * wo_wi)  # h = (wo + wi) / |wo + wi|
    f_cos = ggx_D(cos_h, alpha) * ggx_G2(mu_o, mu_i[:, None], alpha) / (4.0 * mu_o)
    return float(2.0 * (w_mu @ f_cos @ w_phi))
