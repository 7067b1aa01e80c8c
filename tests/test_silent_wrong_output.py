"""No silent wrong output: NaN/Inf samples are dropped and counted, also where llvmpipe turns a
division by a constant zero into an undefined value (shaders/lift/finite.glsl), and a render
whose image is all zero, negative or non-finite, or that dropped many samples, is warned about
(lift_gl/image_checks.py) by `lift-gl render` and in its JSON record."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from lift_gl.image_checks import DROPPED_FRACTION_LIMIT, check_image, check_render
from lift_gl.shaders import ShaderSource, constant_zero_divisions

CORNELL = REPO / "scenes" / "cornell.toml"
SIZE = (32, 32)


def make_plugin(root: Path, name: str, body: str, params: str = "") -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    (folder / "plugin.toml").write_text(f'name = "{name}"\nlanguage = "glsl"\nentry = "{name}.glsl"\n'
                                        f'primary = "gbuffer"\n{params}')
    (folder / f"{name}.glsl").write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) {\n" + body + "}\n")
    return folder


def render(tmp_path, name, body, spp=2, params=""):
    from lift_gl import Renderer, load_scene

    make_plugin(tmp_path / "plugins", name, body, params)
    renderer = Renderer(load_scene(CORNELL), size=SIZE, integrator=name, plugin_dirs=[tmp_path / "plugins"])
    return renderer, renderer.render(spp=spp)


# ---- The guard itself: lift_is_finite against numpy's isfinite ----

GUARD_KERNEL = """
#include "lift/finite.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 10) buffer Out { uint finite[]; };
uniform float u_one;   // 1.0 at run time: the compiler cannot fold what it divides
uniform float u_zero;  // 0.0 at run time
void main() {
    finite[0] = lift_is_finite(vec3(u_one) / 0.0) ? 1u : 0u;     // a constant zero: undef on llvmpipe
    finite[1] = lift_is_finite(vec3(u_one) / u_zero) ? 1u : 0u;  // +Inf
    finite[2] = lift_is_finite(vec3(u_zero) / u_zero) ? 1u : 0u; // NaN
    finite[3] = lift_is_finite(vec3(u_one, sqrt(-u_one), 0.0)) ? 1u : 0u;  // one NaN component
    finite[4] = lift_is_finite(vec3(u_one, 3.4e38 * (u_one + 1.0), 0.0)) ? 1u : 0u;  // overflow: +Inf
    finite[5] = lift_is_finite(vec3(u_one, -2.0, 1e-38 * u_one)) ? 1u : 0u;  // finite (a denormal too)
    finite[6] = lift_is_finite(vec3(u_zero)) ? 1u : 0u;  // zero is finite
}
"""


def test_guard_matches_isfinite_also_for_a_constant_zero_divisor():
    from lift_gl.gl.context import create_context
    from lift_gl.shaders import assemble, compile_compute

    ctx = create_context()
    program = compile_compute(ctx, assemble(GUARD_KERNEL, main_name="<guard test>"))
    program["u_one"].value, program["u_zero"].value = 1.0, 0.0
    out = ctx.buffer(reserve=7 * 4)
    out.bind_to_storage_buffer(10)
    program.run(1)
    got = np.frombuffer(out.read(), np.uint32).astype(bool)
    out.release()
    with np.errstate(all="ignore"):
        one, zero = np.float32(1.0), np.float32(0.0)
        expected = [False,  # IEEE: 1 / 0 is +Inf; GLSL: unspecified, and never finite for the guard
                    *(bool(np.isfinite(v).all()) for v in (
                        np.full(3, one / zero), np.full(3, zero / zero), [one, np.sqrt(-one), 0.0],
                        [one, np.float32(3.4e38) * np.float32(2.0), 0.0], [one, -2.0, 1e-38], [zero] * 3))]
    assert got.tolist() == expected


# ---- Renders ----

def test_division_by_constant_zero_is_dropped_and_counted(tmp_path):
    # every sample divides a run-time value by the literal 0.0
    renderer, image = render(tmp_path, "divzero", "    vec3 L = vec3(rng_next(rng) + 0.5);\n    return L / 0.0;\n")
    samples = 2 * SIZE[0] * SIZE[1]
    assert renderer.stats.dropped_samples == samples
    checks = {w.check: w.message for w in check_render(renderer, image)}
    assert checks.keys() == {"all_zero", "dropped_samples", "zero_division"}
    assert checks["dropped_samples"].startswith(f"dropped 100.0% of samples as NaN/Inf ({samples} of {samples})")
    assert checks["zero_division"].startswith(f"{(tmp_path / 'plugins' / 'divzero' / 'divzero.glsl').resolve()}:3:")


def test_half_the_samples_nan_reports_the_fraction(tmp_path):
    # a float parameter is a uniform: 1 / zero is a run-time +Inf, half of the samples
    params = '[params.zero]\ntype = "float"\ndefault = 0.0\n'
    renderer, image = render(tmp_path, "halfnan", "    if (rng_next(rng) < 0.5) return vec3(1.0) / zero;\n"
                                                   "    return vec3(1.0);\n", spp=4, params=params)
    n = 4 * SIZE[0] * SIZE[1]
    dropped = renderer.stats.dropped_samples
    assert abs(dropped - n / 2) < 5 * math.sqrt(n / 4), dropped  # Binomial(n, 1/2) within 5 sigma
    (warning,) = check_image(image, renderer.stats)
    assert warning.check == "dropped_samples"
    assert warning.message.startswith(f"dropped {100 * dropped / n:.1f}% of samples as NaN/Inf ({dropped} of {n})")
    kept = image[np.isfinite(image).all(-1)]
    assert np.allclose(kept[kept.any(-1)], 1.0)  # the mean of the samples kept, none of the dropped ones


def test_loop_sum_of_constant_zero_divisions_is_warned_about(tmp_path):
    # Inside a loop the compiler may fold the undefined value away (to 0 here): the guard
    # cannot see it, but the all-black image and the source's division are warned about.
    renderer, image = render(tmp_path, "loopdiv", "    vec3 L = vec3(0.0);\n"
                                                  "    for (int i = 0; i < 3; ++i) L += vec3(rng_next(rng)) / 0.0;\n"
                                                  "    return L;\n")
    checks = [w.check for w in check_render(renderer, image)]
    assert "zero_division" in checks
    assert renderer.stats.dropped_samples > 0 or "all_zero" in checks or np.isnan(image).any()


def test_render_warns_on_black_and_negative_images_and_records_it(tmp_path, capsys):
    from lift_gl.cli import main

    make_plugin(tmp_path / "plugins", "black", "    return vec3(0.0);\n")
    make_plugin(tmp_path / "plugins", "negative", "    return vec3(-1.0, 0.25, 0.5);\n")
    for name, check, words in (("black", "all_zero", "the image is all zero"),
                               ("negative", "negative", "1024 pixels have negative values (least -1)")):
        out = tmp_path / f"{name}.npy"
        code = main(["render", str(CORNELL), "--integrator", name, "--plugins", str(tmp_path / "plugins"),
                     "--spp", "2", "--size", "32x32", "--out", str(out)])
        err = capsys.readouterr().err
        assert code == 0
        assert f"lift-gl: warning: {out}: {words}" in err, err
        record = json.loads(Path(f"{out}.json").read_text())
        assert [w["check"] for w in record["warnings"]] == [check]
        assert record["dropped_fraction"] == 0.0


def test_a_correct_render_has_no_warnings(tmp_path, capsys):
    from lift_gl.cli import main

    out = tmp_path / "debug.npy"
    assert main(["render", str(CORNELL), "--integrator", "debug", "--spp", "2", "--size", "32x32",
                 "--out", str(out)]) == 0
    assert "warning" not in capsys.readouterr().err
    assert json.loads(Path(f"{out}.json").read_text())["warnings"] == []


# ---- The checks on arrays (no GL) ----

def test_check_image_on_arrays():
    image = np.full((8, 8, 3), 0.5, np.float32)
    assert check_image(image) == []
    assert check_image(image, {"spp": 4, "dropped_samples": 0}) == []
    bad = image.copy()
    bad[0, 0, 1] = np.nan
    bad[1, 1] = np.inf
    bad[2, 2, 0] = -0.125
    checks = {w.check: w.message for w in check_image(bad)}
    assert checks == {"non_finite": "2 of 64 pixels are NaN or infinite",
                      "negative": "1 pixels have negative values (least -0.125): radiance is never negative"}
    assert [w.check for w in check_image(np.zeros((4, 4, 3)))] == ["all_zero"]
    assert [w.check for w in check_image(np.full((4, 4, 3), np.nan))] == ["non_finite", "all_zero"]


@pytest.mark.parametrize("dropped, warned", [(0, False), (1024, False), (1025, True), (512000, True)])
def test_dropped_fraction_threshold(dropped, warned):
    # 1000 spp in 32x32 pixels: 1,024,000 samples, of which the limit allows 0.1% (1024)
    found = check_image(np.ones((32, 32, 3)), {"spp": 1000, "dropped_samples": dropped})
    assert [w.check for w in found] == (["dropped_samples"] if warned else [])
    if warned:
        assert found[0].message.startswith(f"dropped {100 * dropped / 1_024_000:.1f}% of samples as NaN/Inf "
                                           f"({dropped} of 1024000)")


def test_constant_zero_divisions_lint(tmp_path):
    shader = tmp_path / "mine.glsl"
    shader.write_text("\n".join([
        "a = b / 0.0;",         # 1
        "a /= 0;",              # 2
        "a = b / (0.);",        # 3
        "a = b / vec3(0.0f);",  # 4
        "a = b / 0.5;",         # 5: not zero
        "a = b / 0.01 + c / 10.0;",  # 6
        "a = b / 0x1;",         # 7
        "// a = b / 0.0;",      # 8: a comment
        "/* a = b / 0.0;",      # 9
        "*/ a = b / 0e3;",      # 10
        "a = b / .0 * c;",      # 11
        "a = b / (0.0 + c);",   # 12: not a constant zero
    ]) + "\n")
    library = REPO / "shaders" / "lift" / "sampling.glsl"
    source = ShaderSource(text="", files=[Path("<host main>"), library, shader])
    assert [line for _, line in constant_zero_divisions(source)] == [1, 2, 3, 4, 10, 11]


def test_a_sequence_warns_about_each_black_frame(tmp_path, capsys):
    from lift_gl.cli import main

    make_plugin(tmp_path / "plugins", "black", "    return vec3(0.0);\n")
    out = tmp_path / "seq"
    assert main(["render", str(CORNELL), "--camera-path", str(REPO / "scenes" / "paths" / "cornell_pan.toml"),
                 "--frames", "2", "--spp", "1", "--size", "16x16", "--integrator", "black",
                 "--plugins", str(tmp_path / "plugins"), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    for frame in ("frame_0000.png", "frame_0001.png"):
        assert f"lift-gl: warning: {out / frame}: the image is all zero" in err, err
