"""White furnace tests of shaders/lift/bsdf.glsl: how much energy each BSDF reflects.

The Monte Carlo estimate of the directional albedo, the mean of bsdf_sample's weights
(a rejected sample counts as 0), is compared with a quadrature reference (furnace_reference.py,
numpy, independent of the shader) within z standard errors of the estimate, z from a Sidak
correction of SIGNIFICANCE over the cases (about 3.3 for 9 cases).
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

from furnace_reference import ggx_directional_albedo, ggx_directional_albedo_direct
from lift_gl.glsl_kernel import MAT_CONDUCTOR, MAT_DIELECTRIC, MAT_DIFFUSE, material
from test_bsdf_chi2 import sample, wo_from_cos

SAMPLES = 1 << 20
SIGNIFICANCE = 0.01


def z_score(cases: int) -> float:
    return float(stats.norm.isf(0.5 * (1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / cases))))


def furnace(mat, wo, count=SAMPLES, seed=11):
    """(per-sample weights with rejected samples as 0, wi, accepted mask)."""
    dirs, weights, _ = sample(mat, wo, count, seed=seed)
    ok = dirs[:, 3] > 0.0
    w = np.where(ok[:, None], weights[:, :3], 0.0).astype(np.float64)
    return w, dirs[:, :3].astype(np.float64), ok


# ---- the reference itself ------------------------------------------------------------------
@pytest.mark.parametrize("mu", [0.05, 0.3, 0.7, 1.0])
def test_reference_smooth_limit_is_one(mu):
    assert abs(ggx_directional_albedo(mu, 1e-3) - 1.0) < 1e-3


@pytest.mark.parametrize("mu", [0.3, 0.5, 0.7, 1.0])
def test_reference_at_most_one_and_decreasing_in_alpha(mu):
    alphas = [0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0]
    albedo = np.array([ggx_directional_albedo(mu, a, 512, 256) for a in alphas])
    assert (albedo <= 1.0 + 1e-9).all() and (albedo > 0.0).all()
    assert (np.diff(albedo) < 0.0).all(), dict(zip(alphas, albedo))


def test_reference_at_grazing_is_at_most_one():
    """At grazing incidence E is not monotonic in alpha (a dip near alpha ~ 0.05 for mu = 0.05,
    confirmed by the direct quadrature and by the shader's estimate below); only E <= 1 holds."""
    albedo = np.array([ggx_directional_albedo(0.05, a) for a in (0.01, 0.05, 0.1, 0.3, 1.0)])
    assert (albedo <= 1.0 + 1e-9).all() and (albedo > 0.5).all()


@pytest.mark.parametrize("mu,alpha", [(0.1, 0.3), (0.5, 0.5), (1.0, 1.0), (0.3, 0.7)])
def test_reference_change_of_variables(mu, alpha):
    """Half-vector quadrature = plain quadrature over wi, where the lobe is wide enough for
    the latter; and both are converged (doubling the nodes changes nothing that matters)."""
    e = ggx_directional_albedo(mu, alpha)
    assert abs(ggx_directional_albedo(mu, alpha, 512, 256) - e) < 1e-5
    assert abs(ggx_directional_albedo_direct(mu, alpha, 512, 256) - e) < 1e-5


# ---- the shader against the reference -------------------------------------------------------
CONDUCTOR_CASES = list(itertools.product([0.1, 0.5, 1.0], [0.05, 0.3, 1.0]))


@pytest.mark.parametrize("mu,alpha", CONDUCTOR_CASES)
def test_rough_conductor_furnace_matches_reference(mu, alpha):
    # Schlick with F0 = 1: Fresnel is exactly 1, so the mean weight estimates E(mu, alpha).
    mat = material(MAT_CONDUCTOR, color=(1.0, 1.0, 1.0), alpha=alpha, eta=(-1.0, -1.0, -1.0))
    w, _, _ = furnace(mat, wo_from_cos(mu))
    assert (w <= 1.0 + 1e-5).all(), "a GGX weight G2 / G1 exceeds 1"
    estimate = w[:, 0].mean()
    std_error = w[:, 0].std(ddof=1) / np.sqrt(len(w))
    reference = ggx_directional_albedo(mu, alpha)
    # 2e-5 bounds the quadrature error (see test_reference_change_of_variables).
    assert abs(estimate - reference) <= z_score(len(CONDUCTOR_CASES)) * std_error + 2e-5, (
        f"MC {estimate:.6f} +- {std_error:.2g}, quadrature {reference:.6f}")


@pytest.mark.parametrize("mu", [0.05, 0.5, 1.0])
def test_diffuse_albedo_one_conserves_energy(mu):
    w, _, ok = furnace(material(MAT_DIFFUSE, color=(1.0, 1.0, 1.0)), wo_from_cos(mu), 1 << 18)
    assert (w[ok] == 1.0).all(), "Lambert with albedo 1 must have weight exactly 1"
    # A point exactly on the disk's rim gives wi.z = 0 and is rejected: at most a few per million.
    assert ok.mean() > 1.0 - 1e-5


DIELECTRIC_CASES = list(itertools.product([0.1, 0.3, 0.7], [0.05, 0.3, 1.0], ["outside", "inside"]))


@pytest.mark.parametrize("alpha,mu,side", DIELECTRIC_CASES)
def test_rough_dielectric_loses_energy_only_to_single_scattering(alpha, mu, side):
    """Reflected plus transmitted energy <= 1. Transmitted weights carry the radiance scaling
    1 / etap^2 (bsdf.glsl's convention), which moves radiance, not energy; it is undone here."""
    ior = 1.5
    wo = wo_from_cos(mu, side == "inside")
    w, wi, ok = furnace(material(MAT_DIELECTRIC, color=(1.0, 1.0, 1.0), alpha=alpha, ior=ior), wo)
    transmitted = ok & (wi[:, 2] * wo[2] < 0.0)
    etap = ior if wo[2] > 0.0 else 1.0 / ior
    energy = np.where(transmitted, w[:, 0] * etap ** 2, w[:, 0])
    assert (energy <= 1.0 + 1e-5).all(), "a sample's weight G2 / G1 exceeds 1"
    estimate = energy.mean()
    std_error = energy.std(ddof=1) / np.sqrt(len(energy))
    assert estimate <= 1.0 + z_score(len(DIELECTRIC_CASES)) * std_error
    # A loose floor: single-scattering losses of GGX stay well under half at these roughnesses.
    assert estimate > 0.5


@pytest.mark.parametrize("mu,side", list(itertools.product([0.05, 0.5, 1.0], ["outside", "inside"])))
def test_smooth_dielectric_conserves_energy(mu, side):
    ior = 1.5
    wo = wo_from_cos(mu, side == "inside")
    w, wi, ok = furnace(material(MAT_DIELECTRIC, color=(1.0, 1.0, 1.0), alpha=0.0, ior=ior), wo, 1 << 16)
    assert ok.all()
    etap = ior if wo[2] > 0.0 else 1.0 / ior
    energy = np.where(wi[:, 2] * wo[2] < 0.0, w[:, 0] * etap ** 2, w[:, 0])
    np.testing.assert_allclose(energy, 1.0, rtol=1e-5)
