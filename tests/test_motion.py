"""Motion blur in the scene: the TOML keys (`motion`, `shutter`) and their errors, the
packed motion and the swept BVH, the feature define, the G-buffer's moment, and the
motion-blurred image against a second estimator: static renders at random moments."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from sample_stats import block_means, welch_t
from lift_gl.accel.bvh import check_invariants
from lift_gl.errors import SceneError
from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene
from lift_gl.scene.features import SceneFeatures
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.scene.pack import pack_scene
from lift_gl.scene.primitives import box, quad, sphere

SCENE = """[camera]
position = [0, 1, 5]
target = [0, 0.5, 0]
shutter = [0.25, 0.75]

[materials.white]
color = 0.7

[[objects]]
type = "sphere"
material = "white"
center = [0, 0.5, 0]
radius = 0.5
motion = { translate = [2, 0, 0] }

[[objects]]
type = "box"
material = "white"
translate = [1, 0, 0]
motion = { translate = [0, 0, -4] }

[[objects]]
type = "quad"
material = "white"
center = [0, 0, 0]
u = [0, 0, 4]
v = [4, 0, 0]
"""


def _write(tmp_path, text) -> Path:
    path = tmp_path / "motion.toml"
    path.write_text(text)
    return path


# ---------------------------------------------------------------- scene files
def test_motion_and_shutter_are_read():
    for name in ("motion_blur.toml", "dof.toml"):
        load_scene(REPO / "scenes" / name)  # the shipped examples load
    scene = load_scene(REPO / "scenes" / "motion_blur.toml")
    assert scene.camera.shutter == (0.0, 1.0) and scene.has_motion
    moving = [o for o in (*scene.meshes, *scene.spheres) if o.velocity is not None]
    assert len(moving) == 3


def test_motion_keys(tmp_path):
    scene = load_scene(_write(tmp_path, SCENE))
    assert scene.camera.shutter == (0.25, 0.75)
    np.testing.assert_array_equal(scene.spheres[0].velocity, [2, 0, 0])
    # The velocity is in world space: the box's own transform does not turn it.
    np.testing.assert_array_equal(scene.meshes[0].velocity, [0, 0, -4])
    assert scene.meshes[1].velocity is None
    assert scene.has_motion and SceneFeatures.of(scene).motion
    # A shutter that opens and closes at once shows no motion (the scene at that moment).
    still = load_scene(_write(tmp_path, SCENE.replace("[0.25, 0.75]", "[0.5, 0.5]")))
    assert not still.has_motion and not SceneFeatures.of(still).motion
    assert load_scene(_write(tmp_path, SCENE.replace("shutter = [0.25, 0.75]\n", ""))).camera.shutter == (0, 1)


@pytest.mark.parametrize("old, new, line, words", [
    ("shutter = [0.25, 0.75]", "shutter = [1, 0]", 4, "closes before it opens"),
    ("shutter = [0.25, 0.75]", "shutter = 1", 4, "[open, close]"),
    ("motion = { translate = [2, 0, 0] }", "motion = [2, 0, 0]", 14, "must be a table"),
    ("motion = { translate = [2, 0, 0] }", "motion = { translate = [2, 0] }", 14, "list of 3 numbers"),
    ("motion = { translate = [2, 0, 0] }", "motion = { }", 14, "needs 'translate'"),
])
def test_bad_motion_names_file_and_line(tmp_path, old, new, line, words):
    path = _write(tmp_path, SCENE.replace(old, new))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.path == str(path) and info.value.line == line
    assert words in info.value.message


def test_unknown_motion_key_warns_with_line(tmp_path):
    path = _write(tmp_path, SCENE.replace("{ translate = [2, 0, 0] }", "{ translate = [2, 0, 0], rotate = [0, 9, 0] }"))
    with pytest.warns(SceneWarning, match=r"motion\.toml:14: unknown key 'rotate'"):
        load_scene(path)


# ---------------------------------------------------------------- packing and the BVH
def _moving_soup(n=300, seed=5):
    """Many small moving boxes (each its own velocity) and a moving sphere."""
    rng = np.random.default_rng(seed)
    meshes = []
    for i in range(n // 12):
        m = box(rng.uniform(-2, 2, 3), rng.uniform(0.05, 0.3, 3), material=0)
        m.velocity = rng.normal(0, 1.0, 3) if i % 3 else None  # some stand still
        meshes.append(m)
    s = sphere([0, 0, 0], 0.5, 0)
    s.velocity = np.array([0.0, 3.0, 0.0])
    camera = Camera(position=[0, 0, 8], target=[0, 0, 0], shutter=(0.5, 2.0))
    return Scene(camera=camera, materials=[Material("m")], meshes=meshes, spheres=[s])


def test_pack_stores_shutter_open_positions_and_bvh_boxes_at_open_and_close():
    scene = _moving_soup()
    packed = pack_scene(scene, origin=np.zeros(3))  # world coordinates: no rebasing
    assert packed.has_motion
    T = packed.num_triangles
    open_, close = scene.camera.shutter
    # The unpacked triangles at time 0, in the packer's order, and their velocities.
    corners = np.concatenate([m.positions[m.indices] for m in scene.meshes]).astype(np.float64)
    velocity = np.concatenate([np.broadcast_to(m.velocity if m.velocity is not None else np.zeros(3),
                                               (len(m.indices), 3)) for m in scene.meshes])
    # Match packed triangles to input triangles through their (unique) shutter-open corners.
    at_open = corners + open_ * velocity[:, None]
    key = {tuple(np.round(t.ravel(), 4)): i for i, t in enumerate(at_open)}
    order = np.array([key[tuple(np.round(t.ravel(), 4))] for t in packed.tri_pos[:T, :, :3].astype(np.float64)])
    assert sorted(order) == list(range(T))
    np.testing.assert_allclose(packed.motion[:T, :3], velocity[order] * (close - open_), rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(packed.spheres[0, 0, :3], [0, open_ * 3.0, 0], atol=1e-6)
    np.testing.assert_allclose(packed.motion[T, :3], [0, 3.0 * (close - open_), 0], atol=1e-6)
    # One tree, two sets of boxes: at shutter open (bvh_nodes) and close (after the
    # primitives' rows in `motion`). Each holds its triangles at that moment, and so does
    # their blend at any moment between (checked at a few), as the GPU blends them.
    start = packed.tri_pos[:T, :, :3]
    move = packed.motion[:T, None, :3]
    close_rows = packed.motion[T + len(scene.spheres):]
    from lift_gl.accel.bvh import BVH
    for t in (0.0, 0.3, 0.75, 1.0):
        nodes = packed.bvh_nodes.copy()
        nodes[:, 0:3] = (1 - t) * nodes[:, 0:3] + t * close_rows[0::2, :3]
        nodes[:, 4:7] = (1 - t) * nodes[:, 4:7] + t * close_rows[1::2, :3]
        bvh = BVH(nodes=nodes, order=np.arange(T, dtype=np.uint32), depth=packed.bvh_depth)
        check_invariants(bvh, start + np.float32(t) * move)
    # The scene bounds hold the sphere at both ends.
    assert packed.bounds[1][1] >= 0.5 + 3.0 * close - 1e-6 and packed.bounds[0][1] <= open_ * 3.0 - 0.5 + 1e-6


def test_node_boxes_of_a_rigid_motion_just_move():
    """One mesh moving as a whole: its node boxes at shutter close are those at open moved
    by the displacement (to the padding), not stretched along the path as swept boxes are."""
    m = box([0, 0, 0], [1, 1, 1], material=0)
    m.velocity = np.array([3.0, -1.0, 0.5])
    scene = Scene(camera=Camera(position=[0, 0, 9], target=[0, 0, 0]), materials=[Material("m")], meshes=[m])
    packed = pack_scene(scene)
    close = packed.motion[packed.num_triangles:]
    np.testing.assert_allclose(close[0::2, :3], packed.bvh_nodes[:, 0:3] + m.velocity, atol=1e-5)
    np.testing.assert_allclose(close[1::2, :3], packed.bvh_nodes[:, 4:7] + m.velocity, atol=1e-5)
    np.testing.assert_allclose(packed.bvh_nodes[0, 0:3], [-0.5] * 3, atol=1e-5)


def test_a_still_scene_packs_as_before():
    scene = _moving_soup()
    for o in (*scene.meshes, *scene.spheres):
        o.velocity = None
    packed = pack_scene(scene)
    assert not packed.has_motion and packed.motion is None
    assert not SceneFeatures.of(scene).motion


def test_motion_code_is_compiled_only_for_moving_scenes():
    scene = _moving_soup(24)
    probe = "vec4 probe(uint i) { return motion[i]; }\n"
    import moderngl
    for moving in (True, False):
        if not moving:
            for o in (*scene.meshes, *scene.spheres):
                o.velocity = None
        r = Renderer(scene, size=(8, 8), integrator="drt")
        try:
            r.ctx.compute_shader(r.trace.source.text + probe).release()
            compiled = True
        except moderngl.Error:
            compiled = False
        assert compiled == moving and ("+ motion" in r.explain()) == moving
        r.release()


# ---------------------------------------------------------------- rendering
def _room(shutter=(0.0, 1.0)) -> Scene:
    """A floor and back wall under an area light; a diffuse sphere and a small lamp move
    right, a rough metal box moves back: shadows, light sampling, glossy reflections and
    surfaces of moving things all take part."""
    materials = [Material("white", base_color=[0.7, 0.7, 0.7]),
                 Material("lamp", base_color=[0, 0, 0], emission=[8, 8, 8]),
                 Material("metal", "conductor", base_color=[0.9, 0.7, 0.5], alpha=0.15),
                 Material("small lamp", base_color=[0, 0, 0], emission=[30, 10, 5])]
    meshes = [quad([-2, 0, 2], [4, 0, 0], [0, 0, -4], 0, "floor"),        # faces +y
              quad([-2, 0, -2], [4, 0, 0], [0, 3, 0], 0, "back wall"),    # faces +z
              quad([-0.5, 2.5, -0.5], [1, 0, 0], [0, 0, 1], 1, "light"),  # faces -y
              box([0.8, 0.3, 0.0], [0.5, 0.6, 0.5], 2, "metal box"),
              quad([-1.2, 1.2, -1.0], [0.2, 0, 0], [0, 0.2, 0], 3, "small lamp")]
    meshes[3].velocity = np.array([0.0, 0.0, -0.8])
    meshes[4].velocity = np.array([0.9, 0.0, 0.0])
    ball = sphere([-0.7, 0.35, 0.4], 0.35, 0)
    ball.velocity = np.array([0.9, 0.0, 0.0])
    camera = Camera(position=[0, 1.2, 4.5], target=[0, 0.7, 0], fov_deg=40, shutter=shutter)
    return Scene(camera=camera, materials=materials, meshes=meshes, spheres=[ball], max_depth=4)


SIZE = (32, 32)


def _render(scene, integrator, seed, spp, options=None):
    r = Renderer(scene, size=SIZE, integrator=integrator, seed=seed, options=options)
    image = r.render(spp=spp).astype(np.float64)
    assert r.stats.dropped_samples == 0
    r.release()
    return image


def test_motion_blur_is_the_mean_of_the_scene_over_the_shutter():
    """Second estimator: the scene frozen at a uniformly random moment u of the shutter
    (shutter = [u, u]: nothing moves and no motion code runs), rendered with independent
    seeds. Each such render is an unbiased estimate of the motion-blurred image, so both
    sets of renders have the same mean: the image and every 4x4 block agree within their
    standard errors (Welch's t; 16 + 16 renders, P(|t| > 6) < 1e-5 per block)."""
    K = 16
    moments = np.random.default_rng(2024).random(K)
    blurred = np.array([_render(_room(), "drt", 1 + k, 16) for k in range(K)])
    frozen = np.array([_render(_room((u, u)), "drt", 101 + k, 16) for k, u in enumerate(moments)])
    assert abs(welch_t(blurred.mean(axis=(1, 2, 3)), frozen.mean(axis=(1, 2, 3)))) < 4.5
    t = welch_t(block_means(blurred), block_means(frozen))
    assert np.abs(t).max() < 6.0, np.sort(np.abs(t).ravel())[-5:]
    # And the test can tell: the scene frozen at shutter open is a different image.
    still = np.array([_render(_room((0.0, 0.0)), "drt", 201 + k, 16) for k in range(4)])
    assert np.abs(welch_t(block_means(blurred), block_means(still))).max() > 10


def test_gbuffer_plugins_see_the_scene_at_shutter_open():
    """A plugin that takes its first hit from the raster G-buffer (pt) never sets the ray
    time, so it renders the moment the G-buffer rasterized, shutter open: the same image
    as the scene frozen there, with the same random numbers (and the same light selection:
    auto would pick the light tree for the frozen scene only, its random numbers then mapping
    to other lights)."""
    power = Options(light_selection="power")
    moving = _render(_room(), "pt", 7, 8, power)
    frozen = _render(_room((0.0, 0.0)), "pt", 7, 8, power)
    # Same rays and random numbers; only the BVH differs (swept boxes), which may change
    # which of two triangles sharing an edge a grazing ray reports.
    close = np.isclose(moving, frozen, rtol=1e-4, atol=1e-5).all(axis=-1)
    assert close.mean() > 0.99, close.mean()


def test_a_still_scene_compiled_with_every_feature_renders_the_same():
    """`--all-features` compiles the motion code for a scene that has no motion buffer of
    its own: it gets zero motion (never an out-of-bounds read), and the same image as the
    specialised shader, within noise (the extra features change which random numbers go
    where: the time sample, the environment's share of light samples)."""
    scene = _room((0.5, 0.5))
    K = 6
    specialised = np.array([_render(scene, "drt", 10 + k, 8) for k in range(K)])
    everything = []
    for k in range(K):
        r = Renderer(scene, size=SIZE, integrator="drt", seed=20 + k, features=SceneFeatures.everything())
        assert r.buffers.motion is not None and "HAS_MOTION" in r.defines
        everything.append(r.render(spp=8).astype(np.float64))
        assert r.stats.dropped_samples == 0
        r.release()
    # 6 + 6 renders: two-sided p < 1e-3 at |t| > 4.6 (10 degrees of freedom).
    t = welch_t(specialised.mean(axis=(1, 2, 3)), np.array(everything).mean(axis=(1, 2, 3)))
    assert abs(t) < 4.6, t


def test_refit_over_the_build_positions_gives_the_build_boxes():
    from lift_gl.accel.bvh import build_bvh, refit_boxes
    rng = np.random.default_rng(9)
    tris = (rng.random((500, 1, 3)) + 0.05 * rng.standard_normal((500, 3, 3))).astype(np.float32)
    bvh = build_bvh(tris)
    lo, hi = refit_boxes(bvh, tris[bvh.order])
    np.testing.assert_array_equal(lo, bvh.bmin)
    np.testing.assert_array_equal(hi, bvh.bmax)
