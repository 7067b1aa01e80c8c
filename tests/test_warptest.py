"""`lift-gl warptest`: the examples in examples/warptest/ that are right pass in each domain,
the subtly wrong ones are rejected (exit 1), the library's BSDFs pass and a broken student
BSDF does not, bad files give exit 2 with FILE:line, and the checks besides the histogram
(samples outside the domain, the pdf's integral, its sign) catch what the histogram cannot.

False alarms: every case that must pass runs at alpha = SIGNIFICANCE / (number of such
cases) (Bonferroni), so with fresh seeds all of them pass together with probability at
least 1 - SIGNIFICANCE; the seeds are fixed (the uniform numbers come from numpy's PCG64, so
only the driver's rounding of the sampler can change a verdict). The wrong examples are
rejected by p-values below 1e-20 at these sample counts, or by a deterministic check.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate, stats

from conftest import REPO
from lift_gl.chi2 import grid_rects, pearson_chi2
from lift_gl.cli import main
from lift_gl.warptest import warptest

EXAMPLES = REPO / "examples" / "warptest"
SAMPLES = str(1 << 18)
SIGNIFICANCE = 0.01

CORRECT = [("uniform_square.glsl", "uniform_square", "square"), ("tent.glsl", "tent", "square"),
           ("concentric_disk.glsl", "concentric_disk", "disk"), ("uniform_sphere.glsl", "uniform_sphere", "sphere"),
           ("cosine_hemisphere.glsl", "cosine_hemisphere", "hemisphere"),
           ("power_cosine.glsl", "power_cosine", "hemisphere")]
# (file, sampler, domain, what the verdict must say)
WRONG = [("tent_pdf_off_5_percent.glsl", "tent", "square", "integrates to 1.050"),
         ("disk_without_sqrt.glsl", "polar_disk", "disk", "histogram does not follow"),
         ("sphere_pi_is_3.glsl", "uniform_sphere", "sphere", "integrates to 1.047"),
         ("sphere_radius_without_square.glsl", "uniform_sphere", "sphere", "not of unit length"),
         ("cosine_power_1_1.glsl", "cosine_hemisphere", "hemisphere", "histogram does not follow"),
         ("uniform_sphere.glsl", "uniform_sphere", "hemisphere", "below the horizon")]
# (material, cos theta_o, roughness): the library's BSDFs, each at a grazing and a steep angle.
BSDFS = [(m, c, r) for m, r in (("diffuse", 0.0), ("conductor", 0.3), ("dielectric", 0.4), ("plastic", 0.3))
         for c in (0.2, 0.9)] + [("dielectric", -0.6, 0.4), ("plastic", 0.5, 0.0)]
STUDENT_BSDF = ["--sampler", "phong_sample", "--pdf", "phong_pdf", "--bsdf", "diffuse", "--cos-theta-o", "0.5"]
PASSING = len(CORRECT) + len(BSDFS) + 1
CASE_ALPHA = str(SIGNIFICANCE / PASSING)


def run(capsys, *args):
    """`lift-gl warptest ARGS` in-process: (exit code, stdout, stderr)."""
    code = main(["warptest", *args])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out, captured.err


def verdict(out: str) -> str:
    lines = [line for line in out.splitlines() if line.startswith(("PASS", "REJECTED"))]
    assert len(lines) == 1, out
    return lines[0]


@pytest.mark.parametrize("file,sampler,domain", CORRECT, ids=[c[0] for c in CORRECT])
def test_correct_sampler_passes(capsys, file, sampler, domain):
    code, out, _ = run(capsys, str(EXAMPLES / file), "--sampler", sampler, "--domain", domain,
                       "--samples", SAMPLES, "--alpha", CASE_ALPHA)
    assert code == 0, out
    assert verdict(out).startswith("PASS")
    assert "0 samples outside the domain" in out


@pytest.mark.parametrize("file,sampler,domain,why", WRONG, ids=[f"{c[0]}-{c[2]}" for c in WRONG])
def test_wrong_sampler_is_rejected(capsys, file, sampler, domain, why):
    code, out, _ = run(capsys, str(EXAMPLES / file), "--sampler", sampler, "--domain", domain,
                       "--samples", SAMPLES, "--alpha", CASE_ALPHA)
    assert code == 1, out
    assert verdict(out).startswith("REJECTED") and why in verdict(out), out


@pytest.mark.parametrize("material,cos_o,roughness", BSDFS, ids=[f"{m}-cos{c}-r{r}" for m, c, r in BSDFS])
def test_library_bsdf_passes(capsys, material, cos_o, roughness):
    code, out, _ = run(capsys, "--bsdf", material, "--cos-theta-o", str(cos_o), "--roughness", str(roughness),
                       "--samples", SAMPLES, "--alpha", CASE_ALPHA)
    assert code == 0, out


def test_student_bsdf_passes_and_its_broken_pdf_is_rejected(capsys):
    code, out, _ = run(capsys, str(EXAMPLES / "phong_bsdf.glsl"), *STUDENT_BSDF, "--samples", SAMPLES,
                       "--alpha", CASE_ALPHA)
    assert code == 0, out
    # The sampler rejects what falls below the surface; the pdf's integral is short by that.
    assert "rejected" in out and "pdf integral 0.99" in out
    code, out, _ = run(capsys, str(EXAMPLES / "phong_bsdf_wrong_pdf.glsl"), *STUDENT_BSDF, "--samples", SAMPLES)
    assert code == 1, out
    assert "integrates to 1.03" in verdict(out)  # (n + 2) / (n + 1) = 22/21, less the rejected directions


# ---- what the histogram alone cannot see ----------------------------------------------------
TENT_SCALED = """
float tent_1d(float u) { return u < 0.5 ? sqrt(0.5 * u) : 1.0 - sqrt(0.5 * (1.0 - u)); }
float tent_density(float x) { return x < 0.5 ? 4.0 * x : 4.0 * (1.0 - x); }
vec2 tent(vec2 u) { return vec2(tent_1d(u.x), tent_1d(u.y)); }
float tent_pdf(vec2 p) { return SCALE * tent_density(p.x) * tent_density(p.y); }
"""


def test_pdf_integral_rejects_what_too_few_samples_hide(tmp_path):
    """A pdf that integrates to 0.9: with 1000 samples on the default 32x32 grid every cell
    expects fewer than 5 and they pool into one, so the histogram has no degrees of freedom
    (p = 1) whatever the pdf says; the integral, computed without samples, still rejects."""
    path = tmp_path / "tent.glsl"
    path.write_text(TENT_SCALED.replace("SCALE", "0.9"))
    result = warptest(str(path), sampler="tent", domain="square", samples=1000)
    assert result.dof == 0 and result.histogram_p_value == 1.0
    assert not result.passed and result.reasons == ["the pdf integrates to 0.900000 over the square, not 1 "
                                                    "(tolerance 0.001)"]
    assert "sees little" in result.notes[0]
    path.write_text(TENT_SCALED.replace("SCALE", "1.0"))
    assert warptest(str(path), sampler="tent", domain="square", samples=1000).passed


@pytest.mark.parametrize("pdf,why", [
    # Negative on a strip and compensated elsewhere: the integral is 1, the cells' expected
    # counts are all >= 0 (each cell is wider than the strip), so only the sign check sees it.
    ("p.x < 0.01 ? -1.0 : 1.0 + 0.02 / 0.99", "the pdf is negative"),
    ("p.x < 0.5 ? 1.0 : uintBitsToFloat(0x7fc00000u)", "NaN or Inf"),  # a quiet NaN, spelt in bits
    ("p.x < 0.5 ? 1.0 : uintBitsToFloat(0x7f800000u)", "NaN or Inf"),  # +Inf
])
def test_pdf_sign_and_finiteness(tmp_path, pdf, why):
    path = tmp_path / "square.glsl"
    path.write_text(f"vec2 square(vec2 u) {{ return u; }}\nfloat square_pdf(vec2 p) {{ return {pdf}; }}\n")
    result = warptest(str(path), sampler="square", domain="square", samples=1 << 16, grid=(8, 8))
    assert any(why in reason for reason in result.reasons), result.reasons


def test_nan_samples_are_outside_the_domain(tmp_path):
    path = tmp_path / "square.glsl"
    path.write_text("vec2 square(vec2 u) { return u.x < 0.001 ? vec2(uintBitsToFloat(0x7fc00000u)) : u; }\n"
                    "float square_pdf(vec2 p) { return 1.0; }\n")
    result = warptest(str(path), sampler="square", domain="square", samples=1 << 16)
    assert result.outside["not finite"] == pytest.approx(65.5, abs=5 * math.sqrt(65.5))
    assert result.p_value == 0.0 and not result.passed


# ---- the pieces against independent computations --------------------------------------------
def test_disk_cell_integrals_match_quadpack():
    """The shader's adaptive cubature of the disk's cells (the pdf 1/pi restricted to the
    disk) against scipy's adaptive quadrature of the chord length in float64: the cells'
    errors add up to at most the budget warptest gives the cubature (a tenth of
    --integral-tolerance), even at a sample count that asks little of it."""
    result = warptest(str(EXAMPLES / "concentric_disk.glsl"), sampler="concentric_disk", domain="disk",
                      samples=1000, grid=(8, 8))
    rects = grid_rects(((-1.0, 1.0), (-1.0, 1.0)), (8, 8))

    def chord_in(y0, y1):
        return lambda x: max(0.0, min(y1, math.sqrt(max(0.0, 1 - x * x))) - max(y0, -math.sqrt(max(0.0, 1 - x * x))))

    exact = np.array([integrate.quad(chord_in(y0, y1), x0, x1, limit=200, epsabs=1e-12)[0] / math.pi
                      for x0, x1, y0, y1 in rects]).reshape(8, 8)
    budget = 0.1 * result.integral_tolerance
    assert np.abs(result.expected / result.samples - exact).sum() <= budget
    assert abs(result.pdf_integral - 1.0) <= result.quadrature_error <= budget


def test_pearson_matches_scipy_and_pools_low_cells():
    rng = np.random.default_rng(1)
    observed = rng.poisson(20.0, size=40).astype(float)
    expected = rng.uniform(5, 50, size=40)
    expected *= observed.sum() / expected.sum()  # scipy's chisquare wants equal totals
    statistic, dof, p = pearson_chi2(observed, expected)
    reference = stats.chisquare(observed, expected)
    assert (statistic, dof, p) == (pytest.approx(reference.statistic), 39, pytest.approx(reference.pvalue))
    # Cells expecting < 5 are pooled into one cell (here 1 + 2 + 3 = 6 >= 5).
    statistic, dof, _ = pearson_chi2([10, 1, 2, 3], [10, 1, 2, 3])
    assert (statistic, dof) == (0.0, 1)


# ---- bad files: exit 2, FILE:line ----------------------------------------------------------
def test_file_that_does_not_compile(capsys, tmp_path):
    path = tmp_path / "broken.glsl"
    path.write_text("// a typo on line 3\nvec2 tent(vec2 u) {\n    return u * 2.0 +;\n}\n"
                    "float tent_pdf(vec2 p) { return 1.0; }\n")
    code, _, err = run(capsys, str(path), "--sampler", "tent", "--domain", "square")
    assert code == 2
    assert f"{path}:3:" in err and err.count("\n") == 1, err


def test_missing_pdf_and_wrong_return_type(capsys, tmp_path):
    path = tmp_path / "lonely.glsl"
    path.write_text("\n\nvec3 tent(vec2 u) { return vec3(u, 0.0); }\n")
    code, _, err = run(capsys, str(path), "--sampler", "tent", "--domain", "square")
    assert code == 2 and f"{path}:3:" in err and "vec2 tent(vec2 u)" in err, err  # vec3 for a square
    code, _, err = run(capsys, str(path), "--sampler", "tent", "--domain", "sphere")
    assert code == 2 and f"{path}:" in err and "no function 'tent_pdf'" in err and "float tent_pdf(vec3 w)" in err, err


def test_out_writes_picture_and_json(capsys, tmp_path):
    code, out, _ = run(capsys, str(EXAMPLES / "cosine_power_1_1.glsl"), "--sampler", "cosine_hemisphere",
                       "--domain", "hemisphere", "--samples", SAMPLES, "--out", str(tmp_path))
    assert code == 1
    record = json.loads((tmp_path / "warptest.json").read_text())
    assert record["verdict"] == "rejected" and record["domain"] == "hemisphere" and record["samples"] == 1 << 18
    assert record["p_value"] < 1e-20 and record["dof"] > 500 and record["grid"] == [16, 64]
    from PIL import Image

    with Image.open(tmp_path / "warptest.png") as image:
        assert image.size[0] > 800 and image.size[1] > 250
