"""Instances (two-level BVH): traced instances against the same scene flattened (each
instance copied into world space as a mesh), ray hits against trimesh, G-buffer ids, moving
instances, memory, and bad input."""
from __future__ import annotations

import contextlib
import dataclasses
import textwrap

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.scene import primitives as prim
from lift_gl.scene.features import SceneFeatures
from lift_gl.scene.instances import flatten_instances
from lift_gl.scene.model import Camera, Instance, Material, Mesh, Scene
from lift_gl.scene.pack import pack_scene
from lift_gl.testing import require_opencl

trimesh = pytest.importorskip("trimesh")


def icosphere(subdivisions: int = 2, radius: float = 0.4) -> Mesh:
    ico = trimesh.creation.icosphere(subdivisions)
    return Mesh("ico", ico.vertices * radius, ico.faces, 0, normals=ico.vertex_normals)


# Rotations, non-uniform scales, a mirror and a material override: everything that can
# go wrong between object and world space.
TRANSFORMS = [
    prim.trs_matrix([-1.0, 0.45, -0.9], [0, 0, 0], 1.0),
    prim.trs_matrix([1.0, 0.5, -1.0], [20, 35, 0], [1.0, 1.6, 0.7]),
    prim.trs_matrix([-1.0, 0.45, 1.0], [0, 0, 30], [-1.0, 1.0, 1.0]),   # mirrored
    prim.trs_matrix([1.1, 0.4, 0.9], [-40, 10, 5], [0.8, 0.8, 1.3]),
]


def instanced_scene(materials=None) -> Scene:
    mats = materials or [Material("white", base_color=np.array([0.7, 0.7, 0.7])),
                         Material("light", emission=np.array([6.0, 6.0, 6.0])),
                         Material("red", base_color=np.array([0.8, 0.2, 0.2])),
                         Material("glass", type="dielectric", ior=1.5),
                         Material("metal", type="conductor", alpha=0.1, base_color=np.array([0.9, 0.7, 0.4]))]
    floor = prim.quad_centered([0, 0, 0], [5, 0, 0], [0, 0, -5], 0)
    floor.name = "floor"
    light = prim.quad_centered([0, 3, 0], [1.5, 0, 0], [0, 0, 1.5], 1)
    light.name = "light"
    overrides = [None, 2, 3, 4]
    instances = [Instance(0, m, overrides[k], name=f"ico{k}") for k, m in enumerate(TRANSFORMS)]
    return Scene(Camera(position=[0, 3.2, 5.5], target=[0, 0.3, 0]), mats, [floor, light],
                 prototypes=[icosphere()], instances=instances)


@contextlib.contextmanager
def Renderer(*args, **kwargs):
    from lift_gl.renderer import Renderer as _Renderer

    r = _Renderer(*args, **kwargs)
    try:
        yield r
    finally:
        r.release()


def render(scene, integrator="pt", spp=16, size=(64, 64), seed=7, **kw):
    with Renderer(scene, size=size, integrator=integrator, seed=seed, **kw) as r:
        return r.render(spp=spp)


def test_features_and_flattening():
    scene = instanced_scene()
    assert SceneFeatures.of(scene).instances
    assert "HAS_INSTANCES" in SceneFeatures.of(scene).defines()
    assert not SceneFeatures.of(flatten_instances(scene)).instances
    # the instances' materials count as used (glass, conductor)
    f = SceneFeatures.of(scene)
    assert f.dielectric and f.rough_conductor
    # an emissive instance is flattened: a world mesh, sampled as a light
    lit = dataclasses.replace(scene, instances=[*scene.instances, Instance(0, prim.translate_matrix([0, 2, 0]), 1)])
    packed = pack_scene(lit)
    assert packed.num_instances == 4
    assert packed.num_lights == len(scene.prototypes[0].indices) + 2
    assert SceneFeatures.of(lit).emissive


@pytest.mark.parametrize("integrator", ["pt", "drt", "bdpt", "hybrid"])
def test_instanced_image_matches_flattened(integrator):
    """Same seed, same random numbers: the images differ only where float rounding of the
    object-space hits sends a path elsewhere (measured: mean |difference| 0.14% of the mean,
    0.05% of pixels off by 2% of the peak; normals transformed by the matrix itself instead
    of its inverse transpose give 5% and 2.6%)."""
    scene = instanced_scene()
    traced = render(scene, integrator)
    flat = render(flatten_instances(scene), integrator)
    assert np.isfinite(traced).all()
    diff = np.abs(traced - flat)
    assert diff.mean() < 1e-2 * flat.mean(), (diff.mean(), flat.mean())
    assert (diff.max(axis=2) > 0.02 * max(flat.max(), 1e-6)).mean() < 0.01


CLOSEST = """
#include "lift/surface.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 11) readonly buffer Rays { vec4 rays[]; };     // (origin), (dir)
layout(std430, binding = 12) writeonly buffer Results { vec4 results[]; };  // (t, hit, occluded, -), (p), (ng)
uniform uint u_num_rays;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_num_rays) return;
    Ray ray = Ray(rays[2u * i].xyz, rays[2u * i + 1u].xyz, 0.0, 1e30);
    Hit hit;
    bool found = trace_closest(ray, hit);
    Surface s = surface_at(ray, hit);
    results[3u * i] = vec4(hit.t, found ? 1.0 : 0.0, trace_occluded(ray) ? 1.0 : 0.0, 0.0);
    results[3u * i + 1u] = vec4(found ? s.p : vec3(0.0), 0.0);
    results[3u * i + 2u] = vec4(found ? s.ng : vec3(0.0), 0.0);
}
"""


def test_split_heap_renders_the_same_image():
    """The BLAS live in the heap with the world's arrays: a scene split into several buffers
    renders bit for bit the image of the whole one; also the G-buffer's normal AOV."""
    from lift_gl.options import Options
    from lift_gl.scene.split import HEAP_ARRAYS

    scene = instanced_scene()

    def images(options=None):
        with Renderer(scene, size=(40, 32), integrator="pt", seed=3, options=options) as r:
            return r.render(spp=4), r.aov("normal"), r.buffers.plan

    whole, whole_normal, plan = images()
    assert not plan.split
    packed = pack_scene(scene)
    heap_bytes = sum(getattr(packed, n).nbytes for n in HEAP_ARRAYS)
    split, split_normal, plan = images(Options(max_buffer_bytes=heap_bytes // 4))  # 4 to 8 chunks (powers of two rows)
    assert plan.split and plan.chunks >= 3
    np.testing.assert_array_equal(split, whole)
    np.testing.assert_array_equal(split_normal, whole_normal)


def test_motion_blur_scene_with_instances():
    """A moving world mesh (HAS_MOTION) beside instances: the motion rows cover the BLAS
    (no displacement) and the image is the flattened scene's; an instance of a moving mesh
    is flattened."""
    scene = instanced_scene()
    box = prim.box([0, 1.5, -1.5], [0.4, 0.4, 0.4], 2)
    box.name, box.velocity = "flyer", np.array([0.6, 0.0, 0.0])
    scene = dataclasses.replace(scene, meshes=[*scene.meshes, box])
    assert SceneFeatures.of(scene).motion and SceneFeatures.of(scene).instances
    traced = render(scene, "drt", spp=16)
    flat = render(flatten_instances(scene), "drt", spp=16)
    assert np.abs(traced - flat).mean() < 1e-2 * flat.mean()
    moving = dataclasses.replace(scene, prototypes=[*scene.prototypes, box],
                                 instances=[*scene.instances, Instance(1, prim.translate_matrix([0, 0, 1]))])
    assert pack_scene(moving).num_instances == 4   # the moving one is copied into world space


def test_everything_features_on_a_scene_without_instances():
    """Shaders compiled with every feature (HAS_INSTANCES too) on a scene that has none: an
    empty instance table, and the image of the scene's own features."""
    from lift_gl import load_scene

    from pathlib import Path

    scene = load_scene(Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml")
    own = render(scene, spp=4, size=(32, 32))
    every = render(scene, spp=4, size=(32, 32), features=SceneFeatures.everything())
    assert np.abs(own - every).mean() < 1e-2 * own.mean()


def test_closest_hits_match_trimesh_on_the_flattened_mesh():
    from trimesh.ray.ray_triangle import RayMeshIntersector

    from lift_gl.gl.context import create_context
    from lift_gl.passes.common import SceneBuffers, set_uniforms
    from lift_gl.shaders import assemble, compile_compute

    scene = instanced_scene()
    packed = pack_scene(scene)
    features = SceneFeatures.of(scene)
    ctx = create_context()
    buffers = SceneBuffers(ctx, packed, instances=True)
    program = compile_compute(ctx, assemble(CLOSEST, defines=features.defines(), main_name="test_instances.comp"))
    rng = np.random.default_rng(1)
    n = 4000
    origin = rng.uniform([-2.5, 0.05, -2.5], [2.5, 2.0, 2.5], (n, 3))
    target = rng.uniform([-1.5, 0.0, -1.5], [1.5, 1.2, 1.5], (n, 3))
    d = target - origin
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rays = np.zeros((n, 2, 4), np.float32)
    rays[:, 0, :3], rays[:, 1, :3] = origin - packed.origin, d
    ray_buf = ctx.buffer(rays.tobytes())
    out = ctx.buffer(reserve=n * 48)
    buffers.bind()
    ray_buf.bind_to_storage_buffer(11)
    out.bind_to_storage_buffer(12)
    set_uniforms(program, dict(buffers.uniforms((0, 0, 0)), u_num_rays=n))
    program.run(group_x=(n + 63) // 64)
    res = np.frombuffer(out.read(), np.float32).reshape(n, 3, 4).astype(np.float64)
    for obj in (ray_buf, out, program):
        obj.release()
    buffers.release()

    flat = flatten_instances(scene)
    verts, faces, offset = [], [], 0
    for mesh in flat.meshes:
        verts.append(mesh.positions)
        faces.append(mesh.indices + offset)
        offset += len(mesh.positions)
    world = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    tri, ray, loc = RayMeshIntersector(world).intersects_id(origin, d, multiple_hits=False, return_locations=True)
    t_ref = np.full(n, np.inf)
    t_ref[ray] = np.einsum("ij,ij->i", loc - origin[ray], d[ray])
    normal_ref = np.zeros((n, 3))
    normal_ref[ray] = world.face_normals[tri]

    found = res[:, 0, 1] > 0.5
    t = np.where(found, res[:, 0, 0], np.inf)
    both = found & np.isfinite(t_ref)
    agree = (found == np.isfinite(t_ref))
    agree[both] = np.abs(t[both] - t_ref[both]) <= 1e-4 * np.maximum(t_ref[both], 1)
    assert both.sum() > n // 2
    assert agree.mean() > 0.997, f"{(~agree).sum()} of {n} rays disagree"
    ok = both & agree
    # the surface point and geometric normal (front side as the flattened mesh's, mirror included)
    np.testing.assert_allclose(res[ok, 1, :3] + packed.origin, origin[ok] + t[ok, None] * d[ok], atol=2e-4)
    cos = np.einsum("ij,ij->i", res[ok, 2, :3], normal_ref[ok])
    assert (cos > 0.999).mean() > 0.995
    # shadow rays: occluded exactly when something is hit
    assert ((res[:, 0, 2] > 0.5) == found).mean() > 0.999


def test_gbuffer_ids_resolve_to_the_instance_surface():
    """Each G-buffer texel's (triangle, instance, barycentrics) rebuilds the point whose view
    depth the G-buffer stored; and the normal/depth AOVs equal the flattened scene's."""
    scene = instanced_scene()
    with Renderer(scene, size=(64, 64), integrator="pt") as r:
        depth = r.aov("depth")
        vis = np.frombuffer(r.gbuffer.visibility.read(), np.uint32).reshape(64, 64, 4)
        packed = r.packed
        cam = r.camera
    with Renderer(flatten_instances(scene), size=(64, 64), integrator="pt") as r:
        depth_flat = r.aov("depth")
    instance = (vis[..., 3] >> 16).astype(np.int64) - 1
    seen = instance >= 0
    assert seen.sum() > 200 and len(np.unique(instance[seen])) == 4
    prim_id = vis[seen, 0].astype(np.int64) - 1
    assert (prim_id >= packed.num_world_triangles).all() and (prim_id < packed.num_triangles).all()
    records = packed.instances[packed.instance_table.record_base:].reshape(-1, 7, 4).astype(np.float64)
    corners = packed.tri_pos[prim_id, :, :3].astype(np.float64)
    b = vis[seen, 1:3].view(np.float32).astype(np.float64)
    p_obj = (1 - b[:, :1] - b[:, 1:]) * corners[:, 0] + b[:, :1] * corners[:, 1] + b[:, 1:] * corners[:, 2]
    m = records[instance[seen], 0:3]
    p = np.einsum("kij,kj->ki", m[:, :, :3], p_obj) + m[:, :, 3]
    forward = cam.basis()[2]
    view_depth = (p - cam.position) @ forward
    d = (depth[..., 0] if depth.ndim == 3 else depth)[::-1]  # the AOV's row 0 is the top, GL's the bottom
    np.testing.assert_allclose(view_depth, d[seen], rtol=1e-4, atol=1e-4)
    d_flat = (depth_flat[..., 0] if depth_flat.ndim == 3 else depth_flat)[::-1]
    close = np.abs(d - d_flat) <= 1e-3 * np.maximum(np.abs(d_flat), 1)
    assert close.mean() > 0.98


def test_moving_instance_rebuilds_only_the_tlas(monkeypatch):
    from lift_gl.scene import instances as inst_mod
    from lift_gl.scene import pack as pack_mod

    scene = instanced_scene()
    moved = dataclasses.replace(scene, instances=[
        dataclasses.replace(i, transform=prim.translate_matrix([0.3, 0.2, -0.4]) @ i.transform) if k == 1 else i
        for k, i in enumerate(scene.instances)])
    with Renderer(scene, size=(48, 48), integrator="pt", seed=3) as r:
        r.render(spp=2)

        def no_build(*args, **kwargs):
            raise AssertionError("a BVH was built for a moved instance")

        monkeypatch.setattr(pack_mod, "build_blas", no_build)
        monkeypatch.setattr(pack_mod, "build_bvh_cached", no_build)
        monkeypatch.setattr(inst_mod, "build_bvh_cached", no_build)
        defines = dict(r.defines)
        r.update_scene(moved)
        assert r.uploaded == ["instances"]
        assert r.defines == defines  # nothing recompiled: the instance array keeps its length
        image = r.render(spp=8)
        monkeypatch.undo()
    fresh = render(moved, spp=8, size=(48, 48), seed=3)
    # the same scene from a fresh renderer: the GPU origin differs (it is the new scene's
    # centre), so compare statistically tight rather than bit for bit
    diff = np.abs(image - fresh)
    assert diff.mean() < 3e-3 * fresh.mean()


def test_moving_instance_keeps_its_history_with_reprojection():
    """temporal="reproject": the G-buffer's motion vectors follow the instance's previous
    transform, so a moved instance's pixels are not rejected as disocclusions."""
    scene = instanced_scene()
    step = prim.translate_matrix([0.04, 0.0, 0.0])
    moved = dataclasses.replace(scene, instances=[
        dataclasses.replace(i, transform=step @ i.transform) for i in scene.instances])
    with Renderer(scene, size=(64, 64), integrator="pt", temporal="reproject") as r:
        r.render(spp=4)
        r.update_scene(moved)
        r.render(spp=1)
        motion = np.frombuffer(r.gbuffer.motion.read(), np.float32).reshape(64, 64, 4)
        vis = np.frombuffer(r.gbuffer.visibility.read(), np.uint32).reshape(64, 64, 4)
        history = r.aov("history").reshape(64, 64, -1)[..., 0][::-1]  # GL rows, bottom first
    on_instance = (vis[..., 3] >> 16) > 0
    # 4 samples before the move + 1 after where the history was kept (1: rejected)
    assert np.median(history[on_instance]) > 2
    on_floor = (vis[..., 0] > 0) & ~on_instance
    # the instances moved right (+x) by ~0.5 pixel or more: their previous position is to the left
    assert np.median(motion[on_instance, 0]) < -0.3
    assert np.abs(motion[on_floor, :2]).max() < 1e-3


def test_blas_memory_is_shared_by_every_instance():
    proto = icosphere(3)
    grid = [prim.translate_matrix([x, 0.0, z]) for x in range(10) for z in range(10)]
    scene = Scene(Camera(position=[5, 10, 20], target=[5, 0, 5]), [Material("white")], [],
                  prototypes=[proto], instances=[Instance(0, m) for m in grid])
    packed = pack_scene(scene)
    flat = pack_scene(flatten_instances(scene))
    t = len(proto.indices)
    assert packed.num_triangles == t and flat.num_triangles == 100 * t
    geometry = ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info")
    inst_bytes = sum(getattr(packed, k).nbytes for k in geometry) + packed.instances.nbytes
    flat_bytes = sum(getattr(flat, k).nbytes for k in geometry)
    assert inst_bytes < flat_bytes / 50


def write(tmp_path, body: str):
    path = tmp_path / "scene.toml"
    path.write_text(textwrap.dedent(body))
    return path


SCENE_HEAD = """
    [camera]
    position = [0, 2, 6]
    target = [0, 0, 0]
    [materials.white]
    color = 0.7
    [materials.red]
    color = [0.8, 0.1, 0.1]
    [[objects]]
    type = "box"
    name = "crate"
    size = 0.5
    prototype = true
    [[objects]]
    type = "quad"
    name = "floor"
    center = [0, 0, 0]
    u = [4, 0, 0]
    v = [0, 0, -4]
"""


def test_toml_instances(tmp_path):
    from lift_gl import load_scene

    path = write(tmp_path, SCENE_HEAD + """
    [[instances]]
    mesh = "crate"
    translate = [1, 0.25, 0]
    rotate = [0, 45, 0]
    [[instances]]
    mesh = "crate"
    name = "red crate"
    material = "red"
    transform = [[1, 0, 0, -1], [0, 2, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]]
    [[instances]]
    mesh = "floor"
    translate = [0, 2, 0]
    [environment]
    radiance = 1
    """)
    scene = load_scene(path)
    assert [m.name for m in scene.meshes] == ["floor"]         # the prototype is not drawn itself
    assert [m.name for m in scene.prototypes] == ["crate", "floor"]
    assert len(scene.instances) == 3
    np.testing.assert_allclose(scene.instances[0].transform, prim.trs_matrix([1, 0.25, 0], [0, 45, 0], 1))
    assert scene.instances[1].name == "red crate" and scene.instances[1].material == scene.material_index("red")
    assert scene.instances[1].transform[1, 1] == 2
    assert scene.instances[0].source.endswith(":21")
    image = render(scene, spp=2, size=(32, 32))
    assert np.isfinite(image).all() and image.mean() > 0
    # written back (the viewer's save) and read again: the same prototypes and instances
    from lift_gl.scene.toml_writer import save_toml

    again = load_scene(save_toml(scene, tmp_path / "saved.toml"))
    assert [m.name for m in again.meshes] == ["floor"] and [m.name for m in again.prototypes] == ["crate", "floor"]
    for a, b in zip(scene.instances, again.instances):
        assert (a.mesh, a.material, a.name) == (b.mesh, b.material, b.name)
        np.testing.assert_array_equal(a.transform, b.transform)


@pytest.mark.parametrize("body, line, words", [
    ('[[instances]]\nmesh = "barrel"\n', 22, "unknown mesh 'barrel'"),
    ('[[instances]]\nmesh = "crate"\nscale = [1, 0, 1]\n', 23, "singular"),
    ('[[instances]]\nmesh = "crate"\ntransform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]\n', 23,
     "singular"),
    ('[[instances]]\nmesh = "crate"\ntransform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]\n', 23,
     "affine"),
    ('[[instances]]\nmesh = "crate"\ntransform = [1, 2, 3]\n', 23, "4x4 matrix"),
    ('[[instances]]\nmesh = "crate"\ntransform = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n'
     'translate = [1, 0, 0]\n', 24, "both 'transform' and 'translate'"),
    ('[[instances]]\ntranslate = [1, 0, 0]\n', 21, "needs 'mesh'"),
])
def test_bad_instances_name_file_and_line(tmp_path, body, line, words):
    from lift_gl import load_scene

    path = write(tmp_path, SCENE_HEAD + "\n" + body)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    message = str(err.value)
    assert words in message
    assert f"{path}:{line}" in message


PBRT = """LookAt 0 3 6  0 0.3 0  0 1 0
Camera "perspective" "float fov" [40]
Film "image" "integer xresolution" [64] "integer yresolution" [64]
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
ObjectBegin "pair"
  Material "matte" "rgb Kd" [0.8 0.3 0.2]
  Shape "trianglemesh" "point P" [-0.3 0 0  0.3 0 0  0 0.6 0] "integer indices" [0 1 2]
  Translate 0 0.8 0
  Shape "sphere" "float radius" 0.15
ObjectEnd
AttributeBegin
  Translate 1 0 0
  Rotate 90 0 1 0
  Scale 1 2 1
  ObjectInstance "pair"
AttributeEnd
ObjectInstance "pair"
Shape "trianglemesh" "point P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 1 2 0 2 3]
"""


def test_pbrt_object_instances(tmp_path):
    from lift_gl import load_scene

    path = tmp_path / "inst.pbrt"
    path.write_text(PBRT)
    scene = load_scene(path)
    assert len(scene.meshes) == 1 and len(scene.prototypes) == 1 and len(scene.instances) == 2
    assert len(scene.spheres) == 2                       # spheres are copied, not instanced
    assert scene.instances[0].source == f"{path}:16"
    # the first instance: scaled, turned 90 degrees about y, moved +1 in x (then the loader's
    # mirror in x, as for every pbrt LookAt scene): apex (0, 0.6, 0) -> (-1, 1.2, 0)
    world = flatten_instances(scene).meshes[1]
    np.testing.assert_allclose(world.positions.max(axis=0)[1], 1.2, atol=1e-12)
    np.testing.assert_allclose(sorted(s.center[1] for s in scene.spheres), [0.8, 1.6], atol=1e-12)
    np.testing.assert_allclose(world.positions[:, 0].mean(), -1.0, atol=1e-12)
    image, flat = render(scene, spp=4, size=(32, 32)), render(flatten_instances(scene), spp=4, size=(32, 32))
    assert np.abs(image - flat).mean() < 1e-2 * flat.mean()


@pytest.mark.parametrize("directive, line, words", [
    ('ObjectInstance "tree"\n', 20, "unknown object 'tree'"),
    ('ObjectEnd\n', 20, "ObjectEnd without"),
    ('AttributeBegin\nScale 0 1 1\nObjectInstance "pair"\nAttributeEnd\n', 22, "singular"),
])
def test_pbrt_bad_instances(tmp_path, directive, line, words):
    from lift_gl import load_scene

    path = tmp_path / "bad.pbrt"
    path.write_text(PBRT + directive)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert words in str(err.value) and f"{path}:{line}" in str(err.value)


@pytest.mark.parametrize("change, words", [
    (dict(mesh=3), "uses mesh #3, but there are 1"),
    (dict(material=9), "uses material #9"),
    (dict(transform=np.diag([1.0, 1.0, 0.0, 1.0])), "singular"),
    (dict(transform=np.full((4, 4), np.nan)), "finite"),
])
def test_bad_instances_from_python_are_refused(change, words):
    from lift_gl.scene.validate import validate_scene

    scene = instanced_scene()
    bad = dataclasses.replace(scene.instances[0], source="made.toml:12", **change)
    scene = dataclasses.replace(scene, instances=[bad, *scene.instances[1:]])
    with pytest.raises(SceneError) as err:
        validate_scene(scene)
    assert words in str(err.value) and "made.toml:12" in str(err.value)


def test_opencl_plugin_gets_the_flattened_scene():
    """The OpenCL traversal has one level: an OpenCL plugin renders the instances copied into
    world space, the same image as with the flattened scene given directly."""
    require_opencl()
    scene = instanced_scene()
    with Renderer(scene, size=(32, 32), integrator="ao_cl", seed=2) as r:
        assert not r.scene.instances and r.packed.num_instances == 0
        image = r.render(spp=2)
    flat = render(flatten_instances(scene), "ao_cl", spp=2, size=(32, 32), seed=2)
    np.testing.assert_array_equal(image, flat)
