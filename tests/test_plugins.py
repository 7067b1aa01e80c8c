"""Plugin manifests: discovery, validation with file:line errors, parameters, compile errors."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from lift_gl.errors import PluginError, ShaderError
from lift_gl.plugins import BUILTIN_DIR, discover, find_plugin, load_manifest

GOOD = """name = "mine"
description = "test plugin"
language = "glsl"
entry = "mine.glsl"
primary = "camera"

[params.gain]
type = "float"
default = 1.0
min = 0.0
max = 10.0
help = "multiplies the radiance"
"""
SHADER = "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(gain); }\n"


def make_plugin(tmp_path: Path, manifest=GOOD, shader=SHADER) -> Path:
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "plugin.toml").write_text(manifest)
    (folder / "mine.glsl").write_text(shader)
    return folder


def test_builtins_are_found():
    plugins = discover()
    assert {"pt", "debug"} <= set(plugins)
    assert plugins["pt"].params["max_depth"].type == "int"


def test_plugin_path_env_and_dirs(tmp_path, monkeypatch):
    make_plugin(tmp_path)
    monkeypatch.setenv("LIFT_GL_PLUGIN_PATH", str(tmp_path))
    assert "mine" in discover()
    monkeypatch.delenv("LIFT_GL_PLUGIN_PATH")
    assert "mine" not in discover()
    assert find_plugin("mine", [tmp_path]).params["gain"].default == 1.0


@pytest.mark.parametrize("bad, line, words", [
    (GOOD.replace('language = "glsl"', 'language = "cuda"'), 3, "language"),
    (GOOD.replace('primary = "camera"', 'primary = "raster"'), 5, "primary"),
    (GOOD.replace('type = "float"', 'type = "quaternion"'), 7, "type"),
    (GOOD.replace('entry = "mine.glsl"', 'entry = "missing.glsl"'), 4, "missing.glsl"),
    ("colour = 3\n" + GOOD, 1, "unknown key"),
    (GOOD + "extra = 3\n", 7, "unknown keys"),
    (GOOD.replace("default = 1.0", "default = 1.0.0"), 9, "malformed"),
    (GOOD.replace("default = 1.0", "default = 20.0"), 7, "outside"),
])
def test_bad_manifest_names_file_and_line(tmp_path, bad, line, words):
    folder = make_plugin(tmp_path, manifest=bad)
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    assert err.value.path.endswith("plugin.toml")
    assert err.value.line == line, str(err.value)
    assert words in str(err.value)


def test_param_parsing_and_bounds():
    pt = find_plugin("pt")
    assert pt.params["max_depth"].parse("7") == 7
    with pytest.raises(PluginError):
        pt.params["max_depth"].parse("-1")
    with pytest.raises(PluginError):
        pt.params["max_depth"].parse("seven")


def test_shader_compile_error_names_plugin_file_and_line(tmp_path):
    from lift_gl.renderer import Renderer
    from conftest import furnace_scene
    from lift_gl.scene import Material

    shader = "// line 1\n// line 2\nvec3 radiance(Ray ray, Hit hit, inout Rng rng) {\n    return undefined_name;\n}\n"
    folder = make_plugin(tmp_path, shader=shader)
    scene = furnace_scene(Material("m"))
    with pytest.raises(ShaderError) as err:
        Renderer(scene, size=(8, 8), integrator=str(folder))
    assert err.value.path == str((folder / "mine.glsl").resolve())
    assert err.value.line == 4
    assert "undefined_name" in str(err.value)


def test_parameters_become_uniforms(tmp_path):
    from lift_gl.renderer import Renderer
    from conftest import furnace_scene
    from lift_gl.scene import Material

    folder = make_plugin(tmp_path)
    renderer = Renderer(furnace_scene(Material("m")), size=(8, 8), integrator=str(folder), params={"gain": "2.5"})
    assert abs(renderer.render(spp=1) - 2.5).max() == 0.0
    renderer.set_params(gain=0.5)
    assert abs(renderer.render(spp=1) - 0.5).max() == 0.0
    with pytest.raises(PluginError):
        renderer.set_params(nonexistent=1)


def test_a_broken_manifest_hides_no_other_plugin(tmp_path):
    make_plugin(tmp_path, manifest=GOOD.replace('language = "glsl"', 'language = "cuda"'))
    broken = {}
    plugins = discover([tmp_path], broken)
    assert "pt" in plugins and "mine" in broken
    with pytest.raises(PluginError) as err:
        find_plugin("mine", [tmp_path])
    assert err.value.line == 3


# ---------------------------------------------------------------- compile-time parameters
COUNTED = GOOD + """
[params.count]
type = "int"
default = 3
min = 0
max = 100
define = "MINE_COUNT"
help = "also a compile-time constant"
"""
# The uniform and the define must agree in every program the host compiles.
COUNT_SHADER = "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(float(MINE_COUNT), float(count), gain); }\n"


def test_a_define_follows_its_parameter(tmp_path):
    from conftest import furnace_scene
    from lift_gl.renderer import Renderer
    from lift_gl.scene import Material

    folder = make_plugin(tmp_path, manifest=COUNTED, shader=COUNT_SHADER)
    renderer = Renderer(furnace_scene(Material("m")), size=(8, 8), integrator=str(folder))
    assert (renderer.render(spp=1)[..., :2] == 3.0).all()
    program = renderer.trace.program
    renderer.set_params(gain=2.0)  # no define: the same program
    assert renderer.trace.program is program
    renderer.set_params(count=7)   # a define: recompiled with the new value
    assert renderer.trace.program is not program
    image = renderer.render(spp=1)
    assert (image[..., :2] == 7.0).all() and (image[..., 2] == 2.0).all()


@pytest.mark.parametrize("define, words", [
    ('"MINE COUNT"', "preprocessor name"),
    ("3", "preprocessor name"),
    ('"HAS_COUNT"', "host"),
    ('"gain"', "already a parameter"),
])
def test_bad_defines_are_refused(tmp_path, define, words):
    folder = make_plugin(tmp_path, manifest=COUNTED.replace('"MINE_COUNT"', define))
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    assert err.value.line == 14 and words in str(err.value), str(err.value)


def test_only_int_parameters_have_defines(tmp_path):
    folder = make_plugin(tmp_path, manifest=GOOD.replace('help = "multiplies', 'define = "GAIN"\nhelp = "multiplies'))
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    assert err.value.line == 7 and "only an int parameter" in str(err.value)


def test_a_define_that_does_not_compile_changes_nothing(tmp_path):
    from conftest import furnace_scene
    from lift_gl.renderer import Renderer
    from lift_gl.scene import Material

    shader = ("float table[MINE_COUNT];  // a zero-sized array does not compile\n"
              "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { table[0] = float(count); return vec3(table[0]); }\n")
    folder = make_plugin(tmp_path, manifest=COUNTED, shader=shader)
    renderer = Renderer(furnace_scene(Material("m")), size=(8, 8), integrator=str(folder))
    with pytest.raises(ShaderError):
        renderer.set_params(count=0)
    assert renderer.params["count"] == 3 and (renderer.render(spp=1) == 3.0).all()
