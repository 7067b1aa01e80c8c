"""The plastic BSDF (shaders/lift/bsdf.glsl, HAS_PLASTIC / HAS_ROUGH_PLASTIC): does
bsdf_sample draw what bsdf_pdf claims (chi-square, as tests/test_bsdf_chi2.py does it for
the other materials), and does the layered model reflect the energy its physics says?

Energy, independently of the shader: light entering the coat (transmittance 1 - F) reaches
the base, which reflects Rd; the coat sends back down the fraction Fdr of the diffuse light
that reaches it from below, and so on. Summing the series, the directional albedo of the
smooth plastic is F(cos_o) + (1 - F(cos_o)) Rd (1 - Fdr) / (1 - Rd Fdr) ("nonlinear"), so
exactly 1 for a white base. Fdr is checked against its definition by a separate quadrature.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

from lift_gl.chi2 import pearson_chi2, sphere_histogram
from lift_gl.glsl_kernel import MAT_PLASTIC, Kernel
from lift_gl.scene.optics import fresnel_dielectric, internal_diffuse_reflectance
from lift_gl.warp_kernels import BSDF_GRID, bsdf_cell_integrals
from test_bsdf_chi2 import REL_TOL, sample, wo_from_cos

PLASTIC = {"HAS_PLASTIC": True, "HAS_ROUGH_PLASTIC": True}
SAMPLES = 1 << 19
SIGNIFICANCE = 0.01


def plastic(rd=(0.8, 0.5, 0.3), alpha=0.0, ior=1.5, tint=(1.0, 1.0, 1.0), nonlinear=False,
            fdr=None) -> np.ndarray:
    fdr = internal_diffuse_reflectance(ior) if fdr is None else fdr
    return np.array([[*rd, MAT_PLASTIC], [0, 0, 0, alpha], [fdr, float(nonlinear), 0, ior], [*tint, 0]],
                    dtype=np.float32)


ROUGH_CASES = [(a, c) for a, c in itertools.product((0.05, 0.3, 0.8), (0.15, 0.6, 1.0))]
ROUGH_SIGNIFICANCE = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / len(ROUGH_CASES))


@pytest.mark.parametrize("alpha,cos_o", ROUGH_CASES)
def test_rough_plastic_samples_match_pdf(alpha, cos_o):
    mat, wo = plastic(alpha=alpha), wo_from_cos(cos_o)
    dirs, weights, evals = sample(mat, wo, SAMPLES, defines=PLASTIC)
    ok = dirs[:, 3] > 0.0
    integrals = bsdf_cell_integrals(mat, wo, SAMPLES, PLASTIC)
    total = integrals.sum()
    assert total <= 1.0 + 1e-3
    observed = np.append(sphere_histogram(dirs[ok, :3], BSDF_GRID).ravel(), SAMPLES - ok.sum())
    expected = np.append(integrals.ravel() * SAMPLES, max(0.0, SAMPLES * (1.0 - total)))
    statistic, dof, p = pearson_chi2(observed, expected)
    assert p > ROUGH_SIGNIFICANCE, f"chi2 = {statistic:.1f}, {dof} dof, p = {p:.3g}"
    assert not weights[ok, 3].any(), "a rough coat returned a delta sample"
    assert (dirs[ok, 2] > 0).all(), "plastic is opaque: no direction below the surface"
    # Each sample: weight = eval / pdf and the sample's pdf = bsdf_pdf.
    np.testing.assert_allclose(weights[ok, :3], evals[ok, :3] / evals[ok, 3:4], rtol=REL_TOL, atol=1e-6)
    np.testing.assert_allclose(evals[ok, 3], dirs[ok, 3], rtol=REL_TOL)


SMOOTH_CASES = [0.05, 0.4, 1.0]


@pytest.mark.parametrize("cos_o", SMOOTH_CASES)
def test_smooth_plastic_diffuse_samples_match_pdf_and_mirror_is_fresnel(cos_o):
    tint = np.array([0.9, 0.7, 1.0])
    mat, wo = plastic(tint=tint), wo_from_cos(cos_o)
    dirs, weights, evals = sample(mat, wo, SAMPLES, defines=PLASTIC)
    assert (dirs[:, 3] > 0).all(), "every smooth-plastic sample succeeds"
    delta = weights[:, 3] == 1.0
    # ---- the mirror: chosen with probability P, weight tint F / P ----
    F = float(fresnel_dielectric(cos_o, 1.5))
    s, d = F * tint.mean(), (1 - F) * np.mean([0.8, 0.5, 0.3])
    P = np.clip(s / (s + d), 0.1, 0.9)
    p_binom = stats.binomtest(int(delta.sum()), SAMPLES, P).pvalue
    assert p_binom > SIGNIFICANCE / len(SMOOTH_CASES), (delta.mean(), P)
    np.testing.assert_allclose(dirs[delta, :3], np.tile([-wo[0], -wo[1], wo[2]], (delta.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(weights[delta, :3], np.tile(tint * F / P, (delta.sum(), 1)), rtol=1e-4)
    np.testing.assert_allclose(dirs[delta, 3], P, rtol=1e-5)
    # ---- the diffuse part: histogram against the integral of bsdf_pdf (which is 1 - P) ----
    integrals = bsdf_cell_integrals(mat, wo, SAMPLES, PLASTIC)
    assert abs(integrals.sum() - (1 - P)) < 1e-3
    observed = np.append(sphere_histogram(dirs[~delta, :3], BSDF_GRID).ravel(), delta.sum())
    expected = np.append(integrals.ravel() * SAMPLES, SAMPLES * P)
    statistic, dof, p = pearson_chi2(observed, expected)
    assert p > SIGNIFICANCE / len(SMOOTH_CASES), f"chi2 = {statistic:.1f}, {dof} dof, p = {p:.3g}"
    np.testing.assert_allclose(weights[~delta, :3], evals[~delta, :3] / evals[~delta, 3:4], rtol=REL_TOL)


# ---- energy ------------------------------------------------------------------------------
EVAL_KERNEL = """
layout(std430, binding = 10) readonly buffer Dirs { vec4 dirs[]; };
layout(std430, binding = 11) writeonly buffer Evals { vec4 evals[]; };
uniform vec3 u_wo;
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    evals[i] = vec4(bsdf_eval(test_material(), u_wo, dirs[i].xyz), bsdf_pdf(test_material(), u_wo, dirs[i].xyz));
}
"""


def hemisphere_albedo(mat, wo, n_cos=96, n_phi=1):
    """Integral of bsdf_eval (which includes cos_i) over the hemisphere by Gauss-Legendre in
    cos(theta) (and in phi, when the lobe depends on it)."""
    mu, wmu = np.polynomial.legendre.leggauss(n_cos)
    mu, wmu = 0.5 * mu + 0.5, 0.5 * wmu
    if n_phi == 1:
        phi, wphi = np.zeros(1), np.array([2 * np.pi])
    else:
        phi, wphi = np.polynomial.legendre.leggauss(n_phi)
        phi, wphi = np.pi * phi + np.pi, np.pi * wphi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - m ** 2)
    dirs = np.stack([s * np.cos(p), s * np.sin(p), m, np.zeros_like(m)], axis=-1).reshape(-1, 4).astype(np.float32)
    out = Kernel(EVAL_KERNEL, PLASTIC).run(len(dirs), inputs={10: dirs}, outputs={11: (len(dirs), 4)},
                                           uniforms={"u_material": mat, "u_wo": wo})[11]
    f = out[:, :3].reshape(n_cos, n_phi, 3).astype(np.float64)
    return np.einsum("i,j,ijc->c", wmu, wphi, f)


def test_internal_diffuse_reflectance_matches_its_definition():
    # An independent estimate: midpoint rule on a fine grid of the cosine-weighted average.
    for ior in (1.33, 1.5, 2.0):
        mu = (np.arange(200000) + 0.5) / 200000
        expected = np.mean(2 * mu * fresnel_dielectric(mu, 1.0 / ior))
        assert internal_diffuse_reflectance(ior) == pytest.approx(expected, abs=1e-6)
    # Known value: about 0.596 for ior 1.5 (e.g. Egan-Hilgeman's fit gives 0.597).
    assert internal_diffuse_reflectance(1.5) == pytest.approx(0.596, abs=2e-3)


@pytest.mark.parametrize("ior", [1.3, 1.5, 2.2])
@pytest.mark.parametrize("cos_o", [0.1, 0.5, 1.0])
def test_smooth_plastic_albedo_is_the_layered_sum(ior, cos_o):
    wo = wo_from_cos(cos_o)
    F = float(fresnel_dielectric(cos_o, ior))
    fdr = internal_diffuse_reflectance(ior)
    for rd, nonlinear in ((1.0, False), (1.0, True), (0.5, True)):
        mat = plastic(rd=(rd, rd, rd), ior=ior, nonlinear=nonlinear)
        diffuse = hemisphere_albedo(mat, wo)
        expected = (1 - F) * rd * (1 - fdr) / (1 - rd * fdr)
        np.testing.assert_allclose(diffuse, expected, rtol=2e-4)
        if rd == 1.0:  # a white base under a clear coat reflects everything
            np.testing.assert_allclose(diffuse + F, 1.0, rtol=2e-4)
    # The linear variant scales Rd by 1 / (1 - Fdr) instead.
    diffuse = hemisphere_albedo(plastic(rd=(0.5, 0.5, 0.5), ior=ior), wo)
    np.testing.assert_allclose(diffuse, (1 - F) * 0.5, rtol=2e-4)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0])
@pytest.mark.parametrize("cos_o", [0.1, 0.5, 1.0])
def test_rough_white_plastic_reflects_at_most_everything(alpha, cos_o):
    """The albedo by importance sampling: the mean sample weight (rejected samples count 0),
    whose sampler the chi-square tests above vouch for. A narrow lobe at grazing angles
    defeats quadrature, not this."""
    dirs, weights, _ = sample(plastic(rd=(1, 1, 1), alpha=alpha), wo_from_cos(cos_o), SAMPLES, seed=3,
                              defines=PLASTIC)
    w = np.where(dirs[:, 3:4] > 0, weights[:, :3], 0.0).astype(np.float64)[:, 0]
    albedo, se = w.mean(), w.std() / np.sqrt(len(w))
    # The smooth coat's transmittance stands in for the rough one's (bsdf.glsl): near normal
    # incidence the rough coat reflects slightly more than F(cos_o), a gain measured below
    # 4e-4 (8M samples); allow 1e-3.
    assert albedo <= 1.0 + 1e-3 + 4 * se, (albedo, se)
    # The diffuse part alone reflects 1 - F(cos_o) for a white base, whatever the roughness;
    # the specular lobe adds to it (masking makes it lose most at grazing angles).
    assert albedo >= 1.0 - float(fresnel_dielectric(cos_o, 1.5)) - 4 * se, (albedo, se)
