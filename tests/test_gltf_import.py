"""The glTF 2.0 importer on files written here: materials, base colour texture (orientation
checked end to end through the G-buffer), node transforms, camera, directional light, the
default sky, the binary container, and malformed files."""
from __future__ import annotations

import base64
import io
import json
import struct
import warnings

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.tonemap import srgb_decode

# A 2x2 texture: top-left red, top-right green, bottom-left blue, bottom-right white.
TEXELS = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], np.uint8)


def png_bytes(pixels: np.ndarray) -> bytes:
    from PIL import Image
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="PNG")
    return out.getvalue()


def quad_buffer() -> tuple[bytes, list, list]:
    """A unit quad in the xy plane facing +z, glTF uvs (0, 0) at the top-left corner."""
    positions = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    normals = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blobs = [positions.tobytes(), normals.tobytes(), uvs.tobytes(), indices.tobytes()]
    views, accessors, offset = [], [], 0
    specs = [(5126, "VEC3", 4), (5126, "VEC3", 4), (5126, "VEC2", 4), (5123, "SCALAR", 6)]
    for i, (blob, (ctype, kind, count)) in enumerate(zip(blobs, specs)):
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob)})
        acc = {"bufferView": i, "componentType": ctype, "type": kind, "count": count}
        if i == 0:
            acc["min"], acc["max"] = [-1, -1, 0], [1, 1, 0]
        accessors.append(acc)
        offset += len(blob) + (-len(blob)) % 4
    data = b"".join(b + b"\0" * ((-len(b)) % 4) for b in blobs)
    return data, views, accessors


def gltf_document(buffer_uri=None, with_camera=True, with_light=True, extra_materials=()):
    data, views, accessors = quad_buffer()
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            # T R S: scale 2, rotate 90 degrees about y (quaternion x y z w), move up by 1.
            {"mesh": 0, "translation": [0, 1, 0], "rotation": [0, np.sin(np.pi / 4), 0, np.cos(np.pi / 4)],
             "scale": [2, 2, 2]},
            {"camera": 0, "translation": [5, 1, 0], "rotation": [0, np.sin(np.pi / 4), 0, np.cos(np.pi / 4)]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-np.sin(np.pi / 8), 0, 0, np.cos(np.pi / 8)]},
        ],
        "meshes": [{"name": "quad", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                                     "indices": 3, "material": 0}]}],
        "materials": [{"name": "painted", "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.25, 1.0, 1.0], "baseColorTexture": {"index": 0},
            "metallicFactor": 0.0, "roughnessFactor": 0.5}}, *extra_materials],
        "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(png_bytes(TEXELS)).decode()}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1}}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0,
                                                           "color": [1.0, 0.5, 0.25]}]}},
        "buffers": [{"byteLength": len(data),
                     "uri": buffer_uri or "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    if not with_camera:
        doc["scenes"][0]["nodes"].remove(1)
    if not with_light:
        doc["scenes"][0]["nodes"].remove(2)
    return doc, data


def load_quietly(path):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        scene = load_scene(path)
    return scene, [str(w.message) for w in record if issubclass(w.category, SceneWarning)]


def test_gltf_materials_transforms_camera_and_light(tmp_path):
    doc, _ = gltf_document()
    path = tmp_path / "quad.gltf"
    path.write_text(json.dumps(doc))
    scene, messages = load_quietly(path)
    assert messages == []
    (mesh,) = scene.meshes
    m = scene.materials[mesh.material]
    assert m.type == "plastic" and m.alpha == pytest.approx(0.25) and m.ior == 1.5
    np.testing.assert_allclose(m.base_color, [0.5, 0.25, 1.0])  # exact, from the JSON
    np.testing.assert_array_equal(scene.textures[m.texture].pixels[..., :3], TEXELS)
    # TRS: the quad (facing +z) turned 90 degrees about y faces +x, scaled 2, raised by 1.
    np.testing.assert_allclose(mesh.positions[:, 0], 0, atol=1e-6)
    np.testing.assert_allclose(np.sort(mesh.positions[:, 1]), [-1, -1, 3, 3], atol=1e-6)
    cam = scene.camera
    np.testing.assert_allclose(cam.position, [5, 1, 0], atol=1e-9)
    _, _, forward = cam.basis()
    np.testing.assert_allclose(forward, [-1, 0, 0], atol=1e-9)  # -z turned by 90 about y
    assert cam.fov_deg == pytest.approx(np.degrees(0.6))
    assert scene.film_size == (384, 256)
    (light,) = scene.distant_lights
    # Shining along -z tilted down by 45 degrees: it arrives from +z, tilted up.
    np.testing.assert_allclose(light.direction, [0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-9)
    np.testing.assert_allclose(light.irradiance, [3.0, 1.5, 0.75])
    assert scene.environment is None


def test_texture_orientation_end_to_end(tmp_path):
    """The camera looks at the quad's front: the image's top-left quarter of the quad shows
    the texture's top-left texel, and so on (glTF's uv origin is the image's top-left)."""
    doc, _ = gltf_document(with_light=False)
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = [1, 1, 1, 1]
    doc["nodes"][1]["translation"] = [10, 1, 0]  # far enough to see the whole 4x4 quad
    path = tmp_path / "quad.gltf"
    path.write_text(json.dumps(doc))
    scene, _ = load_quietly(path)
    w, h = 48, 32
    r = Renderer(scene, size=(w, h))
    albedo = r.aov("albedo").astype(np.float64)
    r.release()
    texels = srgb_decode(TEXELS.astype(np.float64) / 255.0)
    # Quadrant centres are 1 unit from the quad's centre, at distance 10 with tan(yfov/2):
    # that many pixels from the image's centre.
    d = int(round(1.0 / (10 * np.tan(0.3)) * h / 2))
    for row, col in np.ndindex(2, 2):
        y = h // 2 - d if row == 0 else h // 2 + d - 1
        x = w // 2 - d if col == 0 else w // 2 + d - 1
        # Near the texel's centre, bilinear filtering leaves that texel dominant: of the four
        # texels, it is the closest colour (a flipped or mirrored texture picks another).
        distance = np.abs(texels.reshape(4, 3) - albedo[y, x]).sum(axis=1)
        assert np.argmin(distance) == 2 * row + col, ((row, col), albedo[y, x])
        assert distance.min() < 0.3


def test_glb_container_and_default_sky(tmp_path):
    doc, data = gltf_document(buffer_uri="unused", with_camera=False, with_light=False,
                              extra_materials=[{"name": "lamp", "emissiveFactor": [1, 1, 1],
                                                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}])
    del doc["buffers"][0]["uri"]
    body = json.dumps(doc).encode()
    body += b" " * ((-len(body)) % 4)
    data += b"\0" * ((-len(data)) % 4)
    glb = (struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(body) + 8 + len(data))
           + struct.pack("<I4s", len(body), b"JSON") + body + struct.pack("<I4s", len(data), b"BIN\0") + data)
    path = tmp_path / "quad.glb"
    path.write_bytes(glb)
    scene, messages = load_quietly(path)
    assert len(scene.meshes) == 1 and scene.materials[0].type == "plastic"
    # No light in the file: a white sky, and a camera that frames the quad.
    np.testing.assert_allclose(scene.environment.radiance, 1.0)
    assert np.linalg.norm(scene.camera.target - [0, 1, 0]) < 1e-6
    # A material that emits is read with its strength (not used by the quad, so no sky change).
    doc2, _ = gltf_document(with_light=False, extra_materials=[])
    doc2["materials"][0]["emissiveFactor"] = [0.5, 0.5, 0.5]
    doc2["materials"][0]["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}
    (tmp_path / "lamp.gltf").write_text(json.dumps(doc2))
    lamp_scene, _ = load_quietly(tmp_path / "lamp.gltf")
    np.testing.assert_allclose(lamp_scene.materials[0].emission, 2.0)
    assert lamp_scene.environment is None  # it is lit by its own emission


def test_metal_and_unsupported_features_warn(tmp_path):
    doc, _ = gltf_document()
    pbr = doc["materials"][0]["pbrMetallicRoughness"]
    pbr["metallicFactor"] = 0.7
    pbr["metallicRoughnessTexture"] = {"index": 0}
    doc["materials"][0]["normalTexture"] = {"index": 0}
    doc["materials"][0]["alphaMode"] = "BLEND"
    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["type"] = "point"
    doc["extensionsUsed"].append("KHR_texture_transform")
    path = tmp_path / "q.gltf"
    path.write_text(json.dumps(doc))
    scene, messages = load_quietly(path)
    m = scene.materials[0]
    assert m.type == "conductor" and m.texture is not None  # F0 = textured base colour
    for text in ("metallic-roughness textures", "normal maps", "alphaMode", "between 0 and 1", "'point' lights",
                 "KHR_texture_transform is not supported"):
        assert sum(text in msg for msg in messages) == 1, (text, messages)
    assert not scene.distant_lights and scene.environment is not None


@pytest.mark.parametrize("content, ext, text", [
    (b"{ not json", ".gltf", "not a readable glTF file"),
    (b"GLTF1234", ".glb", "not a binary glTF"),
    (json.dumps({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}).encode(), ".gltf",
     "no triangles"),
])
def test_bad_gltf_is_one_clear_error(tmp_path, content, ext, text):
    path = tmp_path / f"bad{ext}"
    path.write_bytes(content)
    with pytest.raises(SceneError) as info:
        load_quietly(path)
    assert text in info.value.message and str(path) in str(info.value)


def test_vertex_index_past_the_positions_is_one_clear_error(tmp_path):
    """A triangle naming vertex 4 of a quad's 4 (the fuzzer's case: trimesh keeps such faces
    and its normals then fail with an IndexError)."""
    doc, data = gltf_document()
    data = bytearray(data)
    last_index = 48 + 48 + 32 + 10   # positions, normals, uvs, then the sixth uint16 index
    data[last_index:last_index + 2] = struct.pack("<H", 4)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(data)).decode()
    path = tmp_path / "bad_index.gltf"
    path.write_text(json.dumps(doc))
    with pytest.raises(SceneError) as info:
        load_quietly(path)
    assert "vertex indices outside 0..3" in info.value.message and str(path) in str(info.value)
