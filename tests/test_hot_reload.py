"""Hot reload, headless: an edit to a plugin's files recompiles it and restarts accumulation;
a broken edit raises its error with file and line and keeps the last good program; a
parameter change restarts accumulation.

The plugin is a temporary copy of `ao`. AO samples are exactly 0 or 1, and a reset renderer
with the same seed draws the same random numbers, so an edit that scales the result by 1/2
must give exactly half the image: any sample left over from before the edit would show.
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import PluginError, ShaderError
from lift_gl.renderer import Renderer
from lift_gl.testing import cornell_scene

SIZE = (32, 32)
UNOCCLUDED = "return trace_occluded(probe) ? vec3(0.0) : vec3(1.0);"


@pytest.fixture
def ao_copy(tmp_path):
    folder = tmp_path / "ao"
    shutil.copytree(REPO / "plugins" / "ao", folder)
    return folder


@pytest.fixture
def renderer(ao_copy):
    r = Renderer(cornell_scene(), size=SIZE, integrator=str(ao_copy), seed=5)
    yield r
    r.release()


def edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def line_of(path, needle) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def test_no_change_no_reload(renderer):
    renderer.render(spp=4)
    assert renderer.reload() is False
    assert renderer.stats.spp == 4  # accumulation untouched


def test_shader_edit_recompiles_and_restarts_accumulation(renderer, ao_copy):
    before = renderer.render(spp=8)
    assert 0.2 < before.mean() < 0.9
    edit(ao_copy / "ao.glsl", UNOCCLUDED, UNOCCLUDED.replace("vec3(1.0)", "vec3(0.5)"))
    assert renderer.reload() is True
    assert renderer.stats.spp == 0 and renderer.frame_index == 0
    after = renderer.render(spp=8)
    np.testing.assert_array_equal(after, 0.5 * before)
    assert renderer.stats.dropped_samples == 0


def test_broken_edit_keeps_last_good_program_and_reports_file_and_line(renderer, ao_copy):
    shader = ao_copy / "ao.glsl"
    good = renderer.render(spp=8)
    edit(shader, UNOCCLUDED, "float oops = undefined_occlusion;\n    " + UNOCCLUDED)
    with pytest.raises(ShaderError) as err:
        renderer.reload()
    assert err.value.path == str(shader.resolve())
    assert err.value.line == line_of(shader, "undefined_occlusion")
    assert "undefined_occlusion" in str(err.value)
    assert renderer.reload_error is err.value
    # The renderer goes on with the last good program, from where it was.
    assert renderer.stats.spp == 8
    renderer.reset()
    np.testing.assert_array_equal(renderer.render(spp=8), good)
    # The same broken files are reported once, not on every poll.
    assert renderer.reload() is False
    # Fixing the file reloads it.
    edit(shader, "float oops = undefined_occlusion;\n    ", "")
    assert renderer.reload() is True
    assert renderer.reload_error is None
    np.testing.assert_array_equal(renderer.render(spp=8), good)


def test_edit_of_an_included_file_reloads(tmp_path):
    folder = tmp_path / "glow"
    folder.mkdir()
    (folder / "plugin.toml").write_text('name = "glow"\nentry = "glow.glsl"\n')
    (folder / "glow.glsl").write_text('#include "brightness.glsl"\n'
                                      "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(brightness()); }\n")
    helper = folder / "brightness.glsl"
    helper.write_text("float brightness() { return 2.0; }\n")
    r = Renderer(cornell_scene(), size=(8, 8), integrator=str(folder))
    assert np.all(r.render(spp=1) == 2.0)
    helper.write_text("float brightness() { return 3.0; }\n")
    assert r.reload() is True
    assert np.all(r.render(spp=1) == 3.0)
    r.release()


def test_manifest_edit_new_default_and_broken_manifest(renderer, ao_copy):
    manifest = ao_copy / "plugin.toml"
    renderer.render(spp=2)
    edit(manifest, "default = 1.0", "default = 0.25")
    assert renderer.reload() is True
    assert renderer.params["radius"] == 0.25
    edit(manifest, 'type = "float"', 'type = "quaternion"')
    with pytest.raises(PluginError) as err:
        renderer.reload()
    assert err.value.path == str(manifest.resolve()) and err.value.line == line_of(manifest, "[params.radius]")
    assert renderer.params["radius"] == 0.25  # the last good manifest still holds
    renderer.render(spp=2)


def test_a_setting_survives_a_reload_where_it_still_applies(ao_copy):
    r = Renderer(cornell_scene(), size=(8, 8), integrator=str(ao_copy), params={"radius": 0.3})
    edit(ao_copy / "plugin.toml", "default = 1.0", "default = 0.25")
    assert r.reload() is True
    assert r.params["radius"] == 0.3  # what the caller set wins over the new default
    edit(ao_copy / "plugin.toml", "default = 0.25\nmin = 0.0", "default = 0.75\nmin = 0.5")
    assert r.reload() is True
    assert r.params["radius"] == 0.75  # 0.3 is out of the new range: the new default
    r.release()


def test_switching_primary_hit_source_on_reload(renderer, ao_copy):
    """primary = "camera" drops the G-buffer pass, "gbuffer" brings it back; each renders what
    a renderer built for that manifest renders."""
    manifest = ao_copy / "plugin.toml"
    for primary in ("camera", "gbuffer"):
        edit(manifest, 'primary = "gbuffer"' if primary == "camera" else 'primary = "camera"', f'primary = "{primary}"')
        assert renderer.reload() is True
        assert (renderer.gbuffer is None) == (primary == "camera")
        fresh = Renderer(cornell_scene(), size=SIZE, integrator=str(ao_copy), seed=5)
        np.testing.assert_array_equal(renderer.render(spp=4), fresh.render(spp=4))
        fresh.release()


def test_parameter_change_restarts_accumulation(renderer):
    renderer.render(spp=8)
    renderer.set_params(radius=0.1)
    assert renderer.stats.spp == 0 and renderer.frame_index == 0
    small = renderer.render(spp=8)
    # Only the new radius is in the image: rendered from scratch with it, it is identical.
    fresh = Renderer(cornell_scene(), size=SIZE, integrator=str(renderer.plugin.folder), seed=5,
                     params={"radius": 0.1})
    np.testing.assert_array_equal(small, fresh.render(spp=8))
    fresh.release()
