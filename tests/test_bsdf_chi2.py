"""Statistical tests of shaders/lift/bsdf.glsl: does bsdf_sample draw directions with the
density bsdf_pdf claims?

Chi-square goodness of fit, as Mitsuba 3's `chi2` test does it: N directions are sampled in a
shader and histogrammed on a (cos theta, phi) grid over the whole sphere; the expected count
of each cell is N times the integral of bsdf_pdf over the cell (adaptive Gauss-Legendre in a
shader: lift_gl.chi2 and lift_gl.warp_kernels, which `lift-gl warptest` runs too); cells expecting fewer than 5 samples are pooled; samples that
bsdf_sample rejects form one more cell (expected: N (1 - integral of the pdf)). The p-value of
Pearson's statistic is compared with a significance level corrected for the number of cases
(Sidak), so the whole file fails by chance with probability SIGNIFICANCE.

Besides the fit: each sample's weight must equal bsdf_eval / bsdf_pdf, and the pdf a sample
reports must equal bsdf_pdf; the delta lobes (smooth conductor, smooth glass) are checked
against the analytic directions and Fresnel reflectances.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

from lift_gl.chi2 import pearson_chi2, sphere_histogram
from lift_gl.errors import ShaderError
from lift_gl.glsl_kernel import ALL_MATERIALS, MAT_CONDUCTOR, MAT_DIELECTRIC, MAT_DIFFUSE, Kernel, material
from lift_gl.warp_kernels import BSDF_GRID, bsdf_cell_integrals

SAMPLES = 1 << 20
SIGNIFICANCE = 0.01
# Float32 evaluation of the same expressions along two paths (sample vs eval/pdf).
REL_TOL = 2e-3

COS_O = (0.05, 0.3, 0.7, 1.0)
CONDUCTOR_ALPHAS = (0.05, 0.2, 0.5, 1.0)
DIELECTRIC_ALPHAS = (0.1, 0.3, 0.7)
IOR = 1.5
GOLD_ETA, GOLD_K = (0.143, 0.374, 1.442), (3.983, 2.385, 1.603)  # at ~ 650, 550, 450 nm


def wo_from_cos(cos_o: float, inside: bool = False) -> tuple:
    sin_o = np.sqrt(max(0.0, 1.0 - cos_o * cos_o))
    return (float(sin_o), 0.0, float(-cos_o if inside else cos_o))


# (id, material, wo): every case of the goodness-of-fit test.
CASES = (
    [(f"diffuse-cos{c}", material(MAT_DIFFUSE, color=(0.8, 0.6, 0.4)), wo_from_cos(c)) for c in COS_O]
    + [(f"conductor-a{a}-cos{c}", material(MAT_CONDUCTOR, alpha=a, eta=GOLD_ETA, k=GOLD_K), wo_from_cos(c))
       for a, c in itertools.product(CONDUCTOR_ALPHAS, COS_O)]
    + [(f"dielectric-a{a}-{side}-cos{c}", material(MAT_DIELECTRIC, color=(0.9, 0.8, 1.0), alpha=a, ior=IOR),
        wo_from_cos(c, side == "inside"))
       for a, side, c in itertools.product(DIELECTRIC_ALPHAS, ("outside", "inside"), COS_O)]
)
CASE_SIGNIFICANCE = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / len(CASES))

SAMPLE_KERNEL = """
layout(std430, binding = 10) writeonly buffer SampleDir { vec4 sample_dir[]; };  // wi, pdf (-1: none)
layout(std430, binding = 11) writeonly buffer SampleWeight { vec4 sample_weight[]; };  // weight, is_delta
layout(std430, binding = 12) writeonly buffer SampleEval { vec4 sample_eval[]; };  // eval(wi), pdf(wi)
uniform vec3 u_wo;
uniform uint u_seed;
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    Material m = test_material();
    Rng rng = rng_init(uvec2(i, 0u), 0u, 0u, u_seed);
    BsdfSample s;
    bool ok = bsdf_sample(m, u_wo, rng_next3(rng), s);
    sample_dir[i] = vec4(s.wi, ok ? s.pdf : -1.0);
    sample_weight[i] = vec4(s.weight, s.is_delta ? 1.0 : 0.0);
    sample_eval[i] = vec4(bsdf_eval(m, u_wo, s.wi), bsdf_pdf(m, u_wo, s.wi));
}
"""

def sample(mat, wo, count=SAMPLES, seed=7, defines=ALL_MATERIALS):
    out = Kernel(SAMPLE_KERNEL, defines).run(
        count, outputs={10: (count, 4), 11: (count, 4), 12: (count, 4)},
        uniforms={"u_material": mat, "u_wo": wo, "u_seed": seed})
    return out[10], out[11], out[12]


@pytest.mark.parametrize("name,mat,wo", CASES, ids=[c[0] for c in CASES])
def test_sample_matches_pdf(name, mat, wo):
    dirs, weights, evals = sample(mat, wo)
    ok = dirs[:, 3] > 0.0
    assert ok.any(), "bsdf_sample produced no samples"
    integrals = bsdf_cell_integrals(mat, wo, SAMPLES)
    total = integrals.sum()
    assert total <= 1.0 + 1e-3, f"bsdf_pdf integrates to {total} > 1"
    observed = sphere_histogram(dirs[ok, :3], BSDF_GRID)
    expected = integrals * SAMPLES
    # Samples in cells where the pdf is zero everywhere are an error in their own right.
    impossible = observed[integrals == 0.0].sum()
    assert impossible == 0, f"{impossible:.0f} samples where bsdf_pdf is 0"
    # The rejected samples: one more cell.
    observed = np.append(observed.ravel(), SAMPLES - ok.sum())
    expected = np.append(expected.ravel(), max(0.0, SAMPLES * (1.0 - total)))
    statistic, dof, p = pearson_chi2(observed, expected)
    assert p > CASE_SIGNIFICANCE, (f"chi2 = {statistic:.1f} with {dof} dof, p = {p:.3g} < {CASE_SIGNIFICANCE:.3g}; "
                                   f"pdf integral {total:.5f}, accepted {ok.mean():.5f}")

    # ---- each sample: weight = eval / pdf, sample pdf = bsdf_pdf ----
    assert not weights[ok, 3].any(), "a rough lobe returned is_delta"
    assert np.isfinite(weights[ok, :3]).all() and (weights[ok, :3] >= 0.0).all()
    pdf_sample, pdf_eval = dirs[ok, 3].astype(np.float64), evals[ok, 3].astype(np.float64)
    assert (pdf_eval > 0.0).all(), "bsdf_pdf is 0 at a direction bsdf_sample produced"
    # Same microfacet normal on both sides of the ratio (eval and pdf both rebuild it from wo
    # and wi), so the Fresnel terms cancel and float32 rounding is all that is left.
    expected_weight = evals[ok, :3] / pdf_eval[:, None]
    np.testing.assert_allclose(weights[ok, :3], expected_weight, rtol=REL_TOL, atol=1e-6,
                               err_msg="weight != bsdf_eval / bsdf_pdf")
    # The sample's pdf uses the sampled normal, bsdf_pdf the rebuilt one: near the critical
    # angle, dF/dcos is unbounded and a rounding of the normal moves F by more than REL_TOL.
    # Those few samples are left out of the comparison (and counted).
    well_conditioned = critical_margin(np.array(wo), dirs[ok, :3].astype(np.float64), mat) > CRITICAL_MARGIN
    assert well_conditioned.mean() > 0.99
    np.testing.assert_allclose(pdf_eval[well_conditioned], pdf_sample[well_conditioned], rtol=REL_TOL,
                               err_msg="bsdf_pdf != BsdfSample.pdf")


# Float32 rounding moves sin^2(theta_t) by ~1e-6; near total internal reflection, 1 - F goes
# like sqrt(1 - sin^2(theta_t)), so its relative error is ~ 5e-7 / margin: below REL_TOL / 4
# when the margin exceeds 1e-3.
CRITICAL_MARGIN = 1e-3


def critical_margin(wo: np.ndarray, wi: np.ndarray, mat: np.ndarray) -> np.ndarray:
    """|1 - sin^2(theta_t)| at the microfacet normal that maps wo to wi (dielectrics only)."""
    if int(mat[0, 3]) != MAT_DIELECTRIC:
        return np.full(len(wi), np.inf)
    ior = float(mat[2, 3])
    eta_wo = ior if wo[2] > 0 else 1.0 / ior
    reflect = wi[:, 2] * wo[2] > 0
    etap = np.where(reflect, 1.0, eta_wo)
    h = wi * etap[:, None] + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    cos_h = np.abs(h @ wo)
    return np.abs(1.0 - (1.0 - cos_h ** 2) / eta_wo ** 2)


# ---- delta lobes: compared with analytic Fresnel (numpy, independent of the shader) --------
def fresnel_dielectric_np(cos_i: float, eta: float) -> float:
    if cos_i < 0.0:
        cos_i, eta = -cos_i, 1.0 / eta
    sin2_t = (1.0 - cos_i ** 2) / eta ** 2
    if sin2_t >= 1.0:
        return 1.0
    cos_t = np.sqrt(1.0 - sin2_t)
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (r_s ** 2 + r_p ** 2)


def fresnel_conductor_np(cos_i: float, eta, k) -> np.ndarray:
    """Complex Snell's law and the Fresnel amplitudes, in complex arithmetic."""
    n = np.asarray(eta) + 1j * np.asarray(k)
    sin2_i = 1.0 - cos_i ** 2
    cos_t = np.sqrt(1.0 - sin2_i / n ** 2)
    r_s = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


DELTA_COUNT = 1 << 16


@pytest.mark.parametrize("cos_o", COS_O)
@pytest.mark.parametrize("schlick", [False, True], ids=["exact", "schlick"])
def test_smooth_conductor_is_fresnel_mirror(cos_o, schlick):
    f0 = (0.9, 0.6, 0.3)
    mat = (material(MAT_CONDUCTOR, color=f0, alpha=0.0) if schlick
           else material(MAT_CONDUCTOR, alpha=0.0, eta=GOLD_ETA, k=GOLD_K))
    wo = wo_from_cos(cos_o)
    dirs, weights, evals = sample(mat, wo, DELTA_COUNT)
    assert (dirs[:, 3] > 0).all()
    np.testing.assert_allclose(dirs[:, :3], np.tile([-wo[0], -wo[1], wo[2]], (DELTA_COUNT, 1)), atol=1e-6)
    assert (weights[:, 3] == 1.0).all(), "a mirror sample must be marked delta"
    if schlick:
        expected = np.array(f0) + (1.0 - np.array(f0)) * (1.0 - cos_o) ** 5
    else:
        expected = fresnel_conductor_np(cos_o, GOLD_ETA, GOLD_K)
    np.testing.assert_allclose(weights[:, :3], np.tile(expected, (DELTA_COUNT, 1)), rtol=1e-4, atol=1e-6)
    assert (evals == 0.0).all(), "bsdf_eval and bsdf_pdf must be 0 for a delta lobe"


SMOOTH_GLASS_CASES = [(c, side) for c in COS_O + (0.5,) for side in ("outside", "inside")]
SMOOTH_GLASS_SIGNIFICANCE = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / len(SMOOTH_GLASS_CASES))


@pytest.mark.parametrize("cos_o,side", SMOOTH_GLASS_CASES)
def test_smooth_dielectric_directions_and_fresnel(cos_o, side):
    tint = np.array([0.9, 0.8, 1.0])
    mat = material(MAT_DIELECTRIC, color=tint, alpha=0.0, ior=IOR)
    wo = np.array(wo_from_cos(cos_o, side == "inside"))
    dirs, weights, evals = sample(mat, tuple(wo), DELTA_COUNT)
    assert (dirs[:, 3] > 0).all() and (weights[:, 3] == 1.0).all()
    assert (evals == 0.0).all(), "bsdf_eval and bsdf_pdf must be 0 for a delta lobe"
    wi = dirs[:, :3].astype(np.float64)
    reflected = wi[:, 2] * wo[2] > 0
    F = fresnel_dielectric_np(wo[2], IOR)
    etap = IOR if wo[2] > 0 else 1.0 / IOR

    # ---- the discrete choice: binomial with probability F ----
    k = int(reflected.sum())
    p = stats.binomtest(k, DELTA_COUNT, F).pvalue if 0.0 < F < 1.0 else float(k == DELTA_COUNT * (F == 1.0))
    assert p > SMOOTH_GLASS_SIGNIFICANCE, f"{k} reflections of {DELTA_COUNT}, Fresnel {F:.5f}"
    np.testing.assert_allclose(dirs[reflected, 3], F, rtol=1e-4)
    np.testing.assert_allclose(dirs[~reflected, 3], 1.0 - F, rtol=1e-4, atol=1e-6)

    # ---- directions: mirror; Snell's law with the azimuth turned by pi ----
    np.testing.assert_allclose(wi[reflected], np.tile([-wo[0], -wo[1], wo[2]], (k, 1)), atol=1e-6)
    np.testing.assert_allclose(weights[reflected, :3], 1.0, rtol=1e-6)
    if k < DELTA_COUNT:
        refracted = wi[~reflected]
        sin_o = np.hypot(wo[0], wo[1])
        sin_t = np.hypot(refracted[:, 0], refracted[:, 1])
        np.testing.assert_allclose(sin_t * etap, sin_o, atol=1e-5)
        assert (np.sign(refracted[:, 2]) == -np.sign(wo[2])).all()
        if sin_o > 0:
            np.testing.assert_allclose(refracted[:, 0] / sin_t, -wo[0] / sin_o, atol=1e-5)
        # Radiance transport: the transmitted weight is tint / etap^2.
        np.testing.assert_allclose(weights[~reflected, :3], np.tile(tint / etap ** 2, (DELTA_COUNT - k, 1)),
                                   rtol=1e-5)


# ---- compile-time features ---------------------------------------------------------------
FLAGS = ("HAS_CONDUCTOR", "HAS_ROUGH_CONDUCTOR", "HAS_DIELECTRIC", "HAS_ROUGH_DIELECTRIC")


@pytest.mark.parametrize("flags", [c for r in range(len(FLAGS) + 1) for c in itertools.combinations(FLAGS, r)],
                         ids=lambda c: "+".join(f.removeprefix("HAS_") for f in c) or "diffuse-only")
def test_every_variant_compiles_and_runs(flags):
    dirs, weights, _ = sample(material(MAT_DIFFUSE), (0.0, 0.0, 1.0), 256, defines={f: True for f in flags})
    assert (dirs[:, 3] > 0).all() and np.allclose(weights[:, :3], 1.0)


# A function of each material's code, and the define set under which it must exist.
MATERIAL_FUNCTIONS = {
    "conductor_smooth_sample(m, u_wo, s)": ("HAS_CONDUCTOR",),
    "conductor_rough_sample(m, u_wo, vec2(0.5), s)": ("HAS_ROUGH_CONDUCTOR",),
    "dielectric_smooth_sample(m, u_wo, 0.5, s)": ("HAS_DIELECTRIC",),
    "dielectric_rough_sample(m, u_wo, vec3(0.5), s)": ("HAS_ROUGH_DIELECTRIC",),
}


@pytest.mark.parametrize("call", list(MATERIAL_FUNCTIONS), ids=lambda c: c.split("(")[0])
def test_material_code_exists_only_under_its_define(call):
    kernel = SAMPLE_KERNEL.replace("bool ok = bsdf_sample(m, u_wo, rng_next3(rng), s);", f"bool ok = {call};")
    assert kernel != SAMPLE_KERNEL
    with pytest.raises(ShaderError):
        Kernel(kernel, {})  # diffuse-only: no conductor or glass code at all
    others = {f: True for f in FLAGS if f not in MATERIAL_FUNCTIONS[call] and "ROUGH" not in f}
    if "ROUGH" in MATERIAL_FUNCTIONS[call][0]:
        with pytest.raises(ShaderError):  # the smooth variant's define is not enough
            Kernel(kernel, {MATERIAL_FUNCTIONS[call][0].replace("ROUGH_", ""): True})
    Kernel(kernel, {MATERIAL_FUNCTIONS[call][0]: True, **others})


def test_uncompiled_material_reflects_nothing():
    """A conductor in a shader built without HAS_CONDUCTOR gives no sample, not garbage."""
    dirs, weights, evals = sample(material(MAT_CONDUCTOR, alpha=0.3), (0.0, 0.0, 1.0), 256, defines={})
    assert (dirs[:, 3] < 0).all() and (weights[:, :3] == 0).all() and (evals == 0).all()


# ---- the building blocks: frame, warps and their pdfs, MIS weights ---------------------------
HELPERS_KERNEL = """
#include "lift/frame.glsl"
layout(std430, binding = 10) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, binding = 11) writeonly buffer Outputs { vec4 outputs[]; };
uniform int u_mode;
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    vec4 x = inputs[i];
    vec4 result = vec4(0.0);
    if (u_mode == 0) {         // a frame round trip: (|t x b - n|, to_world(to_local(v)) error, t.n, b.n)
        Frame f = frame_from_normal(normalize(x.xyz));
        vec3 v = vec3(0.3, -0.5, 0.8);
        result = vec4(length(cross(f.t, f.b) - f.n), length(to_world(f, to_local(f, v)) - v),
                      dot(f.t, f.n), dot(f.b, f.n));
    } else if (u_mode == 1) {  // uniform sphere: direction, pdf
        vec3 w = sample_uniform_sphere(x.xy);
        result = vec4(w, pdf_uniform_sphere(w));
    } else if (u_mode == 2) {  // uniform triangle: barycentrics (b1, b2)
        result = vec4(sample_uniform_triangle(x.xy), 0.0, 0.0);
    } else if (u_mode == 3) {  // power heuristic
        result = vec4(power_heuristic(x.x, x.y), 0.0, 0.0, 0.0);
    } else {                   // concentric disk: point, pdf
        result = vec4(sample_concentric_disk(x.xy), pdf_concentric_disk(), 0.0);
    }
    outputs[i] = result;
}
"""


def run_helper(mode: int, inputs: np.ndarray) -> np.ndarray:
    inputs = np.asarray(inputs, dtype=np.float32)
    inputs = np.pad(inputs, ((0, 0), (0, 4 - inputs.shape[1])))
    out = Kernel(HELPERS_KERNEL, {}).run(len(inputs), inputs={10: inputs}, outputs={11: (len(inputs), 4)},
                                         uniforms={"u_mode": mode})
    return out[11]


def uniform_square(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).random((n, 2), dtype=np.float32)


HELPER_SIGNIFICANCE = SIGNIFICANCE / 3  # three goodness-of-fit tests below (Bonferroni)


def test_frame_is_orthonormal_and_round_trips():
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(4096, 3))
    normals = np.concatenate([normals, [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 0, -1 + 1e-7], [1e-8, 0, -1]]])
    out = run_helper(0, normals)
    assert np.isfinite(out).all()
    assert np.abs(out).max() < 1e-5, out[np.abs(out).max(axis=1).argmax()]


def test_uniform_sphere_matches_its_pdf():
    n = 1 << 18
    out = run_helper(1, uniform_square(n, 1))
    np.testing.assert_allclose(np.linalg.norm(out[:, :3], axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(out[:, 3], 1.0 / (4.0 * np.pi), rtol=1e-6)
    observed = sphere_histogram(out[:, :3], BSDF_GRID)
    expected = np.full_like(observed, n / observed.size)  # equal-area cells in (cos theta, phi)
    assert pearson_chi2(observed, expected)[2] > HELPER_SIGNIFICANCE


def test_uniform_triangle_is_uniform():
    n = 1 << 18
    b = run_helper(2, uniform_square(n, 2))[:, :2].astype(np.float64)
    assert (b >= 0).all() and (b.sum(axis=1) <= 1 + 1e-6).all()
    # Cells of a 16 x 16 grid over the unit square, clipped to the triangle b1 + b2 <= 1: the
    # expected count is proportional to each cell's area inside the triangle.
    res = 16
    i, j = (np.minimum((b * res).astype(int), res - 1)).T
    observed = np.bincount(i * res + j, minlength=res * res).reshape(res, res).astype(np.float64)
    ii, jj = np.meshgrid(np.arange(res), np.arange(res), indexing="ij")
    s = ii + jj  # cell (i, j) is inside when s + 2 <= res, on the diagonal when s + 1 == res
    area = np.where(s + 2 <= res, 1.0, np.where(s + 1 == res, 0.5, 0.0)) / res ** 2
    expected = n * area / area.sum()
    assert observed[area == 0].sum() == 0
    assert pearson_chi2(observed[area > 0], expected[area > 0])[2] > HELPER_SIGNIFICANCE


def test_concentric_disk_is_uniform():
    n = 1 << 18
    out = run_helper(4, uniform_square(n, 4)).astype(np.float64)
    r2 = (out[:, :2] ** 2).sum(axis=1)
    assert (r2 <= 1.0 + 1e-6).all()
    np.testing.assert_allclose(out[:, 2], 1.0 / np.pi, rtol=1e-6)
    # Uniform on the disk: r^2 and the angle are independent uniforms; 16 x 16 cells.
    cells = (np.minimum((r2 * 16).astype(int), 15) * 16
             + np.minimum((np.mod(np.arctan2(out[:, 1], out[:, 0]), 2 * np.pi) / (2 * np.pi) * 16).astype(int), 15))
    observed = np.bincount(cells, minlength=256).astype(np.float64)
    assert pearson_chi2(observed, np.full(256, n / 256))[2] > HELPER_SIGNIFICANCE


def test_power_heuristic_values_and_guards():
    inf = np.float32(np.inf)
    pairs = np.array([[1, 1], [3, 1], [0, 0], [0, 2], [inf, 1], [1, inf], [inf, 0], [1e30, 1e30], [1e-30, 0]])
    out = run_helper(3, pairs)[:, 0]
    np.testing.assert_allclose(out, [0.5, 0.9, 0.0, 0.0, 1.0, 0.0, 1.0, 0.5, 1.0], rtol=1e-6)
