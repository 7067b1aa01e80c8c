"""The pbrt-v3 subset of Lift's scenes beyond the Cornell box: substrate, image textures
(and a missing one), infinite lights with a map, distant lights; on small files written
here, against pbrt-v3's documented conventions, and malformed input."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.image_io import write_image
from lift_gl.scene.envmap import direction_to_uv
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.scene.optics import fresnel_dielectric

CAMERA = """LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "image" "integer xresolution" [ 32 ] "integer yresolution" [ 24 ]
WorldBegin
"""
QUAD = 'Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ] "point P" [ -1 -1 0 1 -1 0 1 1 0 -1 1 0 ] "float uv" [ 0 0 1 0 1 1 0 1 ]\n'


def write(tmp_path, body: str, name="scene.pbrt"):
    path = tmp_path / name
    path.write_text(CAMERA + body + "WorldEnd\n")
    return path


def load_quietly(path):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        scene = load_scene(path)
    return scene, [str(w.message) for w in record if issubclass(w.category, SceneWarning)]


def test_substrate_becomes_plastic_with_pbrt_roughness(tmp_path):
    path = write(tmp_path, """MakeNamedMaterial "A" "string type" [ "substrate" ] "rgb Ks" [ 0.04 0.04 0.04 ] "rgb Kd" [ 0.2 0.3 0.4 ] "float uroughness" [ 0.1 ] "float vroughness" [ 0.1 ] "bool remaproughness" [ "false" ]
MakeNamedMaterial "B" "string type" [ "substrate" ] "rgb Kd" [ 0.5 0.5 0.5 ]
MakeNamedMaterial "C" "string type" [ "substrate" ] "rgb Ks" [ 0.04 0.04 0.04 ] "float uroughness" [ 0 ] "float vroughness" [ 0 ] "bool remaproughness" [ "false" ]
NamedMaterial "A"
""" + QUAD + 'NamedMaterial "B"\n' + QUAD + 'NamedMaterial "C"\n' + QUAD)
    scene, messages = load_quietly(path)
    assert messages == []
    a, b, c = (scene.materials[m.material] for m in scene.meshes)
    assert a.type == b.type == c.type == "plastic"
    np.testing.assert_allclose(a.base_color, [0.2, 0.3, 0.4])
    assert a.alpha == pytest.approx(0.1)
    # The coat's index reproduces Ks at normal incidence: Ks = 0.04 is glass of index 1.5.
    assert a.ior == pytest.approx(1.5, rel=1e-6)
    assert float(fresnel_dielectric(1.0, b.ior)) == pytest.approx(0.5, rel=1e-6)  # default Ks 0.5
    # pbrt-v3's defaults: roughness 0.1, remapped (TrowbridgeReitz RoughnessToAlpha).
    x = np.log(0.1)
    assert b.alpha == pytest.approx(1.62142 + 0.819955 * x + 0.1734 * x ** 2 + 0.0171201 * x ** 3
                                    + 0.000640711 * x ** 4)
    assert c.alpha == 0.0  # a smooth coat


def test_imagemap_texture_and_a_missing_one(tmp_path):
    from PIL import Image
    pixels = np.arange(4 * 3 * 3, dtype=np.uint8).reshape(3, 4, 3) * 7
    (tmp_path / "tex").mkdir()
    Image.fromarray(pixels).save(tmp_path / "tex" / "wood.tga")
    path = write(tmp_path, """Texture "T1" "spectrum" "imagemap" "string filename" [ "tex/wood.tga" ] "bool trilinear" [ "true" ] "float scale" [ 0.5 ]
Texture "T2" "spectrum" "imagemap" "string filename" [ "tex/lost.tga" ]
Texture "T3" "spectrum" "imagemap" "string filename" [ "tex/wood.tga" ] "bool gamma" [ "false" ]
MakeNamedMaterial "Wood" "string type" [ "matte" ] "texture Kd" [ "T1" ]
MakeNamedMaterial "Lost" "string type" [ "matte" ] "texture Kd" [ "T2" ]
MakeNamedMaterial "Lost2" "string type" [ "substrate" ] "texture Kd" [ "T2" ]
MakeNamedMaterial "Raw" "string type" [ "matte" ] "texture Kd" [ "T3" ]
NamedMaterial "Wood"
""" + QUAD + 'NamedMaterial "Lost"\n' + QUAD + 'NamedMaterial "Lost2"\n' + QUAD + 'NamedMaterial "Raw"\n' + QUAD)
    scene, messages = load_quietly(path)
    # One warning for the missing file, naming the Texture line, though two materials use it.
    lost = [m for m in messages if "lost.tga" in m]
    assert len(lost) == 1 and "scene.pbrt:6:" in lost[0], messages
    wood, lost_m, lost2, raw = (scene.materials[m.material] for m in scene.meshes)
    assert wood.texture is not None and len(scene.textures) == 2
    tex = scene.textures[wood.texture]
    np.testing.assert_array_equal(tex.pixels[..., :3], pixels)  # row 0 = the image's top
    assert tex.srgb and not scene.textures[raw.texture].srgb
    np.testing.assert_allclose(wood.base_color, 0.5)  # the texture's scale
    assert lost_m.texture is None and np.allclose(lost_m.base_color, 0.5)  # matte's default Kd
    assert lost2.texture is None and lost2.type == "plastic"
    # uvs come through from "float uv".
    np.testing.assert_allclose(scene.meshes[0].uvs, [[0, 0], [1, 0], [1, 1], [0, 1]])


def test_infinite_light_map_follows_pbrt_orientation(tmp_path):
    """pbrt-v3: Le(d) = map(phi(w) / 2pi, theta(w) / pi) with w = WorldToLight(d) (z up,
    phi = atan2(w.y, w.x)) and row 0 of the image at theta = 0."""
    h, w = 4, 8
    image = np.zeros((h, w, 3), np.float32)
    image[1, 2] = (5.0, 6.0, 7.0)
    write_image(tmp_path / "sky.pfm", image)
    path = write(tmp_path, """AttributeBegin
  Rotate 30 1 1 0
  Scale 1 1 1
  LightSource "infinite" "string mapname" [ "sky.pfm" ] "rgb L" [ 2 2 2 ]
AttributeEnd
""" + QUAD)
    scene, messages = load_quietly(path)
    env = scene.environment
    assert env is not None and env.image.shape == (h, w, 3)
    np.testing.assert_allclose(env.radiance, 2.0)
    np.testing.assert_array_equal(env.image, image)
    # Where pbrt puts the texel's centre in the world...
    u, v = (2 + 0.5) / w, (1 + 0.5) / h
    phi, theta = 2 * np.pi * u, np.pi * v
    p_light = np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    from lift_gl.scene.primitives import axis_angle_matrix
    d_world = axis_angle_matrix(30, (1, 1, 0))[:3, :3] @ p_light
    # ...lift-gl must look the same texel up. This LookAt puts pbrt's image right (up x dir)
    # on world -x, so the loader mirrors the world in x (see pbrt_loader): the texel's
    # direction is mirrored with it.
    d_world = np.diag([-1.0, 1.0, 1.0]) @ d_world
    d_map = np.linalg.inv(env.to_world) @ d_world
    np.testing.assert_allclose(direction_to_uv(d_map), [u, v], atol=1e-9)


def test_distant_light_and_mirrored_camera(tmp_path):
    """The LookAt of tests/data/unknown_directive.pbrt makes the loader mirror the world in
    x (test_scene_loading.py); lights must be mirrored with it."""
    path = tmp_path / "s.pbrt"
    path.write_text("""LookAt 0 1 6.8  0 1 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
WorldBegin
AttributeBegin
  Rotate 90 0 0 1
  LightSource "distant" "point from" [ 1 2 3 ] "point to" [ 0 0 1 ] "rgb L" [ 3 3 3 ] "rgb scale" [ 1 2 1 ]
AttributeEnd
LightSource "distant" "rgb L" [ 1 1 1 ]
""" + QUAD + "WorldEnd\n")
    scene, messages = load_quietly(path)
    first, second = scene.distant_lights
    np.testing.assert_allclose(first.irradiance, [3, 6, 3])
    # Rotating (1, 2, 2) by 90 degrees about z gives (-2, 1, 2); the mirror flips x.
    np.testing.assert_allclose(first.direction, np.array([2, 1, 2]) / 3, atol=1e-12)
    # Default from (0,0,0) to (0,0,1): light arrives from -z.
    np.testing.assert_allclose(second.direction, [0, 0, -1], atol=1e-12)


@pytest.mark.parametrize("body, line, text", [
    ('Texture "T" "spectrum" "imagemap"\nMakeNamedMaterial "M" "string type" [ "matte" ] "texture Kd" [ "T" ]\n',
     5, "needs \"string filename\""),
    ('LightSource "infinite" "string mapname" [ "nowhere.exr" ]\n', 5, "nowhere.exr"),
    ('LightSource "distant" "point from" [ 0 0 0 ] "point to" [ 0 0 0 ]\n', 5, "'from' equals 'to'"),
    ('Texture "T" "spectrum"\n', 5, "Texture needs"),
])
def test_bad_pbrt_input_names_file_and_line(tmp_path, body, line, text):
    path = write(tmp_path, body + QUAD)
    with pytest.raises(SceneError) as info:
        load_quietly(path)
    assert info.value.line == line and text in info.value.message, str(info.value)
    assert str(info.value).startswith(f"{path}:{line}: ")


def test_unsupported_texture_kinds_and_unknown_textures_warn(tmp_path):
    path = write(tmp_path, """Texture "C" "spectrum" "checkerboard" "float uscale" [ 4 ]
MakeNamedMaterial "M" "string type" [ "matte" ] "texture Kd" [ "C" ]
MakeNamedMaterial "N" "string type" [ "matte" ] "texture Kd" [ "Nope" ]
NamedMaterial "M"
""" + QUAD + 'NamedMaterial "N"\n' + QUAD)
    scene, messages = load_quietly(path)
    assert any("scene.pbrt:5:" in m and "'checkerboard' textures are not supported" in m for m in messages), messages
    assert any("scene.pbrt:7:" in m and "unknown texture 'Nope'" in m for m in messages), messages
    assert all(scene.materials[m.material].texture is None for m in scene.meshes)
