"""The hybrid plugin (plugins/hybrid) and the passes it brings: a reduced-resolution trace and
a joint bilateral upsampling (lift_gl/passes/reduced_trace.py, upsample.py).

The filter is biased where indirect light varies, so the checks use what does not depend on
it: the full-resolution half alone is pt's direct light (same seed: the same numbers); and
inside a closed glowing box, where indirect light is the same everywhere, any weighted mean
of unbiased estimates stays unbiased, so hybrid must converge to the analytic Le / (1 - a).
Standard errors come from independent renders (the filter correlates neighbouring pixels).
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl import load_scene
from lift_gl.cli import main
from lift_gl.errors import PluginError
from lift_gl.passes.reduced_trace import block_offset
from lift_gl.plugins import load_manifest
from lift_gl.renderer import Renderer
from test_bounces import glowing_box

CORNELL = REPO / "scenes" / "cornell.toml"
SIZE = (32, 32)


def _render(scene, spp, seed=0, integrator="hybrid", **params):
    r = Renderer(scene, size=SIZE, seed=seed, integrator=integrator, params=params)
    image = r.render(spp=spp)
    assert r.stats.dropped_samples == 0
    r.release()
    return image.astype(np.float64)


def test_without_indirect_light_hybrid_is_pts_direct_light():
    """max_depth 1 leaves the reduced pass nothing to add: the full-resolution half draws the
    same random numbers as pt limited to one bounce, so the images agree to rounding."""
    scene = load_scene(CORNELL)
    hybrid = _render(scene, 4, seed=5, max_depth=1)
    pt = _render(scene, 4, seed=5, integrator="pt", max_depth=1)
    np.testing.assert_allclose(hybrid, pt, rtol=1e-6, atol=1e-7)


def test_under_a_distant_light_hybrid_is_pts_direct_light():
    """The same with a distant (delta) light, which neither may weight by MIS."""
    from test_bdpt_lights import porch
    scene = porch("distant")
    hybrid = _render(scene, 4, seed=5, max_depth=1)
    pt = _render(scene, 4, seed=5, integrator="pt", max_depth=1)
    assert hybrid.mean() > 0.05
    np.testing.assert_allclose(hybrid, pt, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("scale", [2, 4])
def test_in_a_glowing_box_hybrid_converges_to_the_analytic_radiance(scale):
    """Every wall emits Le and reflects a: L = Le / (1 - a) everywhere, indirect light
    Le a^2 / (1 - a) everywhere, so the filter cannot bias it. K independent renders give
    the standard error of the image mean (|t| > 5.5 with 7 degrees of freedom: p < 0.001)."""
    emission, albedo, k = 1.0, 0.5, 8
    scene = glowing_box(emission, albedo)
    means = np.array([_render(scene, 4, seed=s, indirect_scale=scale).mean() for s in range(k)])
    expected = emission / (1 - albedo)
    standard_error = means.std(ddof=1) / np.sqrt(k)
    t = (means.mean() - expected) / standard_error
    assert abs(t) < 5.5, f"mean {means.mean():.5f}, expected {expected:.5f}, t = {t:.1f} ({k - 1} dof)"
    # Not a vacuous test: dropping the indirect half is far outside that error.
    assert abs(_render(scene, 4, max_depth=1).mean() - expected) > 20 * standard_error


def test_block_offsets_visit_every_pixel_of_a_block():
    for scale in (1, 2, 3, 4):
        seen = {block_offset(frame, scale) for frame in range(4 * scale * scale)}
        assert seen == {(x, y) for x in range(scale) for y in range(scale)}


def test_reduced_resolution_follows_the_parameter_and_explain_labels_the_bias(capsys, tmp_path):
    r = Renderer(load_scene(CORNELL), size=(30, 22), integrator="hybrid", params={"indirect_scale": 4})
    r.render(spp=1)
    assert r.reduced.reduced.size == (8, 6)  # ceil(30 / 4), ceil(22 / 4)
    r.set_params(indirect_scale=2)
    r.render(spp=1)
    assert r.reduced.reduced.size == (15, 11)
    text = r.explain()
    assert "BIASED: indirect light" in text
    for line in ("reduced     scene, camera, visibility, albedo -> reduced", "upsample    frame, reduced, normal_depth"):
        assert line in text
    assert "reduced" not in Renderer(load_scene(CORNELL), size=(8, 8)).explain()  # pt: no such passes
    assert main(["plugins"]) == 0
    assert "BIASED" in capsys.readouterr().out


REDUCED_MANIFEST = """name = "mine"
entry = "mine.glsl"
primary = "gbuffer"

[params.k]
type = "int"
default = 2

[reduced]
function = "indirect"
scale = "k"
"""


@pytest.mark.parametrize("bad, words", [
    (REDUCED_MANIFEST.replace('primary = "gbuffer"', 'primary = "camera"'), "needs primary"),
    (REDUCED_MANIFEST.replace('scale = "k"', 'scale = "missing"'), "must name an int parameter"),
    (REDUCED_MANIFEST.replace('scale = "k"', "scale = 0"), "positive int"),
    (REDUCED_MANIFEST.replace('function = "indirect"', 'function = "2x"'), "needs 'function'"),
    (REDUCED_MANIFEST + "blur = 3\n", "unknown keys"),
    (REDUCED_MANIFEST.replace('entry = "mine.glsl"', 'entry = "mine.glsl"\nlanguage = "opencl"'), "GLSL plugins"),
])
def test_bad_reduced_tables_name_the_manifest_and_line(tmp_path, bad, words):
    (tmp_path / "plugin.toml").write_text(bad)
    (tmp_path / "mine.glsl").write_text("")
    with pytest.raises(PluginError, match=words) as info:
        load_manifest(tmp_path)
    assert info.value.path.endswith("plugin.toml") and info.value.line is not None
