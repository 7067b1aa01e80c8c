"""Hostile sizes are refused before anything is allocated, with the limit named; values that
would be NaN or Inf on the GPU are refused (or their triangles dropped) with file:line; and
what goes wrong on the GPU anyway is counted and reported: NaN/Inf samples, and paths that
the driver's loop limit cuts short."""
from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from lift_gl import limits
from lift_gl.cli import main
from lift_gl.errors import LimitError, SceneError
from lift_gl.gl.context import create_context
from lift_gl.passes.common import SCENE_BINDINGS
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Mesh, Scene, Sphere
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.scene.mesh_io import MAX_MESH_ELEMENTS
from lift_gl.scene.pack import pack_scene
from lift_gl.scene import pbrt_loader
from lift_gl.scene import primitives as prim

FURNACE = REPO / "scenes" / "furnace.toml"
PLY_HEAD = ("ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n")


def forbid(monkeypatch, target: str):
    """Make `target` (module.attribute) fail loudly if anything calls it."""
    def called(*args, **kwargs):
        raise AssertionError(f"{target} was called: the limit was checked too late")
    monkeypatch.setattr(target, called)


def is_llvmpipe() -> bool:
    return "llvmpipe" in create_context().info["GL_RENDERER"]


# ---------------------------------------------------------------- PLY headers
def test_ply_header_claiming_1e12_vertices_is_refused_before_trimesh_reads_it(tmp_path, monkeypatch):
    ply = tmp_path / "liar.ply"
    ply.write_bytes(PLY_HEAD.format(n=10 ** 12).encode() + bytes(64))
    scene = tmp_path / "scene.toml"
    scene.write_text(f'[[objects]]\ntype = "sphere"\n\n[[objects]]\ntype = "mesh"\nfile = "{ply.name}"\n')
    forbid(monkeypatch, "trimesh.load")
    with pytest.raises(SceneError) as info:
        load_scene(scene)
    err = info.value
    assert err.path == str(scene) and err.line == 6  # the scene's `file =` line...
    assert "liar.ply" in err.message and "1,000,000,000,000" in err.message  # ...the file, the claim
    assert f"MAX_MESH_ELEMENTS = {MAX_MESH_ELEMENTS:,}" in err.message  # ...and the limit


def test_ply_header_claiming_more_than_the_file_holds_is_refused(tmp_path, monkeypatch):
    ply = tmp_path / "short.ply"
    ply.write_bytes(PLY_HEAD.format(n=1_000_000).encode() + bytes(100))
    forbid(monkeypatch, "trimesh.load")
    with pytest.raises(SceneError, match=r"1,000,000 vertex elements \(at least 12,000,000 bytes\), but the "
                                         r"file has only 100 bytes"):
        load_scene(ply)


# ---------------------------------------------------------------- the film
@pytest.mark.parametrize("size, limit", [((100_000, 100_000), "GL_MAX_TEXTURE_SIZE"),
                                         ((16_000, 16_000), "MAX_FILM_BYTES")])
def test_huge_film_is_refused_before_any_buffer(monkeypatch, size, limit):
    for target in ("lift_gl.renderer.pack_scene", "lift_gl.renderer.SceneBuffers",
                   "lift_gl.frame_passes.TracePass", "lift_gl.frame_passes.AccumulatePass"):
        forbid(monkeypatch, target)
    with pytest.raises(LimitError, match=limit) as info:
        Renderer(load_scene(FURNACE), size=size)
    assert f"{size[0]}x{size[1]}" in str(info.value)


def test_huge_film_from_the_scene_file_names_the_file(tmp_path):
    scene = tmp_path / "big.toml"
    scene.write_text('[film]\nsize = [100000, 100000]\n\n[[objects]]\ntype = "sphere"\n')
    with pytest.raises(LimitError, match="GL_MAX_TEXTURE_SIZE") as info:
        Renderer(load_scene(scene))
    assert str(info.value).startswith(f"{scene}: ")


def test_cli_refuses_a_huge_size_with_one_line(capsys, tmp_path):
    code = main(["render", str(FURNACE), "--size", "100000x100000", "--out", str(tmp_path / "x.png")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "GL_MAX_TEXTURE_SIZE" in err
    assert not (tmp_path / "x.png").exists()


# ---------------------------------------------------------------- shader storage buffers
def test_limits_come_from_the_context():
    ctx = create_context()
    lim = limits.GlLimits.query(ctx)
    assert lim.max_ssbo_bytes == ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"] > 0
    assert lim.max_texture_size == ctx.info["GL_MAX_TEXTURE_SIZE"] > 0
    if is_llvmpipe():
        assert lim.max_ssbo_bytes == 128 << 20  # FACTS.md


def test_scene_over_the_split_heap_is_refused_before_the_bvh_is_built(monkeypatch):
    """A real one: one triangle more than the split heap can hold even without a BVH
    (split.MAX_HEAP_CHUNKS buffers of GL_MAX_SHADER_STORAGE_BLOCK_SIZE, 152 bytes of triangle
    data a triangle: 7.1 million triangles on llvmpipe), all sharing three vertices. Scenes
    below that are split across buffers (tests/test_split_buffers.py)."""
    lim = limits.GlLimits.query(create_context())
    count = limits._heap_bytes_allowed(lim) // limits.TRIANGLE_HEAP_BYTES + 1
    mesh = Mesh("many", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((count, 3), np.int32) + [0, 1, 2], 0)
    scene = Scene(camera=Camera([0, 0, 3], [0, 0, 0]), materials=[Material("m")], meshes=[mesh])
    forbid(monkeypatch, "lift_gl.renderer.pack_scene")
    with pytest.raises(LimitError) as info:
        Renderer(scene, size=(8, 8))
    message = str(info.value)
    assert f"{count:,} triangles" in message and "GL_MAX_SHADER_STORAGE_BLOCK_SIZE" in message
    assert f"{lim.max_ssbo_bytes / (1 << 20):,.1f} MiB" in message


def test_packed_buffers_are_checked_exactly(monkeypatch):
    """Every buffer, not only the triangles': with a 1000-byte limit, 40 spheres (32 bytes
    each) pass the triangle estimate (there are none) but not the exact check."""
    real = limits.GlLimits.query(create_context())
    tiny = limits.GlLimits(real.renderer, real.max_texture_size, real.max_framebuffer, real.max_viewport, 1000)
    monkeypatch.setattr("lift_gl.renderer.GlLimits.query", classmethod(lambda cls, ctx, max_buffer_bytes=None: tiny))
    forbid(monkeypatch, "lift_gl.renderer.SceneBuffers")
    spheres = [Sphere([i, 0, 0], 0.4, 0) for i in range(40)]
    scene = Scene(camera=Camera([0, 0, 50], [0, 0, 0]), materials=[Material("m")], spheres=spheres)
    with pytest.raises(LimitError, match="'spheres' buffer needs 0.0 MiB .* 0.0 MiB"):
        Renderer(scene, size=(8, 8))
    fewer = Scene(camera=scene.camera, materials=scene.materials, spheres=spheres[:30])  # 960 bytes
    limits.check_packed(pack_scene(fewer), tiny, SCENE_BINDINGS)


# ---------------------------------------------------------------- values the GPU cannot hold
def test_values_beyond_float32_are_refused_with_file_and_line(tmp_path):
    scene = tmp_path / "bright.toml"
    scene.write_text('[materials.sun]\nemission = 1e39\n\n[[objects]]\ntype = "sphere"\nmaterial = "sun"\n')
    with pytest.raises(SceneError, match="emission must be 3 finite values") as info:
        load_scene(scene)
    assert info.value.path == str(scene) and info.value.line == 1


def test_non_finite_and_far_vertices_are_dropped_with_a_warning():
    quad = prim.quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    bad = Mesh("bad", [[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 0], [1e30, 0, 0]],
               [[0, 1, 2], [0, 1, 3], [0, 4, 2]], 0, source="made.toml:7")
    scene = Scene(camera=Camera([0, 0, 3], [0, 0, 0]), materials=[Material("m")], meshes=[quad, bad])
    with pytest.warns(SceneWarning, match=r"made\.toml:7 \(mesh 'bad'\): 2 vertices are NaN/Inf"):
        r = Renderer(scene, size=(8, 8))
    assert bad.indices.tolist() == [[0, 1, 2]] and np.isfinite(r.packed.tri_pos).all()


def test_scene_built_in_python_is_validated_too():
    scene = Scene(camera=Camera([0, 0, 3], [0, 0, 0]), materials=[Material("m")],
                  spheres=[Sphere([0, np.inf, 0], 1.0, 0, source="mine.py:3")])
    with pytest.raises(SceneError, match=r"^mine\.py:3: sphere needs a finite centre"):
        Renderer(scene, size=(8, 8))


def test_text_that_is_not_utf8_or_nested_too_deeply(tmp_path):
    latin1 = tmp_path / "latin1.toml"
    latin1.write_bytes(b'[materials.a]\ncolor = 0.5\n# caf\xe9\n[[objects]]\ntype = "sphere"\n')
    with pytest.raises(SceneError, match="not UTF-8") as info:
        load_scene(latin1)
    assert info.value.line == 3
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(SceneError, match="nested too deeply"):
        load_scene(deep)


def test_pbrt_include_cycle_names_the_include_line(tmp_path):
    (tmp_path / "a.pbrt").write_text('WorldBegin\nInclude "b.pbrt"\n')
    (tmp_path / "b.pbrt").write_text('# b\nInclude "a.pbrt"\n')
    with pytest.raises(SceneError, match="Include cycle") as info:
        load_scene(tmp_path / "a.pbrt")
    assert info.value.path.endswith("b.pbrt") and info.value.line == 2


# ---------------------------------------------------------------- what the GPU does anyway
NAN_PLUGIN = """
// Column 0: NaN always; column 1: Inf in one channel always; column 2: NaN on even frames.
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    uint x = gl_GlobalInvocationID.x;
    float nan = uintBitsToFloat(0x7fc00000u);
    float inf = uintBitsToFloat(0x7f800000u);
    if (x == 0u) return vec3(nan);
    if (x == 1u) return vec3(0.25, inf, 0.25);
    if (x == 2u && (u_frame & 1u) == 0u) return vec3(nan, 0.25, 0.25);
    return vec3(0.25);
}
"""


def test_nan_and_inf_samples_are_dropped_counted_and_reported(tmp_path, capsys):
    folder = tmp_path / "plugins" / "nans"
    folder.mkdir(parents=True)
    (folder / "plugin.toml").write_text('name = "nans"\nentry = "nans.glsl"\n')
    (folder / "nans.glsl").write_text(NAN_PLUGIN)
    w, h, spp = 8, 4, 5
    r = Renderer(load_scene(FURNACE), size=(w, h), integrator=str(folder))
    image = r.render(spp=spp)
    expected_drops = h * spp * 2 + h * math.ceil(spp / 2)  # frames 0, 2, 4 are even
    assert r.stats.dropped_samples == expected_drops
    assert np.all(image[:, :2] == 0.0)  # no valid sample: 0, never NaN
    assert np.allclose(image[:, 2:], 0.25) and np.isfinite(image).all()
    out = tmp_path / "x.npy"
    assert main(["render", str(FURNACE), "--plugins", str(tmp_path / "plugins"), "--integrator", "nans",
                 "--size", f"{w}x{h}", "--spp", str(spp), "--out", str(out)]) == 0
    assert f"dropped NaN/Inf samples: {expected_drops}" in capsys.readouterr().out


def _fine_glowing_box(n: int) -> Scene:
    """scenes/stress/furnace_box.toml (albedo 1, emission 1) with each wall cut into 2 n^2
    triangles: a deeper BVH, so more loop iterations per bounce."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        scene = load_scene(REPO / "scenes" / "stress" / "furnace_box.toml")
    meshes = []
    for m in scene.meshes:
        c, u, v = m.positions[0], m.positions[1] - m.positions[0], m.positions[3] - m.positions[0]
        meshes += [prim.quad(c + u * i / n + v * j / n, u / n, v / n, m.material) for i in range(n) for j in range(n)]
    scene.meshes = meshes
    return scene


@pytest.mark.skipif(not is_llvmpipe(), reason="the loop limit measured here is llvmpipe's (Mesa gallivm)")
def test_paths_cut_short_by_the_drivers_loop_limit_are_counted_and_reported():
    scene = _fine_glowing_box(24)  # 6912 triangles
    # 10000 bounces need > 65535 loop iterations in every pixel, with the binary BVH and with
    # the 4-wide one (accel/wide.py), which needs fewer a bounce: the default
    # 1001 bounces exceed the limit only with the binary tree
    r = Renderer(scene, size=(8, 8), seed=1, params={"max_depth": 10000})
    long_paths = r.render(spp=1)[..., 0]
    assert r.stats.loop_limited == 64
    assert long_paths.max() < 10001 and "loop limit" in r.stats.summary()
    r = Renderer(scene, size=(8, 8), seed=1, params={"max_depth": 64})
    short_paths = r.render(spp=2)[..., 0].ravel()
    assert r.stats.loop_limited == 0 and "WARNING" not in r.stats.summary()
    se = short_paths.std(ddof=1) / math.sqrt(short_paths.size)
    assert abs(short_paths.mean() - 65) < 4 * se + 1e-4  # the series 1 + 1 + ... for 64 bounces


# ---------------------------------------------------------------- issue 32: limits on input
def _pixel_film(tmp_path, film: int, kind: str = "triangle") -> Path:
    scene = tmp_path / "film.toml"
    scene.write_text(f'[film]\nsize = [{film}, {film}]\nfilter = "{kind}"\n\n[[objects]]\ntype = "sphere"\n')
    return scene


def test_a_huge_film_with_a_filter_costs_what_a_small_one_does(tmp_path):
    """The filter's table is built from the render's size: a film of 1e12 x 1e12 pixels rendered
    at 8x8 (125 billion film pixels a rendered pixel) is a box over the pixel with ramps too
    narrow to see, as the limit of the film-pixel sum."""
    from lift_gl.passes.pixel_filter import cdf_knots, KNOTS
    from lift_gl.scene.model import PixelFilter

    for kind, radius in (("triangle", 1.0), ("box", 0.5), ("gaussian", 2.0)):
        (cdf, start, step), _ = cdf_knots(PixelFilter(kind, (radius, radius)), (10 ** 12, 10 ** 12), (8, 8))
        positions = start + step * np.arange(KNOTS)
        assert abs(start) < 1e-9 and abs(positions[-1] - 1.0) < 1e-9  # the pixel's own square
        assert np.allclose(cdf, np.clip(positions, 0, 1), atol=5e-4)  # uniform over it, to the table's 1/4096
    renderer = Renderer(load_scene(_pixel_film(tmp_path, 10 ** 12)), size=(8, 8))
    assert np.isfinite(renderer.render(spp=1)).all()


def _fan_out(tmp_path: Path, levels: int) -> Path:
    (tmp_path / "main.pbrt").write_text('LookAt 0 0 5 0 0 0 0 1 0\nCamera "perspective"\nWorldBegin\n'
                                         'Include "l1.pbrt"\n')
    for i in range(1, levels + 1):
        body = f'Include "l{i + 1}.pbrt"\nInclude "l{i + 1}.pbrt"\n' if i < levels else 'Shape "sphere"\n'
        (tmp_path / f"l{i}.pbrt").write_text(body)
    return tmp_path / "main.pbrt"


def test_pbrt_include_fan_out_is_refused_at_the_include_over_the_total(tmp_path, monkeypatch):
    """Each file including the next twice, 20 levels: 2^20 inclusions without a total."""
    monkeypatch.setattr(limits, "MAX_INCLUDES", 100)
    reads = []
    real_tokenize = pbrt_loader.tokenize
    monkeypatch.setattr(pbrt_loader, "tokenize", lambda text, path: reads.append(path) or real_tokenize(text, path))
    with pytest.raises(LimitError, match=r"makes 101 inclusions in this scene, over the limit "
                                         r"lift_gl\.limits\.MAX_INCLUDES = 100") as info:
        load_scene(_fan_out(tmp_path, 20))
    assert info.value.path.endswith(".pbrt") and info.value.line in (1, 2)  # the Include over the total
    assert len(reads) == 101  # the main file and 100 inclusions: never 2^20


def test_pbrt_includes_are_also_limited_in_bytes(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_INCLUDED_BYTES", 1000)
    (tmp_path / "big.pbrt").write_text("# " + "x" * 600 + "\n")
    (tmp_path / "main.pbrt").write_text('WorldBegin\nInclude "big.pbrt"\nInclude "big.pbrt"\n')
    with pytest.raises(LimitError, match=r"bytes of included text, over the limit lift_gl\.limits\."
                                         r"MAX_INCLUDED_BYTES = 1,000") as info:
        load_scene(tmp_path / "main.pbrt")
    assert info.value.line == 3



def test_mitsuba_includes_are_limited_as_pbrt_s(tmp_path, monkeypatch):
    """Mitsuba's <include> reads each file once, but many files are many bytes: the same
    budget as pbrt's Include, refused at the element over it."""
    monkeypatch.setattr(limits, "MAX_INCLUDED_BYTES", 1000)
    for k in range(3):
        (tmp_path / f"part{k}.xml").write_text('<scene version="0.5.0">\n<!-- ' + "x" * 400 + ' -->\n</scene>\n')
    includes = "".join(f'  <include filename="part{k}.xml"/>\n' for k in range(3))
    (tmp_path / "main.xml").write_text(f'<scene version="0.5.0">\n{includes}  <shape type="sphere"/>\n</scene>\n')
    with pytest.raises(LimitError, match=r"MAX_INCLUDED_BYTES = 1,000") as info:
        load_scene(tmp_path / "main.xml")
    assert info.value.path.endswith("main.xml") and info.value.line == 4   # the third include

def test_200000_object_instances_are_refused_before_the_file_is_parsed(tmp_path, monkeypatch):
    lines = ['LookAt 0 0 5 0 0 0 0 1 0', 'Camera "perspective"', 'WorldBegin', 'ObjectBegin "o"',
             'Shape "trianglemesh" "integer indices" [0 1 2] "point P" [0 0 0 1 0 0 0 1 0]', 'ObjectEnd',
             '# ObjectInstance "o" in a comment is not one', 'Attribute "ObjectInstance" "is a string"']
    lines += [f'AttributeBegin Translate {i} 0 0 ObjectInstance "o" AttributeEnd' for i in range(200_000)]
    scene = tmp_path / "many.pbrt"
    scene.write_text("\n".join(lines) + "\n")
    forbid(monkeypatch, "lift_gl.scene.pbrt_loader.tokenize")
    with pytest.raises(LimitError, match=r"65,535 instances, over the limit lift_gl\.limits\.MAX_INSTANCES "
                                         r"= 65,534") as info:
        load_scene(scene)
    assert info.value.path == str(scene) and info.value.line == 8 + 65_535  # the first one over


def test_instances_are_counted_exactly_as_they_are_placed(tmp_path, monkeypatch):
    """An object of two meshes placed 6 times is 12 instances: with a limit of 10 the sixth
    placement is refused at its line (the text's count, 6 placements, was within it)."""
    monkeypatch.setattr(limits, "MAX_INSTANCES", 10)
    monkeypatch.setattr(pbrt_loader, "MAX_INSTANCES", 10)
    tri = 'Shape "trianglemesh" "integer indices" [0 1 2] "point P" [0 0 0 1 0 0 0 1 0]'
    lines = ['LookAt 0 0 5 0 0 0 0 1 0', 'Camera "perspective"', 'WorldBegin', 'ObjectBegin "o"', tri,
             'Translate 0 0 1', tri, 'ObjectEnd'] + [f'Translate 1 0 0\nObjectInstance "o"' for _ in range(6)]
    scene = tmp_path / "pairs.pbrt"
    scene.write_text("\n".join(lines) + "\n")
    with pytest.raises(LimitError, match=r"12 instances, over the limit lift_gl\.limits\.MAX_INSTANCES = 10") as info:
        load_scene(scene)
    assert info.value.line == 8 + 2 * 6


def _png_claiming(path: Path, width: int, height: int) -> Path:
    """A valid grey PNG of width x height zero pixels, compressed to almost nothing."""
    import struct
    import zlib

    packer = zlib.compressobj(9)
    row = bytes(width + 1)
    data = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
                     + chunk(b"IDAT", data) + chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize("side, claim", [(10_000, "10,000x10,000 pixels (100,000,000)"),
                                         (30_000, "900,000,000 pixels")])  # over pillow's own limit too
def test_texture_over_the_pixel_limit_is_refused_from_its_header(tmp_path, monkeypatch, side, claim):
    _png_claiming(tmp_path / "bomb.png", side, side)
    scene = tmp_path / "bomb.toml"
    scene.write_text('[materials.m]\ntexture = "bomb.png"\n\n[[objects]]\ntype = "sphere"\nmaterial = "m"\n')
    forbid(monkeypatch, "PIL.ImageFile.ImageFile.load")  # not a pixel decoded
    with pytest.warns(SceneWarning, match=rf"bomb\.toml:2: cannot read texture .*bomb\.png \(a texture of "
                                          rf"{re.escape(claim)}, over the limit lift_gl\.limits\.MAX_TEXTURE_PIXELS = "
                                          rf"16,777,216\); using the material's constant colour"):
        loaded = load_scene(scene)
    assert loaded.textures == [] and loaded.materials[0].texture is None


@pytest.mark.parametrize("side, claim", [(10_000, "10,000x10,000 pixels"), (30_000, "more pixels than pillow allows")])
def test_gltf_texture_over_the_pixel_limit_is_refused_from_its_header(tmp_path, monkeypatch, side, claim):
    import json

    import trimesh
    from PIL import Image

    mesh = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]], process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [0, 1]],
                                                image=Image.fromarray(np.full((4, 4, 3), 200, np.uint8)))
    for name, data in trimesh.Scene(mesh).export(file_type="gltf").items():
        (tmp_path / name).write_bytes(data)
    document = json.loads((tmp_path / "model.gltf").read_text())
    document["images"] = [{"uri": "bomb.png", "mimeType": "image/png"}]
    (tmp_path / "model.gltf").write_text(json.dumps(document))
    _png_claiming(tmp_path / "bomb.png", side, side)
    forbid(monkeypatch, "PIL.ImageFile.ImageFile.load")  # not a pixel decoded
    with pytest.warns(SceneWarning, match=rf"model\.gltf: images\[0\]: texture .*bomb\.png has {claim}, over the "
                                          r"limit lift_gl\.limits\.MAX_TEXTURE_PIXELS = 16,777,216") as caught:
        scene = load_scene(tmp_path / "model.gltf")
    assert scene.textures == [] and all(m.texture is None for m in scene.materials)
    assert sum("MAX_TEXTURE_PIXELS" in str(w.message) for w in caught) == 1  # one warning, not two


def test_a_jpeg_over_the_pixel_limit_is_decoded_smaller(tmp_path, monkeypatch):
    from PIL import Image

    Image.fromarray(np.full((64, 48, 3), 200, np.uint8)).save(tmp_path / "wood.jpg")
    monkeypatch.setattr(limits, "MAX_TEXTURE_PIXELS", 1000)  # 48 x 64 = 3072: decoded at 1/2 is 24 x 32 = 768
    scene = tmp_path / "jpg.toml"
    scene.write_text('[materials.m]\ntexture = "wood.jpg"\n\n[[objects]]\ntype = "sphere"\nmaterial = "m"\n')
    with pytest.warns(SceneWarning, match=r"jpg\.toml:2: texture .*wood\.jpg is 48x64 pixels, more than lift_gl\."
                                          r"limits\.MAX_TEXTURE_PIXELS = 1,000; decoded at 24x32"):
        loaded = load_scene(scene)
    assert loaded.textures[0].pixels.shape == (32, 24, 4)


@pytest.mark.parametrize("name, header", [
    ("sky.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n"),
    ("sky.pfm", b"PF\n100000 100000\n-1.0\n"),
])
def test_environment_map_over_the_pixel_limit_is_refused_from_its_header(tmp_path, name, header):
    (tmp_path / name).write_bytes(header + bytes(64))
    scene = tmp_path / "env.toml"
    scene.write_text(f'[environment]\nmap = "{name}"\n\n[[objects]]\ntype = "sphere"\n')
    with pytest.raises(SceneError, match=r"100,000x100,000 pixels \(10,000,000,000\), over the limit "
                                         r"lift_gl\.limits\.MAX_TEXTURE_PIXELS"):
        load_scene(scene)


def _plugin(root: Path, name: str, source: str, manifest_extra: str = "") -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    (folder / "plugin.toml").write_text(f'name = "{name}"\nentry = "{name}.glsl"\n{manifest_extra}')
    (folder / f"{name}.glsl").write_text(source)
    return folder


HUGE_ARRAY = """vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    float samples[100000000];
    samples[0] = 1.0;
    return vec3(samples[0]);
}
"""


def test_a_huge_shader_array_is_refused_before_the_compiler_sees_it(tmp_path, monkeypatch):
    folder = _plugin(tmp_path, "huge", HUGE_ARRAY)
    forbid(monkeypatch, "moderngl.Context.compute_shader")
    with pytest.raises(LimitError, match=r"an array of 100,000,000 scalar components, over the limit "
                                         r"lift_gl\.limits\.MAX_SHADER_ARRAY_COMPONENTS = 4,096") as info:
        Renderer(load_scene(FURNACE), size=(8, 8), integrator=str(folder))
    assert info.value.path == str((folder / "huge.glsl").resolve()) and info.value.line == 2


def _own_source(tmp_path, body: str, defines=None):
    from lift_gl import shaders

    path = tmp_path / "mine.glsl"
    path.write_text(body)
    return shaders.assemble(path, defines)


@pytest.mark.parametrize("body, defines, components", [
    ("vec4 history[2000];\n", None, 8000),                              # vec4: 4 a element
    ("float grid[64][128];\n", None, 8192),                             # both dimensions
    ("#define N (1 << 13)\nfloat a[N];\n", None, 8192),                 # a #define, an expression
    ("float a[COUNT];\n", {"COUNT": 5000}, 5000),                       # a parameter's define
    ("#ifndef COUNT\n#define COUNT 1\n#endif\nfloat a[COUNT];\n", {"COUNT": 5000}, 5000),  # the host's wins
    ("struct S { vec4 p; float w[10]; };\nS path[300];\n", None, 4200),  # a struct: its members
    ("mat4[300] frames;\n", None, 4800),                                # the array-type syntax
])
def test_shader_arrays_are_counted_in_scalar_components(tmp_path, body, defines, components):
    from lift_gl import shaders
    from lift_gl.glsl_arrays import check_array_sizes

    with pytest.raises(LimitError, match=rf"an array of {components:,} scalar components") as info:
        check_array_sizes(_own_source(tmp_path, body, defines), shaders.SHADER_DIR)
    assert info.value.path.endswith("mine.glsl") and info.value.line == body.count("\n")


@pytest.mark.parametrize("body, defines", [
    ("float a[4096];\nvec3 b[1365];\n", None),                                    # at the limit
    ("#ifndef D\n#define D 64\n#elif D > 64\n#undef D\n#define D 64\n#endif\nuvec4 a[D * 4];\n",
     {"D": 100000}),                                                              # bdpt's cap
    ("#if 0\nfloat a[100000];\n#endif\n", None),                                  # dropped by #if
    ("float a[100];\nvoid f(int i) { a[i] = 0.0; }\n// float b[100000];\n", None),  # an index; a comment
])
def test_shader_arrays_within_the_limit_or_dropped_are_accepted(tmp_path, body, defines):
    from lift_gl import shaders
    from lift_gl.glsl_arrays import check_array_sizes

    check_array_sizes(_own_source(tmp_path, body, defines), shaders.SHADER_DIR)


# ---------------------------------------------------------------- issue 32: plugin containment
def test_a_manifest_entry_outside_the_plugin_folder_is_refused(tmp_path):
    from lift_gl.errors import PluginError
    from lift_gl.plugins import load_manifest

    outside = tmp_path / "secret.glsl"
    outside.write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(1.0); }\n")
    folder = tmp_path / "plugins" / "sneaky"
    folder.mkdir(parents=True)
    for entry in ("../../secret.glsl", str(outside), "link.glsl"):
        (folder / "plugin.toml").write_text(f'name = "sneaky"\ndescription = "x"\nentry = "{entry}"\n')
        if entry == "link.glsl":
            (folder / "link.glsl").symlink_to(outside)
        with pytest.raises(PluginError, match=r"is outside the plugin's folder") as info:
            load_manifest(folder)
        assert info.value.path == str(folder / "plugin.toml") and info.value.line == 3


def test_a_plugin_include_outside_its_folder_and_the_library_is_refused(tmp_path):
    from lift_gl import shaders
    from lift_gl.errors import ShaderError

    (tmp_path / "outside.glsl").write_text("float stolen() { return 1.0; }\n")
    folder = tmp_path / "plugins" / "inc"
    folder.mkdir(parents=True)
    (folder / "link.glsl").symlink_to(tmp_path / "outside.glsl")
    (folder / "helpers.glsl").write_text('#include "lift/rng.glsl"\nfloat helper() { return 1.0; }\n')
    for include in ("../../outside.glsl", "link.glsl", "../../../../../../etc/hostname"):
        (folder / "inc.glsl").write_text(f'#include "helpers.glsl"\n#include "{include}"\n')
        with pytest.raises(ShaderError, match=r"outside the plugin's folder and the GLSL library") as info:
            shaders.assemble('#include "inc.glsl"\n', include_dirs=[folder])
        assert info.value.path == str((folder / "inc.glsl").resolve()) and info.value.line == 2
    (folder / "inc.glsl").write_text('#include "helpers.glsl"\n#include "lift/sampling.glsl"\n')
    shaders.assemble('#include "inc.glsl"\n', include_dirs=[folder])  # its own files and the library



def test_an_opencl_plugin_include_outside_its_folder_and_the_library_is_refused(tmp_path):
    """The OpenCL assembler holds a plugin's includes to the same rule (no pyopencl needed)."""
    from lift_gl import opencl
    from lift_gl.errors import ShaderError

    (tmp_path / "outside.cl").write_text("float stolen(void) { return 1.0f; }\n")
    folder = tmp_path / "plugins" / "inc_cl"
    folder.mkdir(parents=True)
    (folder / "link.cl").symlink_to(tmp_path / "outside.cl")
    (folder / "helpers.cl").write_text('#include "lift/rng.h"\nfloat helper(void) { return 1.0f; }\n')
    for include in ("../../outside.cl", "link.cl", "../../../../../../etc/hostname"):
        (folder / "inc.cl").write_text(f'#include "helpers.cl"\n#include "{include}"\n')
        with pytest.raises(ShaderError, match=r"outside the plugin's folder and the OpenCL library") as info:
            opencl.assemble(f'#include "{folder / "inc.cl"}"\n', include_dirs=[folder])
        assert info.value.path == str((folder / "inc.cl").resolve()) and info.value.line == 2
    (folder / "inc.cl").write_text('#include "helpers.cl"\n#include "lift/host.h"\n')
    opencl.assemble(f'#include "{folder / "inc.cl"}"\n', include_dirs=[folder])  # its own files and the library

def test_a_plugin_that_shadows_a_built_in_is_reported_naming_both_folders(tmp_path):
    from lift_gl.plugins import BUILTIN_DIR, ShadowedPluginWarning, discover

    _plugin(tmp_path / "mine", "pt", "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(1.0); }\n")
    with pytest.warns(ShadowedPluginWarning) as caught:
        found = discover([tmp_path / "mine"])
    assert found["pt"].folder == (tmp_path / "mine" / "pt").resolve()
    message = next(str(w.message) for w in caught if w.category is ShadowedPluginWarning)
    assert f"in {tmp_path / 'mine' / 'pt'}" in message and f"the built-in 'pt' in {BUILTIN_DIR / 'pt'}" in message


# ---------------------------------------------------------------- issue 32: what refusing costs
CHILD = """
import json, time, warnings
from lift_gl.errors import LiftError
start = time.perf_counter()
try:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=ResourceWarning)
        {code}
    outcome = "warned: " + str(caught[0].message) if caught else "done"
except LiftError as exc:
    outcome = "refused: " + str(exc)
print(json.dumps({{"outcome": outcome, "seconds": time.perf_counter() - start}}))
"""
# Linux hands an exec'd process the peak of the process that forked it (ru_maxrss carries over
# exec): a small launcher in between starts the case, so that its getrusage(RUSAGE_CHILDREN)
# is the case's own peak, not the test runner's.
LAUNCHER = """
import json, resource, subprocess, sys
result = subprocess.run([sys.executable, "-c", sys.argv[1]], capture_output=True, text=True)
sys.stderr.write(result.stderr)
report = json.loads(result.stdout.strip().splitlines()[-1]) if result.returncode == 0 else {}
report["peak_mib"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps(report))
sys.exit(result.returncode)
"""
LOAD = "from lift_gl.scene.loader import load_scene; load_scene({path!r})"
RENDER = ("from lift_gl.renderer import Renderer; from lift_gl.scene.loader import load_scene; "
          "Renderer(load_scene({path!r}), size=(8, 8), integrator={integrator!r}).render(spp=1)")


def _hostile_cases(tmp_path: Path) -> dict:
    """name -> (code run in a child, the words its outcome must have)."""
    cases = {}
    for name, side in (("PNG texture 10000x10000 (97 KB)", 10_000), ("PNG bomb 30000x30000 (875 KB)", 30_000)):
        folder = tmp_path / f"png{side}"
        folder.mkdir()
        _png_claiming(folder / "t.png", side, side)
        (folder / "s.toml").write_text('[materials.m]\ntexture = "t.png"\n\n[[objects]]\ntype = "sphere"\n'
                                       'material = "m"\n')
        cases[name] = (LOAD.format(path=str(folder / "s.toml")), "warned: ", "MAX_TEXTURE_PIXELS")
    (tmp_path / "sky.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n" + bytes(64))
    (tmp_path / "env.toml").write_text('[environment]\nmap = "sky.hdr"\n\n[[objects]]\ntype = "sphere"\n')
    cases[".hdr header claiming 100000x100000"] = (LOAD.format(path=str(tmp_path / "env.toml")), "refused: ",
                                                   "MAX_TEXTURE_PIXELS")
    fan = tmp_path / "fan"
    fan.mkdir()
    cases["pbrt Include fan-out, 2 a file, 20 levels"] = (LOAD.format(path=str(_fan_out(fan, 20))), "refused: ",
                                                         "MAX_INCLUDES = 2,048")
    lines = ['WorldBegin', 'ObjectBegin "o"', 'Shape "sphere"', 'ObjectEnd']
    (tmp_path / "many.pbrt").write_text("\n".join(lines + ['ObjectInstance "o"'] * 200_000) + "\n")
    cases["pbrt 200,000 ObjectInstance"] = (LOAD.format(path=str(tmp_path / "many.pbrt")), "refused: ",
                                            "MAX_INSTANCES")
    cases["TOML film 1e12 x 1e12, triangle filter, rendered 8x8"] = (
        RENDER.format(path=str(_pixel_film(tmp_path, 10 ** 12)), integrator="pt"), "", "")
    cases["plugin declaring float a[100000000]"] = (
        RENDER.format(path=str(FURNACE), integrator=str(_plugin(tmp_path, "huge", HUGE_ARRAY))), "refused: ",
        "MAX_SHADER_ARRAY_COMPONENTS")
    return cases


def test_the_largest_hostile_inputs_are_refused_well_under_a_gigabyte(tmp_path):
    """Each case in a child process of its own, its peak resident memory from getrusage
    (interpreter, numpy and, where a case renders, a GL context included). Times are printed,
    not asserted (they depend on the machine's load)."""
    import json
    import subprocess
    import sys

    for name, (code, outcome, words) in _hostile_cases(tmp_path).items():
        result = subprocess.run([sys.executable, "-c", LAUNCHER, CHILD.format(code=code)],
                                cwd=REPO, capture_output=True, text=True, timeout=600)
        assert result.returncode == 0, (name, result.stderr[-2000:])
        report = json.loads(result.stdout.strip().splitlines()[-1])
        print(f"{name}: {report['outcome'][:90]}... {report['seconds']:.1f} s, peak {report['peak_mib']:.0f} MiB")
        assert report["outcome"].startswith(outcome) and words in report["outcome"], (name, report)
        assert report["peak_mib"] < 1024, (name, report)


@pytest.mark.parametrize("kwargs", [{"spp": 0}, {"spp": -3}, {"spp": 2.5}, {"seconds": 0.0}, {"seconds": float("nan")}])
def test_render_refuses_counts_and_times_it_cannot_run(kwargs):
    """Renderer.render as the CLI's arguments are checked: no frame runs on a count below 1
    or a time that is not finite and positive (spp=0 returned the empty image as if rendered)."""
    r = Renderer(load_scene(FURNACE), size=(8, 8))
    try:
        with pytest.raises(ValueError, match="spp|seconds"):
            r.render(**kwargs)
        assert r.stats.spp == 0
    finally:
        r.release()
