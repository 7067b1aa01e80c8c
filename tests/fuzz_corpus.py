"""The fuzzer's corpus: seed inputs of every loader (tests/fuzz_harness.py TARGETS).

Two kinds of seeds, both mutated byte by byte by the fuzzer (fuzz_strategies.seeded) and
each run as it is by tests/test_fuzz_loaders.py:
- files of the repository: shipped scenes, camera paths and plugins, test data;
- the hostile cases of issue 32, built here (some are large or made of links), each with
  what it must give beyond the fuzzer's property (`expect`): 'loads', 'refused', 'warns'
  (loads with a warning saying what was changed or dropped, or is refused) or 'clean'
  (anything but an escape); and, where it matters, the line the refusal or warning names
  or a word its message must hold.

OPEN lists the cases that still fail, with who is fixing them; their tests are expected to
fail (strict: a case that starts passing fails the test until its name leaves OPEN).
"""
from __future__ import annotations

import base64
import functools
import io
import json
import re
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from fuzz_harness import DATA, FUZZ_DATA, REPO, SCENES, Case, Fifo, Link


@dataclass
class Seed:
    name: str
    target: str  # a fuzz_harness.TARGETS name
    build: Callable[[], Case]
    item: int | None = None  # the item of issue 32's list
    expect: str = "clean"  # loads | refused | warns | clean
    line: int | None = None  # the line its refusal (or first warning) names
    mentions: str | None = None  # a word its refusal (or first warning) holds
    mutate: bool = True  # False: too large or slow to mutate over and over (run as it is only)

    def case(self) -> Case:
        return self.build()

    def __repr__(self):
        return f"Seed({self.name!r})"


def _file_seed(path: Path, target: str, files=None, name: str = "") -> Seed:
    rel = path.relative_to(REPO).as_posix()
    return Seed(rel, target, lambda: Case(path.read_bytes(), dict(files or {}), f"seed {rel}", name=name),
                expect="loads")


def _self_contained(path: Path) -> bool:
    """A scene whose files lie beside it (covered_dragon.toml's mesh is in ../shared)."""
    return '"../' not in path.read_text(errors="replace")


def _plugin_seed(manifest: Path) -> Seed:
    folder = manifest.parent

    def build():
        files = {f.name: f.read_bytes() for f in folder.iterdir() if f.is_file() and f.name != "plugin.toml"}
        return Case(manifest.read_bytes(), files, f"seed {folder.name}")
    return Seed(f"plugins/{folder.name}", "plugin manifest", build, expect="loads")


# ---- builders of the issue's cases -----------------------------------------------------------

SCENE_HEAD = """\
[camera]
position = [0, 1, 5]
target = [0, 0.5, 0]

[environment]
radiance = 1
"""

QUAD = """
[[objects]]
type = "quad"
center = [0, 0, 0]
u = [0, 0, 2]
v = [2, 0, 0]
"""


def _text(main: str, files=None, how="", name="") -> Callable[[], Case]:
    return lambda: Case(main.encode("utf-8"), dict(files or {}), how, name=name)


def _toml_film(width: int, height: int) -> str:
    return SCENE_HEAD + f'\n[film]\nsize = [{width}, {height}]\nfilter = "triangle"\n' + QUAD


def _pfm(pixels: np.ndarray) -> bytes:
    h, w, _ = pixels.shape
    return f"PF\n{w} {h}\n-1.0\n".encode() + np.ascontiguousarray(pixels[::-1], "<f4").tobytes()


def _env_pfm(edit) -> bytes:
    px = np.full((4, 8, 3), 0.5, np.float32)
    edit(px)
    return _pfm(px)


ENV_SCENE = SCENE_HEAD.replace("radiance = 1\n", 'radiance = 1\nmap = "sky.pfm"\n') + """
[[objects]]
type = "sphere"
radius = 0.5
"""


def _png(width: int, height: int) -> bytes:
    """A 1-bit black PNG, written row by row (no pillow image of the full size is made)."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    row = b"\x00" + b"\x00" * ((width + 7) // 8)
    packer = zlib.compressobj(9)
    body = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0))
            + chunk(b"IDAT", body) + chunk(b"IEND", b""))


bomb_png = functools.lru_cache(maxsize=4)(_png)

TEXTURE_SCENE = SCENE_HEAD + """
[materials.textured]
texture = "tex.png"

[[objects]]
type = "quad"
material = "textured"
center = [0, 0, 0]
u = [0, 0, 2]
v = [2, 0, 0]
"""

PBRT_HEAD = """\
LookAt 0 1 5  0 0.5 0  0 1 0
Camera "perspective" "float fov" [40]
Film "image" "integer xresolution" [16] "integer yresolution" [16]
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
"""
PBRT_TRIANGLE = 'Shape "trianglemesh" "integer indices" [0 1 2] "point P" [-1 0 -1  1 0 -1  0 0 1]\n'


def _pbrt_fanout(levels: int) -> Case:
    files = {}
    for k in range(levels):
        line = f'Include "fan{k + 1}.pbrt"\n' if k + 1 < levels else 'Shape "sphere" "float radius" [0.1]\n'
        files[f"fan{k}.pbrt"] = (line * 2).encode()
    return Case((PBRT_HEAD + 'Include "fan0.pbrt"\n').encode(), files, f"Include fan-out, {levels} levels")


def _pbrt_instances(count: int) -> Case:
    text = (PBRT_HEAD + 'ObjectBegin "ball"\nShape "sphere" "float radius" [0.01]\nObjectEnd\n'
            + 'ObjectInstance "ball"\n' * count)
    return Case(text.encode(), {}, f"{count} ObjectInstances")


MITSUBA_HEAD = """\
<?xml version="1.0"?>
<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 1, 5" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
"""
MITSUBA_TAIL = "</scene>\n"


def _mitsuba(body: str, w: int = 16, h: int = 16) -> str:
    return MITSUBA_HEAD.format(w=w, h=h) + body + MITSUBA_TAIL


def gltf_triangle(light: dict | None = None, material: dict | None = None, images=None) -> dict:
    """A glTF 2.0 document: one triangle (embedded buffer), a camera and a directional light."""
    positions = np.array([[-1, 0, -1], [1, 0, -1], [0, 0, 1]], "<f4")
    indices = np.array([0, 1, 2, 0], "<u2")  # padded to 4 bytes
    blob = positions.tobytes() + indices.tobytes()
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 1, 5]},
                  {"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-0.383, 0, 0, 0.924]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [material or {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                                             "metallicFactor": 0.0}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}],
        "extensions": {"KHR_lights_punctual": {"lights": [light or {"type": "directional", "intensity": 3.0}]}},
        "extensionsUsed": ["KHR_lights_punctual"],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [-1, 0, -1], "max": [1, 0, 1]},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    if images:
        doc.update({"images": images, "textures": [{"source": 0}]})
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    return doc


def _gltf(doc, files=None, how="", prefix=b"") -> Callable[[], Case]:
    return lambda: Case(prefix + json.dumps(doc).encode(), dict(files or {}), how, name="scene.gltf")


OBJ = "# a triangle\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n"

PATH = """\
[[keyframe]]
time = 0.0
position = [0, 1, 6]
target = [0, 0.5, 0]

[[keyframe]]
time = 1.0
position = [1, 1, 6]
target = [1, 0.5, 0]
"""

MANIFEST = """\
name = "fuzzed"
description = "a plugin of the fuzz corpus"
language = "glsl"
entry = "{entry}"
"""
ENTRY = "{include}vec3 radiance(Ray ray, Hit hit, inout Rng rng) {{ return vec3(1.0); }}\n"
OUTSIDE = "../" * 24 + "etc/passwd"


def _plugin(entry="main.glsl", include="", files=None, prefix="") -> Callable[[], Case]:
    def build():
        shader = {"main.glsl": ENTRY.format(include=include).encode()}
        return Case((prefix + MANIFEST.format(entry=entry)).encode(), {**shader, **(files or {})}, "plugin")
    return build


BOM = "\ufeff"

ISSUE_CASES = [
    # 1. the pixel filter's table and the film's size
    Seed("i32-1-toml-film-1e8-triangle", "TOML scene", _text(_toml_film(10000, 10000)), 1, "loads"),
    Seed("i32-1-toml-film-1e12-triangle", "TOML scene", _text(_toml_film(1000000, 1000000)), 1),
    Seed("i32-1-mitsuba-film-1e6", "Mitsuba XML scene",
         _text(_mitsuba('<shape type="rectangle"/>\n', 1000, 1000)), 1, "loads"),
    # 2. far geometry
    Seed("i32-2-toml-box-at-1e8", "TOML scene", _text(SCENE_HEAD + """
[[objects]]
type = "box"
center = [0, 0.5, 0]

[[objects]]
type = "box"
center = [1e8, 0, 0]
"""), 2, "clean"),
    Seed("i32-2-toml-instance-at-3.5e38", "TOML scene", _text(SCENE_HEAD + """
[[objects]]
type = "box"
name = "crate"
center = [0, 0.5, 0]

[[instances]]
mesh = "crate"
translate = [3.5e38, 0, 0]
"""), 2, "warns"),
    Seed("i32-2-toml-quad-2e10", "TOML scene", _text(SCENE_HEAD + """
[[objects]]
type = "quad"
center = [0, 0, 0]
u = [0, 0, 2e10]
v = [2e10, 0, 0]
"""), 2, "loads"),
    # 3. environment-map texels
    Seed("i32-3-env-texel-minus-100", "environment map",
         _text(ENV_SCENE, {"sky.pfm": _env_pfm(lambda px: px.__setitem__((1, 2, 0), -100.0))}), 3, "warns"),
    Seed("i32-3-env-texel-nan", "environment map",
         _text(ENV_SCENE, {"sky.pfm": _env_pfm(lambda px: px.__setitem__((1, 2, 1), np.nan))}), 3, "warns"),
    Seed("i32-3-env-all-nan", "environment map",
         _text(ENV_SCENE, {"sky.pfm": _env_pfm(lambda px: px.fill(np.nan))}), 3, "warns"),
    # 4. negative emission
    Seed("i32-4-pbrt-negative-area-light", "pbrt scene", _text(
        PBRT_HEAD + 'AttributeBegin\nAreaLightSource "diffuse" "rgb L" [-5 -5 -5]\n' + PBRT_TRIANGLE
        + "AttributeEnd\n"), 4, "warns"),
    Seed("i32-4-mitsuba-negative-area-emitter", "Mitsuba XML scene", _text(_mitsuba(
        '<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="-10"/></emitter></shape>\n')),
         4, "warns"),
    Seed("i32-4-gltf-negative-directional-light", "glTF scene",
         _gltf(gltf_triangle(light={"type": "directional", "intensity": -5.0})), 4, "warns"),
    # 5. a camera path looking along its up vector
    Seed("i32-5-path-looks-along-up", "camera path", _text(PATH.replace("target = [1, 0.5, 0]",
                                                                         "target = [1, 5, 6]")), 5, "refused"),
    # 6. include and instance counts
    Seed("i32-6-pbrt-include-fanout-20", "pbrt scene", lambda: _pbrt_fanout(20), 6, "refused", mutate=False),
    Seed("i32-6-pbrt-200000-instances", "pbrt scene", lambda: _pbrt_instances(200_000), 6, mutate=False),
    # 8. internal errors
    Seed("i32-8-texture-decompression-bomb", "texture image",
         lambda: Case(TEXTURE_SCENE.encode(), {"tex.png": bomb_png(20000, 20000)}, "20000x20000 PNG"), 8, "warns",
         mutate=False),
    Seed("i32-8-pbrt-include-symlink-loop", "pbrt scene", lambda: Case(
        (PBRT_HEAD + 'Include "a.pbrt"\n').encode(), {"a.pbrt": Link("b.pbrt"), "b.pbrt": Link("a.pbrt")}),
         8, "refused"),
    Seed("i32-8-mitsuba-include-symlink-loop", "Mitsuba XML scene", lambda: Case(
        _mitsuba('<include filename="a.xml"/>\n').encode(), {"a.xml": Link("b.xml"), "b.xml": Link("a.xml")}),
         8, "refused"),
    Seed("i32-8-gltf-top-level-array", "glTF scene", _gltf([gltf_triangle()]), 8, "refused"),
    Seed("i32-8-gltf-emissive-strength-string", "glTF scene", _gltf(gltf_triangle(material={
        "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": "x"}}})),
         8, "refused"),
    Seed("i32-8-gltf-light-intensity-string", "glTF scene",
         _gltf(gltf_triangle(light={"type": "directional", "intensity": "bright"})), 8, "refused"),
    # 10. memory
    Seed("i32-10-texture-10000x10000", "texture image",
         lambda: Case(TEXTURE_SCENE.encode(), {"tex.png": bomb_png(10000, 10000)}, "10000x10000 PNG"), 10, "warns",
         mutate=False),
    Seed("i32-10-plugin-huge-array", "plugin manifest",
         _plugin(include="float a[100000000];\n"), 10),
    # 11. plugin containment
    Seed("i32-11-plugin-entry-outside", "plugin manifest", _plugin(entry=OUTSIDE), 11, "refused"),
    Seed("i32-11-plugin-include-outside", "plugin manifest", _plugin(include=f'#include "{OUTSIDE}"\n'),
         11, "refused"),
    Seed("i32-11-plugin-entry-links-outside", "plugin manifest",
         _plugin(files={"main.glsl": Link("/etc/passwd")}), 11, "refused"),
    # 12. messages and encodings
    Seed("i32-12-toml-bom", "TOML scene", _text(BOM + SCENE_HEAD + QUAD), 12, "loads"),
    Seed("i32-12-pbrt-bom", "pbrt scene", _text(BOM + PBRT_HEAD + PBRT_TRIANGLE), 12, "loads"),
    Seed("i32-12-manifest-bom", "plugin manifest", _plugin(prefix=BOM), 12, "loads"),
    Seed("i32-12-path-bom", "camera path", _text(BOM + PATH), 12, "loads"),
    Seed("i32-12-gltf-bom", "glTF scene", _gltf(gltf_triangle(), prefix=BOM.encode()), 12, "loads"),
    Seed("i32-12-obj-latin1-comment", "OBJ mesh",
         lambda: Case(b"# caf\xe9\n" + OBJ.encode(), {}, "Latin-1 comment"), 12, "loads"),
    Seed("i32-12-obj-bom", "OBJ mesh", _text(BOM + OBJ), 12, "loads"),
    Seed("i32-12-pbrt-nan", "pbrt scene", _text(PBRT_HEAD + 'Shape "sphere" "float radius" [nan]\n'),
         12, "refused", line=6, mentions="nan"),
    Seed("i32-12-pbrt-xresolution-0", "pbrt scene", _text(PBRT_HEAD.replace("xresolution\" [16]", "xresolution\" [0]")
                                                         + PBRT_TRIANGLE), 12, "refused", line=3,
         mentions="xresolution"),
    Seed("i32-12-toml-unknown-table", "TOML scene", _text(SCENE_HEAD + QUAD + "\n[[objcts]]\ntype = \"box\"\n"),
         12, "warns", line=14),
    Seed("i32-12-env-bad-exr-header", "environment map",
         lambda: Case(ENV_SCENE.replace("sky.pfm", "sky.exr").encode(), {"sky.exr": _bad_exr()}, "bad EXR header"),
         12, "refused"),
    # 13. accepted silently
    Seed("i32-13-toml-empty-scene", "TOML scene", _text(SCENE_HEAD), 13, "warns"),
    Seed("i32-13-pbrt-repeated-index", "pbrt scene", _text(
        PBRT_HEAD + 'Shape "trianglemesh" "integer indices" [0 0 1] "point P" [-1 0 -1  1 0 -1  0 0 1]\n'),
         13, "warns"),
    Seed("i32-13-gltf-negative-roughness", "glTF scene", _gltf(gltf_triangle(material={
        "pbrMetallicRoughness": {"roughnessFactor": -5.0, "metallicFactor": 0.0}})), 13, "warns"),
    Seed("i32-13-gltf-missing-texture", "glTF scene", _gltf(gltf_triangle(images=[{"uri": "nowhere.png"}])),
         13, "warns"),
    Seed("i32-13-pbrt-projective-transform", "pbrt scene", _text(
        PBRT_HEAD + "Transform [1 0 0 0.5  0 1 0 0  0 0 1 0  0 0 0 1]\n" + PBRT_TRIANGLE), 13, "warns"),
    Seed("i32-13-mitsuba-projective-transform", "Mitsuba XML scene", _text(_mitsuba(
        '<shape type="rectangle"><transform name="to_world">'
        '<matrix value="1 0 0 0  0 1 0 0  0 0 1 0  0 0.5 0 1"/></transform></shape>\n')), 13, "warns"),
]


def _truncated_png() -> bytes:
    """A 16x16 PNG cut in the middle of its pixel data (pillow reads its header, not its pixels)."""
    from PIL import Image
    out = io.BytesIO()
    Image.fromarray(np.arange(16 * 16 * 3, dtype=np.uint8).reshape(16, 16, 3)).save(out, format="PNG")
    data = out.getvalue()
    return data[:data.index(b"IDAT") + 24]


def _gltf_index_past_positions() -> dict:
    """The triangle with its third index 3, past its 3 positions."""
    doc = gltf_triangle()
    blob = bytearray(base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1]))
    blob[36 + 4:36 + 6] = struct.pack("<H", 3)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
    return doc



def _gltf_external_buffer() -> dict:
    """The triangle with its buffer in a file beside it, scene.bin."""
    doc = gltf_triangle()
    doc["buffers"][0]["uri"] = "scene.bin"
    return doc


# Escapes the fuzzer found, each fixed and kept as a regression case.
FUZZ_FOUND = [
    Seed("fuzz-path-keyframe-not-tables", "camera path", _text("keyframe = nan\n"), expect="refused",
         mentions="array of tables"),
    Seed("fuzz-pbrt-nul-in-include", "pbrt scene", _text(PBRT_HEAD + 'Include "a\0b.pbrt"\n'), expect="refused",
         line=6, mentions="NUL"),
    Seed("fuzz-pbrt-string-parameter-given-a-number", "pbrt scene",
         _text(PBRT_HEAD + 'Shape "plymesh" "string filename" [ -1e10 ]\n'), expect="refused", line=6,
         mentions="quoted strings"),
    Seed("fuzz-gltf-buffer-is-a-fifo", "glTF scene", lambda: _gltf(_gltf_external_buffer(), {"scene.bin": Fifo()})(),
         expect="refused", mentions="not a regular file"),
    Seed("fuzz-plugin-entry-symlink-loop", "plugin manifest",
         _plugin(files={"main.glsl": Link("loop-b.glsl"), "loop-b.glsl": Link("main.glsl")}), expect="refused",
         mentions="cannot be followed"),
    Seed("fuzz-plugin-entry-with-nul", "plugin manifest", _plugin(entry="main\\u0000.glsl"), expect="refused",
         line=4, mentions="NUL"),
    Seed("fuzz-plugin-include-with-nul", "plugin manifest", _plugin(include='#include "a\0b.glsl"\n'),
         expect="refused", mentions="not found"),
    Seed("fuzz-path-of-9-megabytes", "camera path", _text(PATH + "# " + "x" * (5 << 20) + "\n"), expect="refused",
         mentions="MAX_SETTINGS_BYTES"),
    Seed("fuzz-obj-vt-of-one-number", "OBJ mesh",
         _text("v -1 0 -1\nv 1 0 -1\nv 0 0 1\nvt 0\nvt 0.3 0.6\nvt 0.5 0.9\nf 1/1 2/2 3/3\n"), expect="warns",
         mentions="texture coordinates"),
    Seed("fuzz-gltf-truncated-png", "glTF scene", lambda: _gltf(gltf_triangle(images=[
        {"uri": "data:image/png;base64," + base64.b64encode(_truncated_png()).decode()}]))(), expect="warns"),
    Seed("fuzz-gltf-index-past-positions", "glTF scene", lambda: _gltf(_gltf_index_past_positions())(),
         expect="refused", mentions="vertex indices outside"),
    Seed("fuzz-plugin-entry-latin1", "plugin manifest",
         _plugin(files={"main.glsl": "// caf\xe9\n".encode("latin-1") + ENTRY.format(include="").encode()}),
         expect="refused", mentions="UTF-8"),
    Seed("fuzz-path-time-past-float64", "camera path",
         _text(PATH.replace("time = 1.0", "time = 1" + "0" * 400)), expect="refused", line=None,
         mentions="finite number"),
    Seed("fuzz-path-time-past-int64", "camera path", _text(PATH.replace("time = 1.0", "time = 1" + "0" * 30)),
         expect="loads"),
    Seed("fuzz-hdr-texture-of-no-rows", "texture image",
         _text(TEXTURE_SCENE.replace("tex.png", "tex.hdr"),
               {"tex.hdr": b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 4\n" + bytes(16)}),
         expect="warns", mentions="no pixels"),
    Seed("fuzz-environment-map-side-over-limit", "environment map",
         _text(ENV_SCENE.replace("sky.pfm", "sky.png"), {"sky.png": _png(100_000, 1)}), expect="refused",
         mentions="MAX_ENVIRONMENT_SIDE"),
    Seed("fuzz-glb-chunk-longer-than-file", "glTF scene",
         lambda: _glb(gltf_triangle(), bin_length=2_700_000_000), expect="refused", mentions="claims"),
    Seed("fuzz-glb-json-chunk-over-limit", "glTF scene",
         lambda: _glb(gltf_triangle(), json_length=1_500_000_000), expect="refused", mentions="MAX_SCENE_TEXT_BYTES"),
    Seed("fuzz-gltf-extension-name-an-array", "glTF scene",
         _gltf(dict(gltf_triangle(), extensionsUsed=[["KHR_lights_punctual"]])), expect="refused",
         mentions="must be a string"),
]


def _glb(doc: dict, json_length: int | None = None, bin_length: int | None = None) -> Case:
    """A .glb of the document and a small BIN chunk, with the chunks' lengths as claimed."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary = bytes(16)
    body = (struct.pack("<I", len(text) if json_length is None else json_length) + b"JSON" + text
            + struct.pack("<I", len(binary) if bin_length is None else bin_length) + b"BIN\0" + binary)
    return Case(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body, {}, "glb of claimed chunk lengths",
                name="scene.glb")


def _bad_exr() -> bytes:
    """sky.exr with a data window far larger than its pixels (OpenEXR prints a warning)."""
    import tempfile
    import OpenEXR

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sky.exr"
        with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                          {"RGB": np.ones((4, 8, 3), np.float32)}) as f:
            f.write(str(path))
        data = path.read_bytes()
    at = data.find(b"dataWindow\x00box2i\x00") + len(b"dataWindow\x00box2i\x00") + 4
    return data[:at] + struct.pack("<4i", 0, 0, 1 << 14, 1 << 14) + data[at + 16:]


# Cases of ISSUE_CASES that still fail, and whose part of issue 32 fixes them. A fixed case
# fails its (strict xfail) test until its name is removed here.
OPEN: dict[str, str] = {}


# Escapes the fuzzer still finds, known and not fixed yet: (target, kind, a regular expression
# of the message, where the fix belongs). The test suite's sample tolerates these (and counts
# them); the benchmark counts them as escapes.
KNOWN_ESCAPES: list[tuple[str, str, str, str]] = []


def known_escape(target: str, escape) -> bool:
    return any(t == target and k == escape.kind and re.search(p, escape.message)
               for t, k, p, _ in KNOWN_ESCAPES)


# ---- the repository's files -----------------------------------------------------------------

def _repository_seeds() -> list[Seed]:
    stress = SCENES / "stress"
    out = [_file_seed(p, "TOML scene") for p in sorted(SCENES.glob("*.toml")) + sorted(stress.glob("*.toml"))
           if _self_contained(p)]
    out.append(_file_seed(FUZZ_DATA / "path_scene.toml", "TOML scene"))
    out.append(_file_seed(DATA / "cornell_diffuse.toml", "TOML scene",
                          {"icosphere_smooth.obj": (DATA / "icosphere_smooth.obj").read_bytes()}))
    out += [_file_seed(p, "pbrt scene") for p in sorted(DATA.glob("*.pbrt")) + sorted(FUZZ_DATA.glob("*.pbrt"))]
    out += [_file_seed(p, "Mitsuba XML scene") for p in sorted(FUZZ_DATA.glob("*.xml"))]
    out += [_file_seed(p, "PLY mesh") for p in sorted(stress.glob("*.ply")) + sorted(DATA.glob("*.ply"))
            + sorted(FUZZ_DATA.glob("*.ply"))]
    out += [_file_seed(p, "OBJ mesh") for p in sorted(DATA.glob("*.obj"))]
    out += [_file_seed(p, "camera path") for p in sorted((SCENES / "paths").glob("*.toml"))]
    out += [_plugin_seed(p) for p in sorted((REPO / "plugins").glob("*/plugin.toml"))]
    for image in (DATA / "checker_4x4.png", REPO / "assets" / "textures" / "checker.png"):
        out.append(Seed(image.relative_to(REPO).as_posix(), "texture image",
                        lambda image=image: Case(TEXTURE_SCENE.encode(), {"tex.png": image.read_bytes()}),
                        expect="loads"))
    sky = REPO / "assets" / "env" / "sky.exr"
    out.append(Seed(sky.relative_to(REPO).as_posix(), "environment map",
                    lambda: Case(ENV_SCENE.replace("sky.pfm", "sky.exr").encode(), {"sky.exr": sky.read_bytes()}),
                    expect="loads"))
    out.append(Seed("tests: a grey 8x8 PFM", "environment map",
                    _text(ENV_SCENE, {"sky.pfm": _env_pfm(lambda px: None)}), expect="loads"))
    out.append(Seed("tests: the triangle glTF", "glTF scene", _gltf(gltf_triangle()), expect="loads"))
    out.append(Seed("tests: an 8x8 PFM reference", "reference image",
                    lambda: Case(_pfm(np.full((8, 8, 3), 0.25, np.float32)), name="reference.pfm"), expect="loads"))
    out.append(Seed("tests: a 16x16 PFM reference (downsampled)", "reference image",
                    lambda: Case(_pfm(np.full((16, 16, 3), 0.25, np.float32)), name="reference.pfm"),
                    expect="loads"))
    out.append(Seed("tests: a NaN PFM reference", "reference image",
                    lambda: Case(_pfm(np.full((8, 8, 3), np.nan, np.float32)), name="reference.pfm"),
                    expect="refused"))
    return out


SEEDS = _repository_seeds() + ISSUE_CASES + FUZZ_FOUND


def seeds_for(target: str, mutable: bool = False) -> list[Seed]:
    return [s for s in SEEDS if s.target == target and (s.mutate or not mutable)]
