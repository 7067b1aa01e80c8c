"""Rough conductors with a Beckmann distribution (HAS_BECKMANN, a negative alpha in the
material): the distribution's normalisation, and bsdf_sample against bsdf_pdf by the
chi-square test of tests/test_bsdf_chi2.py (lift_gl.chi2)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from lift_gl.chi2 import pearson_chi2, sphere_histogram
from lift_gl.glsl_kernel import ALL_MATERIALS, MAT_CONDUCTOR, Kernel, material
from lift_gl.warp_kernels import BSDF_GRID, bsdf_cell_integrals
from test_bsdf_chi2 import GOLD_ETA, GOLD_K, REL_TOL, sample, wo_from_cos

DEFINES = {**ALL_MATERIALS, "HAS_BECKMANN": True}
SAMPLES = 1 << 19
SIGNIFICANCE = 0.01
CASES = list(itertools.product((0.05, 0.25, 0.6), (0.2, 0.7, 1.0)))
CASE_SIGNIFICANCE = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / len(CASES))

D_KERNEL = """
layout(std430, binding = 10) readonly buffer Dirs { vec4 dirs[]; };
layout(std430, binding = 11) writeonly buffer Out { float d_cos[]; };
uniform float u_alpha;
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    d_cos[i] = beckmann_D(dirs[i].xyz, u_alpha) * dirs[i].z;
}
"""


@pytest.mark.parametrize("alpha", [0.02, 0.1, 0.5, 1.0])
def test_beckmann_distribution_projects_to_unit_area(alpha):
    """The integral of D(m) cos(m) over the hemisphere is 1 (microfacets cover the surface
    once); Gauss-Legendre in tan(theta)-adapted cos(theta), which the narrow lobes need."""
    nodes, weights = np.polynomial.legendre.leggauss(400)
    # cos(theta) = 1 / sqrt(1 + t^2) with t = tan(theta) in [0, 12 alpha]: the rest is < e^-144.
    t = 6 * alpha * (nodes + 1)
    dcos_dt = t / (1 + t * t) ** 1.5
    c = 1 / np.sqrt(1 + t * t)
    dirs = np.stack([np.sqrt(1 - c * c), np.zeros_like(c), c, np.zeros_like(c)], 1).astype(np.float32)
    out = Kernel(D_KERNEL, DEFINES).run(len(dirs), inputs={10: dirs}, outputs={11: (len(dirs),)},
                                        uniforms={"u_alpha": alpha})[11].astype(np.float64)
    total = 2 * np.pi * np.sum(weights * 6 * alpha * out * dcos_dt)
    assert total == pytest.approx(1.0, abs=2e-4)


@pytest.mark.parametrize("alpha,cos_o", CASES)
def test_beckmann_conductor_samples_match_pdf(alpha, cos_o):
    mat = material(MAT_CONDUCTOR, alpha=-alpha, eta=GOLD_ETA, k=GOLD_K)
    wo = wo_from_cos(cos_o)
    dirs, weights, evals = sample(mat, wo, SAMPLES, defines=DEFINES)
    ok = dirs[:, 3] > 0.0
    integrals = bsdf_cell_integrals(mat, wo, SAMPLES, DEFINES)
    total = integrals.sum()
    assert 0.5 < total <= 1.0 + 1e-3
    observed = np.append(sphere_histogram(dirs[ok, :3], BSDF_GRID).ravel(), SAMPLES - ok.sum())
    expected = np.append(integrals.ravel() * SAMPLES, max(0.0, SAMPLES * (1.0 - total)))
    statistic, dof, p = pearson_chi2(observed, expected)
    assert p > CASE_SIGNIFICANCE, f"chi2 = {statistic:.1f}, {dof} dof, p = {p:.3g}"
    np.testing.assert_allclose(weights[ok, :3], evals[ok, :3] / evals[ok, 3:4], rtol=REL_TOL, atol=1e-6)
    np.testing.assert_allclose(evals[ok, 3], dirs[ok, 3], rtol=REL_TOL)


def test_beckmann_and_ggx_differ_only_when_asked():
    """The same alpha with and without the Beckmann mark: different lobes (Beckmann's tail
    is lighter), and a shader without HAS_BECKMANN treats the material as GGX."""
    wo = wo_from_cos(1.0)
    ggx = material(MAT_CONDUCTOR, alpha=0.2, eta=GOLD_ETA, k=GOLD_K)
    beck = material(MAT_CONDUCTOR, alpha=-0.2, eta=GOLD_ETA, k=GOLD_K)
    tail = (np.sin(np.radians(50)), 0.0, np.cos(np.radians(50)))
    kernel = """
layout(std430, binding = 10) writeonly buffer Out { vec4 result[]; };
uniform vec3 u_wo;
uniform vec3 u_wi;
void main() { if (invocation_index() == 0u) result[0] = vec4(bsdf_eval(test_material(), u_wo, u_wi), 0.0); }
"""
    def f(mat, defines):
        return Kernel(kernel, defines).run(1, outputs={10: (1, 4)},
                                           uniforms={"u_material": mat, "u_wo": wo, "u_wi": tail})[10][0, 0]
    assert f(beck, DEFINES) < 0.2 * f(ggx, DEFINES)
    assert f(beck, ALL_MATERIALS) == f(ggx, ALL_MATERIALS)
