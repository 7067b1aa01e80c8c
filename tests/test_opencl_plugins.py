"""OpenCL plugins (language = "opencl", pyopencl + PoCL): the same image as their GLSL twins,
the same NaN/Inf guard, parameters of every type, file:line build errors, hot reload, and
pyopencl imported only when such a plugin runs."""
from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LiftError, ShaderError
from lift_gl.renderer import Renderer
from lift_gl.testing import assert_same_expectation, cornell_scene, render_seeds, require_opencl

require_opencl(module=True)

SIZE = (32, 32)
CORNELL = str(REPO / "scenes" / "cornell.toml")


def make_plugin(root, name, language, source, params="", primary="gbuffer"):
    folder = root / name
    folder.mkdir(parents=True)
    entry = f"{name}.{'cl' if language == 'opencl' else 'glsl'}"
    (folder / "plugin.toml").write_text(f'name = "{name}"\nlanguage = "{language}"\nentry = "{entry}"\n'
                                        f'primary = "{primary}"\n' + textwrap.dedent(params))
    (folder / entry).write_text(textwrap.dedent(source))
    return folder


# ---------------------------------------------------------------- the twins agree
K = 16     # independent renders a plugin: enough to estimate each block's variance
SPP = 4


def test_ao_cl_and_ao_agree_within_noise():
    """Independent seeds on each side: per 8x8 block, Welch's t within the Bonferroni-corrected
    critical value for p = 1e-3 over the whole image (the Cornell box: triangles, a sphere,
    contact shadows)."""
    scene = cornell_scene()
    params = {"radius": 0.5}
    glsl = render_seeds(scene, "ao", range(1, K + 1), SPP, SIZE, params)
    opencl = render_seeds(scene, "ao_cl", range(101, 101 + K), SPP, SIZE, params)
    assert 0.3 < opencl.mean() < 0.95
    assert_same_expectation(opencl, glsl, block=8)


def test_same_seed_draws_the_same_samples():
    """The OpenCL host seeds its random numbers as the GLSL host does, so with one seed the
    two images differ only where float rounding flips a visibility test: far below the noise
    (measured on llvmpipe + PoCL: bit-identical)."""
    scene = cornell_scene()
    a = render_seeds(scene, "ao", [7, 8], SPP, SIZE, {"radius": 0.5})
    b = render_seeds(scene, "ao_cl", [7], SPP, SIZE, {"radius": 0.5})[0]
    same_seed = np.mean((a[0] - b) ** 2)
    other_seed = np.mean((a[0] - a[1]) ** 2)  # two independent renders: twice the pixel variance
    assert other_seed > 0
    assert same_seed <= 0.01 * other_seed, (same_seed, other_seed)


def test_camera_primary_and_every_parameter_type(tmp_path):
    """A `primary = "camera"` OpenCL plugin with int, float, bool and colour parameters gives
    exactly what its GLSL twin gives: the parameter values arrive intact."""
    params = """
    [params.tint]
    type = "color"
    default = [0.25, 0.5, 2.0]
    [params.count]
    type = "int"
    default = 3
    [params.gain]
    type = "float"
    default = 0.5
    [params.flip]
    type = "bool"
    default = true
    """
    glsl = make_plugin(tmp_path, "probe_glsl", "glsl", """
        vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
            float visible = hit.prim == NO_HIT ? 0.0 : 1.0;
            return tint * float(count) * gain * (flip ? visible : 1.0 - visible) + rng_next(rng);
        }
        """, params, primary="camera")
    cl = make_plugin(tmp_path, "probe_cl", "opencl", """
        float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params) {
            float visible = hit.prim == NO_HIT ? 0.0f : 1.0f;
            float3 base = params->tint * (float)params->count * params->gain;
            return base * (params->flip ? visible : 1.0f - visible) + rng_next(rng);
        }
        """, params, primary="camera")
    scene = cornell_scene()
    scene.camera.fov_deg = 40.0  # wide enough to see past the box: misses and hits
    images = {}
    for folder in (glsl, cl):
        r = Renderer(scene, size=SIZE, integrator=str(folder), seed=4, params={"count": 2, "flip": False})
        images[folder.name] = r.render(spp=4)
        assert r.stats.dropped_samples == 0
        r.release()
    a, b = images["probe_glsl"], images["probe_cl"]
    np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6)
    # Every channel gets the same uniform number; blue - red is (2 - 0.25) * (1 - flip) *
    # count * gain = 1.75 times the fraction of the pixel's 4 samples that missed.
    missed = (a[..., 2] - a[..., 0]) / 1.75
    np.testing.assert_allclose(4 * missed, np.round(4 * missed), atol=1e-4)
    assert np.any(missed == 0.0) and np.any(np.isclose(missed, 1.0))


def test_nan_samples_are_dropped_and_counted_like_glsl(tmp_path):
    """Half the samples are NaN: dropped, counted, and the same ones as the GLSL host drops."""
    glsl = make_plugin(tmp_path, "nan_glsl", "glsl", """
        vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
            float zero = 0.0;
            return rng_next(rng) < 0.5 ? vec3(zero / zero) : vec3(1.0);
        }
        """)
    cl = make_plugin(tmp_path, "nan_cl", "opencl", """
        float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params) {
            return rng_next(rng) < 0.5f ? (float3)(NAN) : (float3)(1.0f);
        }
        """)
    dropped = {}
    for folder in (glsl, cl):
        r = Renderer(cornell_scene(), size=SIZE, integrator=str(folder), seed=9)
        image = r.render(spp=8)
        dropped[folder.name] = r.stats.dropped_samples
        assert np.all(np.isfinite(image)) and set(np.unique(image)) <= {0.0, 1.0}
        r.release()
    total = SIZE[0] * SIZE[1] * 8
    assert abs(dropped["nan_cl"] - total / 2) < 4 * np.sqrt(total / 4)  # binomial(total, 1/2)
    assert dropped["nan_cl"] == dropped["nan_glsl"]


# ---------------------------------------------------------------- errors and reload
BROKEN = """
    float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params) {
        float3 L = (float3)(0.0f);
        return L * undefined_gain;
    }
    """


def test_build_error_names_cl_file_and_line(tmp_path, capfd):
    folder = make_plugin(tmp_path / "plugins", "broken_cl", "opencl", BROKEN)
    from lift_gl.cli import main

    code = main(["render", CORNELL, "--plugins", str(tmp_path / "plugins"), "--integrator", "broken_cl",
                 "--spp", "1", "--size", "8x8", "--out", str(tmp_path / "x.npy")])
    assert code == 2
    err = capfd.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err  # one clear line: nothing from the compiler beside it
    assert f"{(folder / 'broken_cl.cl').resolve()}:4:" in lines[0] and "undefined_gain" in lines[0]


def test_hot_reload_of_an_opencl_plugin(tmp_path):
    folder = tmp_path / "ao_cl"
    shutil.copytree(REPO / "plugins" / "ao_cl", folder)
    source = folder / "ao_cl.cl"
    r = Renderer(cornell_scene(), size=SIZE, integrator=str(folder), seed=5)
    before = r.render(spp=4)
    text = source.read_text()
    source.write_text(text.replace("(float3)(0.0f) : (float3)(1.0f);", "(float3)(0.0f) : (float3)(0.5f);"))
    assert r.reload() is True
    np.testing.assert_array_equal(r.render(spp=4), 0.5 * before)
    source.write_text(text.replace("Surface s = ", "Surface s = oops + "))
    with pytest.raises(ShaderError) as err:
        r.reload()
    assert err.value.path == str(source.resolve())
    assert "oops" in str(err.value)
    r.reset()
    np.testing.assert_array_equal(r.render(spp=4), 0.5 * before)  # the last good kernel
    r.release()


def test_pyopencl_is_imported_only_for_opencl_plugins(tmp_path):
    code = ("import sys; from lift_gl.cli import main; "
            "main(['render', {scene!r}, '--integrator', {plugin!r}, '--spp', '1', '--size', '8x8', "
            "'--out', {out!r}]); print('pyopencl' in sys.modules)")
    for plugin, expected in (("ao", "False"), ("ao_cl", "True")):
        out = subprocess.run([sys.executable, "-c", code.format(scene=CORNELL, plugin=plugin, out=str(tmp_path / "x.npy"))],
                             capture_output=True, text=True, timeout=120)
        assert out.stdout.strip().splitlines()[-1] == expected, out.stdout + out.stderr


def test_missing_pyopencl_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyopencl", None)  # import pyopencl now raises ImportError
    with pytest.raises(LiftError) as err:
        Renderer(cornell_scene(), size=(8, 8), integrator="ao_cl")
    assert "lift-gl[opencl]" in str(err.value) and err.value.path.endswith("plugin.toml")
