"""Hostile sizes are refused before anything is allocated, with the limit named; values that
would be NaN or Inf on the GPU are refused (or their triangles dropped) with file:line; and
what goes wrong on the GPU anyway is counted and reported: NaN/Inf samples, and paths that
the driver's loop limit cuts short."""
from __future__ import annotations

import math
import warnings

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
                   "lift_gl.renderer.TracePass", "lift_gl.renderer.AccumulatePass"):
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
    monkeypatch.setattr("lift_gl.renderer.GlLimits.query", classmethod(lambda cls, ctx: tiny))
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
