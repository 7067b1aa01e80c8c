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

import numpy as np


def ggx_D(h: np.ndarray, alpha: float) -> np.ndarray:
    """GGX normal distribution; h is (..., 3), unit."""
    cos2 = h[..., 2] ** 2
    a2 = alpha * alpha
    d = np.pi * (cos2 * (a2 - 1.0) + 1.0) ** 2
    return np.where(h[..., 2] > 0.0, a2 / d, 0.0)


def ggx_lambda(w: np.ndarray, alpha: float) -> np.ndarray:
    """Smith Lambda of GGX: (sqrt(1 + alpha^2 tan^2(theta)) - 1) / 2."""
    cos2 = w[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        tan2 = np.where(cos2 > 0.0, (1.0 - cos2) / cos2, np.inf)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


def ggx_G2(wo: np.ndarray, wi: np.ndarray, alpha: float) -> np.ndarray:
    """Height-correlated Smith masking-shadowing, 1 / (1 + Lambda(wo) + Lambda(wi))."""
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))


def _direction(mu: float) -> np.ndarray:
    return np.array([np.sqrt(max(0.0, 1.0 - mu * mu)), 0.0, mu])


def ggx_directional_albedo(mu_o: float, alpha: float, n_theta: int = 1024, n_phi: int = 512) -> float:
    """E(mu_o, alpha) with F = 1, by Gauss-Legendre quadrature over (xi, phi) of the half vector."""
    if not (0.0 < mu_o <= 1.0) or alpha <= 0.0:
        raise ValueError("need 0 < mu_o <= 1 and alpha > 0")
    wo = _direction(mu_o)
    x, wx = np.polynomial.legendre.leggauss(n_theta)
    y, wy = np.polynomial.legendre.leggauss(n_phi)
    xi, w_xi = 0.5 * (x + 1.0), 0.5 * wx                 # [0, 1]
    phi, w_phi = 0.5 * np.pi * (y + 1.0), 0.5 * np.pi * wy  # [0, pi]
    tan_h = alpha * np.sqrt(xi / (1.0 - xi))
    cos_h = 1.0 / np.sqrt(1.0 + tan_h ** 2)
    sin_h = tan_h * cos_h
    h = np.stack(np.broadcast_arrays(sin_h[:, None] * np.cos(phi)[None, :],
                                     sin_h[:, None] * np.sin(phi)[None, :],
                                     cos_h[:, None]), axis=-1)
    wo_h = h @ wo
    wi = 2.0 * wo_h[..., None] * h - wo
    valid = (wo_h > 0.0) & (wi[..., 2] > 0.0)
    integrand = np.where(valid, ggx_G2(wo, wi, alpha) * wo_h / (mu_o * cos_h[:, None]), 0.0)
    # Weights: xi, phi over [0, pi] doubled for the other half, divided by 2 pi.
    return float(w_xi @ integrand @ w_phi / np.pi)


def ggx_directional_albedo_direct(mu_o: float, alpha: float, n_theta: int = 512, n_phi: int = 256) -> float:
    """The same integral taken over wi in (cos theta_i, phi): only accurate for wide lobes
    (alpha >~ 0.3), used to check the change of variables above."""
    wo = _direction(mu_o)
    x, wx = np.polynomial.legendre.leggauss(n_theta)
    y, wy = np.polynomial.legendre.leggauss(n_phi)
    mu_i, w_mu = 0.5 * (x + 1.0), 0.5 * wx
    phi, w_phi = 0.5 * np.pi * (y + 1.0), 0.5 * np.pi * wy
    sin_i = np.sqrt(1.0 - mu_i ** 2)
    wi = np.stack(np.broadcast_arrays(sin_i[:, None] * np.cos(phi)[None, :],
                                      sin_i[:, None] * np.sin(phi)[None, :], mu_i[:, None]), axis=-1)
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    f_cos = ggx_D(h, alpha) * ggx_G2(wo, wi, alpha) / (4.0 * mu_o)
    return float(2.0 * (w_mu @ f_cos @ w_phi))
