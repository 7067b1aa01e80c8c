"""bdpt in two passes (its [prepass] traces and stores the light subpaths, the trace pass joins
the camera subpaths to them) against bdpt in one pass, as it was before the split: the same
estimator with the same random numbers, so the same image. The one-pass plugin is this
repository's own bdpt at the commit before the split (git), an implementation that shares no
storage code with today's, given today's Russian roulette (_with_todays_roulette: the split
changed no estimator, the roulette changed later). Camera-side estimates must agree bit for bit; light tracing's
splats are float atomics summed in the threads' order, so full images agree to float rounding.
Also: the prepass's storage layout (split over buffers at the driver's block limit) and the
[prepass] manifest checks."""
from __future__ import annotations

import subprocess
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LimitError, PluginError
from lift_gl.options import Options
from lift_gl.passes.prepass import prepass_layout
from lift_gl.plugins import find_plugin, load_manifest
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

ONE_PASS_COMMIT = "04d1945"  # the last commit with bdpt's light subpath in a local array
BDPT_FILES = ("plugin.toml", "bdpt.glsl", "bdpt_vertex.glsl", "bdpt_subpaths.glsl", "bdpt_strategies.glsl",
              "bdpt_mis.glsl")


@pytest.fixture(scope="module")
def one_pass_dir(tmp_path_factory):
    """The one-pass bdpt, as plugin `bdpt_one_pass`, from git."""
    folder = tmp_path_factory.mktemp("plugins") / "bdpt_one_pass"
    folder.mkdir()
    for name in BDPT_FILES:
        shown = subprocess.run(["git", "-C", str(REPO), "show", f"{ONE_PASS_COMMIT}:plugins/bdpt/{name}"],
                               capture_output=True, text=True)
        if shown.returncode != 0:
            pytest.skip(f"no git history with {ONE_PASS_COMMIT} here: {shown.stderr.strip()}")
        text = shown.stdout
        if name == "plugin.toml":
            text = text.replace('name = "bdpt"', 'name = "bdpt_one_pass"', 1)
        if name == "bdpt_subpaths.glsl":
            text = _with_todays_roulette(text)
        (folder / name).write_text(text)
    return folder.parent


# the one-pass file's lines, and today's (plugins/bdpt/bdpt_subpaths.glsl): the roulette judges a
# camera subpath's throughput without its refractions' 1 / etap^2
ROULETTE_THEN_NOW = [
    ("    vec3 roulette_weight = vec3(1.0);  // throughput relative to the subpath's start\n",
     "    vec3 roulette_weight = vec3(1.0);  // throughput relative to the subpath's start\n"
     "    float eta_scale = 1.0;\n"),
    ("        roulette_weight *= weight;\n",
     "        roulette_weight *= weight;\n"
     "        if (!importance) eta_scale *= refraction_eta2(m, wo_local, bs.wi);\n"),
    ("            float survive = clamp(max(roulette_weight.r, max(roulette_weight.g, roulette_weight.b)),\n"
     "                                  rr_min_survival, 1.0);\n",
     "            vec3 judged = roulette_weight * eta_scale;\n"
     "            float survive = clamp(max(judged.r, max(judged.g, judged.b)), rr_min_survival, 1.0);\n"),
]


def _with_todays_roulette(text: str) -> str:
    for then, now in ROULETTE_THEN_NOW:
        assert text.count(then) == 1, f"the one-pass bdpt_subpaths.glsl has no single {then.strip()!r}"
        text = text.replace(then, now)
    return text


def _render(scene, integrator, plugin_dirs, splats, size=(32, 24), spp=3, samples_per_frame=None, **params):
    r = Renderer(scene, size=size, integrator=integrator, seed=7, params=params, plugin_dirs=plugin_dirs,
                 samples_per_frame=samples_per_frame)
    if not splats:
        r.trace.splats.add_to = lambda frame: None
    image = r.render(spp=spp)
    assert r.stats.dropped_samples == 0 and r.stats.dropped_splats == 0
    r.release()
    return image


# glass and rough gold (delta vertices); textures (four words a light vertex); a sky (light
# subpaths from the environment's disk); two samples a frame (two light subpaths a pixel stored)
@pytest.mark.parametrize("scene_file, sky, samples_per_frame, params", [
    ("scenes/cornell.toml", False, None, {}),
    ("tests/data/cornell_textured.toml", False, None, {"max_depth": 5}),
    ("tests/data/cornell_diffuse.toml", True, 2, {"mis_power": 1.0}),
], ids=["glass-gold", "textured", "diffuse-sky-2-a-frame"])
def test_two_passes_give_the_one_pass_image(one_pass_dir, scene_file, sky, samples_per_frame, params):
    from lift_gl.scene import Environment

    scene = load_scene(REPO / scene_file)
    if sky:
        scene.environment = Environment((0.6, 0.7, 1.0))
    for splats in (False, True):
        two = _render(scene, "bdpt", [one_pass_dir], splats, samples_per_frame=samples_per_frame, **params)
        one = _render(scene, "bdpt_one_pass", [one_pass_dir], splats, samples_per_frame=samples_per_frame,
                      **params)
        assert two.max() > 0.0
        if splats:
            np.testing.assert_allclose(two, one, rtol=1e-6, atol=0)  # a few float roundings of a sum
        else:
            assert np.array_equal(two, one)


def test_coherent_sampling_two_passes_give_the_one_pass_image(one_pass_dir):
    """Coherent sampling draws the light subpath from the pixel's own numbers and the camera
    subpath from the tile's: the prepass must do the same."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    images = []
    for name in ("bdpt", "bdpt_one_pass"):
        r = Renderer(scene, size=(32, 24), integrator=name, seed=7, plugin_dirs=[one_pass_dir],
                     options=Options(coherent_sampling="on"))
        r.trace.splats.add_to = lambda frame: None
        images.append(r.render(spp=2))
        r.release()
    assert images[0].max() > 0.0 and np.array_equal(*images)


def _fake_ctx(max_block):
    return SimpleNamespace(info={"GL_MAX_SHADER_STORAGE_BLOCK_SIZE": max_block})


def test_storage_splits_over_buffers_at_the_block_limit():
    bdpt = find_plugin("bdpt")
    entries = bdpt.prepass.entry_count({"max_depth": 32})
    assert entries == 4 * 33 + 2
    size, local = (1920, 1080), (8, 4)
    invocations = 1920 * 1080   # 8x4 groups cover 1080p exactly
    whole = entries * invocations * 16
    for max_block, buffers in ((whole, 1), (whole - 1, 2), (whole // 3 + 16 * invocations, 3)):
        layout = prepass_layout(_fake_ctx(max_block), bdpt, {"max_depth": 32}, size, {}, local, 1)
        assert layout.invocations == invocations and layout.buffers == buffers
        assert layout.buffers * layout.buffer_entries >= entries
        assert layout.buffer_bytes(1) <= max_block
    with pytest.raises(LimitError, match="prepass needs"):
        prepass_layout(_fake_ctx(whole // 5), bdpt, {"max_depth": 32}, size, {}, local, 1)


def test_split_storage_renders_the_one_buffer_image(monkeypatch):
    """Entries spread over three buffers (a small block limit, as on a big image) read back as
    from one."""
    from lift_gl.passes import prepass

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    one = _render(scene, "bdpt", [], splats=False, max_depth=4)
    real = prepass.prepass_layout

    def small_blocks(ctx, plugin, params, size, defines, local_size, samples):
        layout = real(ctx, plugin, params, size, defines, local_size, samples)
        third = -(-layout.entries // 3) * layout.stride(samples) * 16   # a third of the entries a buffer
        return real(_fake_ctx(third), plugin, params, size, defines, local_size, samples)

    monkeypatch.setattr("lift_gl.frame_passes.prepass_layout", small_blocks)
    r = Renderer(scene, size=(32, 24), integrator="bdpt", seed=7, params={"max_depth": 4})
    assert r.prepass.layout.buffers == 3 and "#define LIFT_PREPASS_BUFFERS 3" in r.trace.source.text
    r.trace.splats.add_to = lambda frame: None
    assert np.array_equal(r.render(spp=3), one)
    r.release()


@pytest.mark.parametrize("table, message", [
    ('[prepass]\nentries = 4\n', "needs 'function'"),
    ('[prepass]\nfunction = "f"\nentries = "2 ** depth"\n', "entries must be"),
    ('[prepass]\nfunction = "f"\nentries = "depth - 10"\n', "must be positive"),
    ('[prepass]\nfunction = "f"\nentries = 2\nsize = 3\n', "unknown keys"),
])
def test_bad_prepass_tables_are_refused(tmp_path, table, message):
    (tmp_path / "p.glsl").write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(0.0); }\n")
    (tmp_path / "plugin.toml").write_text('name = "p"\nentry = "p.glsl"\n'
                                          '[params.depth]\ntype = "int"\ndefault = 3\n' + table)
    with pytest.raises(PluginError, match=message):
        load_manifest(tmp_path)


def test_prepass_entries_follow_the_parameters():
    bdpt = find_plugin("bdpt")
    assert [bdpt.prepass.entry_count({"max_depth": d}) for d in (0, 16, 64, 1000)] == [6, 70, 262, 262]

