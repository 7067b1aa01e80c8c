"""The native TOML format's new parts: plastic materials, base colour textures, environment
maps (with a rotation) and distant lights, and their mistakes."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.image_io import write_image
from lift_gl.scene.envmap import direction_to_uv
from lift_gl.scene.loader import SceneWarning, load_scene

SCENE = """[environment]
radiance = 2
map = "sky.pfm"
rotate = [0, 90, 0]

[[lights]]
type = "distant"
direction = [0, 1, 1]
irradiance = [3, 2, 1]

[materials.coat]
type = "plastic"
color = [0.2, 0.4, 0.6]
roughness = 0.3
ior = 1.4
nonlinear = true
texture = "grid.png"

[materials.lost]
texture = "nowhere.png"

[[objects]]
type = "sphere"
material = "coat"

[[objects]]
type = "box"
material = "lost"
center = [3, 0, 0]
"""


def test_plastic_texture_environment_map_and_distant_light(tmp_path):
    from PIL import Image
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "grid.png")
    write_image(tmp_path / "sky.pfm", np.ones((4, 8, 3), np.float32))
    (tmp_path / "s.toml").write_text(SCENE)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        scene = load_scene(tmp_path / "s.toml")
    messages = [str(w.message) for w in record if issubclass(w.category, SceneWarning)]
    assert len(messages) == 1 and "s.toml:20:" in messages[0] and "nowhere.png" in messages[0], messages
    coat = scene.materials[scene.spheres[0].material]
    assert coat.type == "plastic" and coat.nonlinear and coat.ior == 1.4
    assert coat.alpha == pytest.approx(0.09) and coat.texture == 0
    assert scene.materials[scene.meshes[0].material].texture is None  # fell back to its colour
    env = scene.environment
    np.testing.assert_allclose(env.radiance, 2)
    # rotate [0, 90, 0] turns the map's +x (u = 1/4 on the horizon) to world -z.
    np.testing.assert_allclose(direction_to_uv(np.linalg.inv(env.to_world) @ [0, 0, -1.0]), [0.25, 0.5], atol=1e-12)
    (light,) = scene.distant_lights
    np.testing.assert_allclose(light.direction, np.array([0, 1, 1]) / np.sqrt(2))
    np.testing.assert_allclose(light.irradiance, [3, 2, 1])


@pytest.mark.parametrize("text, line, message", [
    ('[environment]\nrotate = [0, 10, 0]\n', 2, "give 'map' too"),
    ('[environment]\nmap = "none.exr"\n', 2, "none.exr"),
    ('[[lights]]\ntype = "distant"\n', 1, "needs a 'direction'"),
    ('[[lights]]\ntype = "spot"\ndirection = [0, 1, 0]\n', 2, "unknown light type 'spot'"),
    ('[materials.p]\ntype = "plastic"\nnonlinear = 1\n', 3, "must be true or false"),
])
def test_bad_toml_additions_name_file_and_line(tmp_path, text, line, message):
    path = tmp_path / "bad.toml"
    path.write_text(text + '[[objects]]\ntype = "sphere"\n')
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.line == line and message in info.value.message, str(info.value)


def test_showcase_scene_loads_without_warnings():
    from conftest import REPO
    from lift_gl.scene.features import SceneFeatures
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneWarning)
        scene = load_scene(REPO / "scenes" / "showcase.toml")
    f = SceneFeatures.of(scene)
    assert f.textures and f.environment_map and f.plastic and f.rough_plastic and f.rough_conductor and f.dielectric
