"""Temporal reprojection (docs/temporal.md): the still camera keeps the exact running mean,
motion vectors match the camera model, disoccluded pixels restart their history, ghosts of
a moving object fade within the bound the minimum blend factor sets, and the camera path
file and the sequence CLI."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import REPO
from lift_gl.camera_path import load_camera_path
from lift_gl.cli import main
from lift_gl.errors import SceneError
from lift_gl.frame_settings import TemporalSettings
from lift_gl.passes.camera import frame_jitter
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene
from lift_gl.scene.loader import load_scene
from lift_gl.scene.primitives import quad, sphere

CORNELL = REPO / "scenes" / "cornell.toml"
SIZE = (40, 32)


def shifted(camera: Camera, dx: float) -> Camera:
    step = np.array([dx, 0.0, 0.0])
    return dataclasses.replace(camera, position=camera.position + step, target=camera.target + step)


def frame_radiance(renderer: Renderer) -> np.ndarray:
    """The last frame's (rgb sum, count), float64 (H, W, 4), row 0 = bottom."""
    w, h = renderer.size
    return np.frombuffer(renderer.trace.frame.read(), np.float32).reshape(h, w, 4).astype(np.float64)


def test_still_camera_is_the_plain_average_of_its_frames():
    scene = load_scene(CORNELL)
    temporal = Renderer(scene, size=SIZE, seed=5, temporal="reproject")
    total = np.zeros((SIZE[1], SIZE[0], 4))
    for _ in range(12):
        temporal.render_frame()
        total += frame_radiance(temporal)
        temporal.set_camera(dataclasses.replace(scene.camera))  # the same camera again: not a move
    temporal.ctx.finish()
    assert temporal.stats.reprojected == 0
    plain = (total[..., :3] / total[..., 3:4])[::-1]
    np.testing.assert_allclose(temporal.image(), plain, rtol=2e-6, atol=1e-7)
    # ...and bit for bit the image of the renderer without reprojection.
    reset = Renderer(scene, size=SIZE, seed=5, temporal="reset", ctx=temporal.ctx)
    assert np.array_equal(reset.render(spp=12), temporal.image())
    assert "runs ONLY on frames where the camera or an object moved" in temporal.explain()
    assert "reproject" not in [p.name for p in reset.passes]


def test_motion_vectors_match_the_camera_projection():
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=SIZE, seed=1, temporal="reproject")
    r.render(spp=1)
    new = shifted(scene.camera, 0.2)
    r.set_camera(new)
    r.render(spp=1)
    w, h = SIZE
    motion = np.frombuffer(r.gbuffer.motion.read(), np.float32).reshape(h, w, 4).astype(np.float64)
    # The frame's first hits, from its jittered sample positions and the view depths the
    # G-buffer kept, through the camera model (shaders/lift/camera.glsl); rows bottom-up.
    depth = np.frombuffer(r.gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)[..., 3].astype(np.float64)
    jx, jy = frame_jitter(r.frame_index - 1, r.seed)
    ys, xs = np.mgrid[0:h, 0:w]
    right, up, forward = new.basis()
    t = math.tan(math.radians(new.fov_deg) / 2)
    ndc_x, ndc_y = (xs + jx) / w * 2 - 1, (ys + jy) / h * 2 - 1
    world = new.position + depth[..., None] * (forward + (ndc_x * t * w / h)[..., None] * right
                                               + (ndc_y * t)[..., None] * up)
    o_right, o_up, o_forward = scene.camera.basis()
    rel = world - scene.camera.position
    surface = depth > 0
    z = np.where(surface, rel @ o_forward, 1.0)
    expected_x = ((rel @ o_right) / (z * t * w / h) * 0.5 + 0.5) * w - (xs + jx)
    expected_y = ((rel @ o_up) / (z * t) * 0.5 + 0.5) * h - (ys + jy)
    assert surface.mean() > 0.7
    # The camera moved 0.2 to the right: a point seen now was further right before.
    assert np.all(expected_x[surface] > 0.3)
    np.testing.assert_allclose(motion[..., 0][surface], expected_x[surface], atol=2e-3)
    np.testing.assert_allclose(motion[..., 1][surface], expected_y[surface], atol=2e-3)
    np.testing.assert_allclose(motion[..., 2][surface], z[surface], rtol=1e-4)  # depth in the old camera
    assert np.all(motion[~surface] == 0)  # background: cleared, no history


def occluder_scene(size=(48, 32)) -> Scene:
    """An emissive back wall behind a diffuse sphere: where the wall is seen its radiance is
    its emission, exactly, so histories can be checked pixel by pixel."""
    materials = [Material(name="wall", base_color=np.zeros(3), emission=np.array([0.2, 0.3, 1.0])),
                 Material(name="ball", base_color=np.zeros(3), emission=np.array([1.0, 0.1, 0.05]))]
    wall = quad([-4, -3, -1], [8, 0, 0], [0, 6, 0], material=0, name="wall")
    ball = sphere([0, 0, 2.5], 0.6, material=1)
    ball.authored = {"name": "ball"}
    camera = Camera(position=np.array([0.0, 0.0, 6.0]), target=np.array([0.0, 0.0, 0.0]), fov_deg=40.0)
    return Scene(camera=camera, materials=materials, meshes=[wall], spheres=[ball], film_size=size)


def hidden_by_sphere(points, eye, centre, radius, margin):
    """Whether the segment eye -> point passes within (1 - margin) radius of the centre."""
    d = points - eye
    length = np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-9)
    d = d / length
    s = np.clip(((centre - eye) * d).sum(-1, keepdims=True), 0, length)
    closest = eye + s * d
    return np.linalg.norm(closest - centre, axis=-1) < (1 - margin) * radius


def test_disoccluded_pixels_restart_their_history():
    scene = occluder_scene()
    r = Renderer(scene, size=scene.film_size, seed=2, temporal="reproject")
    r.render(spp=8)
    new = shifted(scene.camera, 1.0)
    r.set_camera(new)
    r.render(spp=1)
    assert r.stats.reprojected == 1
    history = r.aov("history")[..., 0]
    depth = r.aov("depth")[..., 0]
    w, h = scene.film_size
    right, up, forward = new.basis()
    t = math.tan(math.radians(new.fov_deg) / 2)
    ys, xs = np.mgrid[0:h, 0:w]
    d = (forward + (((xs + 0.5) / w * 2 - 1) * t * w / h)[..., None] * right
         + ((((h - 1 - ys) + 0.5) / h * 2 - 1) * t)[..., None] * up)
    world = new.position + depth[..., None] * d
    on_wall = np.abs(world[..., 2] + 1) < 1e-3
    centre = scene.spheres[0].center
    # Wall points the old camera could not see (well inside the sphere's shadow from the old
    # eye) and that the new camera sees: revealed by the move. Points clearly seen from both.
    revealed = on_wall & hidden_by_sphere(world, scene.camera.position, centre, 0.6, margin=0.15)
    seen_before = on_wall & ~hidden_by_sphere(world, scene.camera.position, centre, 0.6, margin=-0.25)
    seen_before &= ~hidden_by_sphere(world, new.position, centre, 0.6, margin=-0.25)
    old_right, _, old_forward = scene.camera.basis()
    rel = world - scene.camera.position
    old_z = np.where(depth > 0, rel @ old_forward, 1.0)
    old_x = ((rel @ old_right) / (old_z * t * w / h) * 0.5 + 0.5) * w
    seen_before &= (old_x > 1) & (old_x < w - 1)  # in the old view, not at its border
    assert revealed.sum() >= 10 and seen_before.sum() > 200
    assert np.all(history[revealed] == 1)  # history length 1: this frame's one sample
    assert np.all(history[seen_before] > 1)
    rejection = r.aov("rejection")
    assert np.all(rejection[revealed][:, 0] > 0.99)  # rejected by depth
    # Where the wall was seen before, its reprojected history is still its exact emission.
    np.testing.assert_allclose(r.image()[seen_before], np.broadcast_to([0.2, 0.3, 1.0], (seen_before.sum(), 3)),
                               rtol=1e-5)


def test_ghost_of_a_moving_object_fades_within_the_bound():
    """The ball moves right across the wall, one step a frame (the camera stays). Pixels it
    leaves must lose its colour: fully on the first frame where the depth test sees the wall
    (footprint interior), and at the pixels of its edge (which mixed ball and wall through
    the subpixel jitter, and may pass the depth test) by at least the minimum blend factor a
    frame, so below 2% within N = ceil(log(0.02) / log(1 - 0.1)) = 38 frames."""
    scene = occluder_scene(size=(48, 32))
    min_blend = 0.1
    r = Renderer(scene, size=scene.film_size, seed=3, temporal=TemporalSettings("reproject", min_blend=min_blend))
    r.render(spp=16)
    was_ball = r.image()[..., 0] > 0.6  # the ball's pixels (red) before it moves
    wall = np.array([0.2, 0.3, 1.0])
    steps = 12
    ghost_interior, ghost_any, kept_history = [], [], []
    for step in range(1, steps + 1):
        ball = dataclasses.replace(scene.spheres[0], center=scene.spheres[0].center + [0.25 * step, 0, 0])
        r.update_scene(dataclasses.replace(scene, spheres=[ball]))
        image = r.render(spp=1)
        now_ball = r.aov("depth")[..., 0] < 6.5  # pixels whose G-buffer sample hits the ball now
        left = was_ball & ~_dilate(now_ball, 2)  # pixels the ball has left (and not next to it)
        red = np.clip((image[..., 0] - wall[0]) / (1.0 - wall[0]), 0, None)  # the ball's share
        interior = left & ~_dilate(~was_ball, 1)
        ghost_interior.append(red[interior].max(initial=0.0))
        ghost_any.append(red[left].max(initial=0.0))
        # The object's motion vectors: the ball's own pixels carry their history along
        # (without them they would find the wall's depth there and restart).
        on_ball = now_ball & ~_dilate(~now_ball, 1)
        if on_ball.sum() > 20:  # until it leaves the picture
            kept_history.append((r.aov("history")[..., 0][on_ball] > 1).mean())
    assert r.stats.reprojected == steps
    assert len(kept_history) >= 4 and min(kept_history) > 0.9
    assert max(ghost_interior) < 1e-5  # rejected at once: no ghost at all
    bound = math.ceil(math.log(0.02) / math.log(1 - min_blend))
    # Each frame the ghost shrinks by (1 - min_blend) at least: check that rate on what we saw.
    for k, g in enumerate(ghost_any):
        assert g <= (1 - min_blend) ** (k + 1) + 1e-6
    assert bound == 38


def _dilate(mask, n):
    out = mask.copy()
    for _ in range(n):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def test_slanted_floor_keeps_its_history():
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=(48, 48), seed=1, temporal="reproject")
    r.render(spp=2)
    r.set_camera(shifted(scene.camera, 0.05))
    r.render(spp=1)
    normal = r.aov("normal")
    floor = normal[..., 1] > 0.99
    floor &= ~_dilate(~floor, 1)  # not its edges
    rejected = r.aov("rejection").sum(-1)
    assert floor.sum() > 100
    assert (rejected[floor] > 0).mean() < 0.02


def test_variance_from_moments_matches_the_frames():
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=SIZE, seed=4, temporal="reproject")
    lum = []
    for _ in range(10):
        r.render_frame()
        f = frame_radiance(r)
        lum.append((f[..., :3] / f[..., 3:4]) @ [0.2126, 0.7152, 0.0722])
    lum = np.array(lum)
    expected = np.var(lum, axis=0, ddof=1)[::-1]
    # float32 sums of L and L^2: where L hardly varies (the light), the difference of the two
    # loses the digits of L^2 beyond float32's: allow a few ulps of the mean of L^2.
    ulps = 8 * np.spacing(np.float32(1)) * (lum ** 2).mean(axis=0)[::-1]
    assert np.all(np.abs(r.variance() - expected) <= 1e-3 * expected + ulps)
    assert np.array_equal(r.aov("variance")[..., 1], r.variance())


def test_accumulation_aovs():
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=SIZE, seed=1)  # temporal="reset": the views exist too
    r.render(spp=3)
    assert np.all(r.aov("history") == 3)
    assert np.all(r.aov("rejection") == 0)
    albedo = r.aov("albedo")
    irradiance = r.aov("irradiance")
    lit = albedo > 0.1
    np.testing.assert_allclose(irradiance[lit] * albedo[lit], r.image()[lit], rtol=1e-3)


CAMERA_PATH = """# a pan
[[keyframe]]
time = 0
position = [0, 1, 6.8]
target = [0, 1, 0]

[[keyframe]]
time = 2
position = [0.4, 1, 6.8]
target = [0.4, 1, 0]
fov = 25

[[move]]
object = "glass sphere"
velocity = [-0.1, 0, 0]
"""


def test_camera_path_interpolates_keyframes(tmp_path):
    f = tmp_path / "pan.toml"
    f.write_text(CAMERA_PATH)
    path = load_camera_path(f)
    assert path.times(5) == [0, 0.5, 1.0, 1.5, 2.0]
    scene = load_scene(CORNELL)
    cam = path.camera_at(0.5, scene.camera)
    np.testing.assert_allclose(cam.position, [0.1, 1, 6.8])
    assert cam.fov_deg == pytest.approx(19.5 + 0.25 * (25 - 19.5))
    moved = path.scene_at(1.0, scene)
    before = [s for s in scene.spheres if s.authored["name"] == "glass sphere"][0]
    after = [s for s in moved.spheres if s.authored["name"] == "glass sphere"][0]
    np.testing.assert_allclose(after.center - before.center, [-0.1, 0, 0])


@pytest.mark.parametrize("text, message", [
    ("[[keyframe]]\ntime = 0\nposition = [0, 0, 1]\n", "lacks target"),
    ("[[keyframe]]\ntime = 1\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n"
     "[[keyframe]]\ntime = 0\nposition = [0, 0, 2]\ntarget = [0, 0, 0]\n", "must increase"),
    ("[[keyframe]]\ntime = 0\nposition = [0, 0]\ntarget = [0, 0, 0]\n", "3 numbers"),
    ("[camera]\n", "unknown table"),
    ("[[keyframe]\n", "not a valid TOML"),
])
def test_bad_camera_path_names_the_file(tmp_path, text, message):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match=message) as info:
        load_camera_path(f)
    assert str(f) in str(info.value)


def test_render_sequence_cli(tmp_path, capsys):
    f = tmp_path / "pan.toml"
    f.write_text(CAMERA_PATH)
    out = tmp_path / "frames"
    assert main(["render", str(CORNELL), "--size", "32x32", "--camera-path", str(f), "--frames", "3",
                 "--spp", "1", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    assert "2 reprojected frames" in capsys.readouterr().out
    assert main(["render", str(CORNELL), "--size", "32x32", "--camera-path", str(f), "--frames", "2",
                 "--spp", "1", "--aov", "history", "--out", str(tmp_path / "h_{frame:02d}.png")]) == 0
    assert (tmp_path / "h_01.png").is_file()
    assert main(["render", str(CORNELL), "--frames", "2", "--out", str(out)]) == 2  # --frames needs a path
    assert main(["render", str(CORNELL), "--camera-path", str(f), "--out", str(tmp_path / "one.png")]) == 2
    assert main(["render", str(CORNELL), "--clamp-sigma", "1", "--out", str(tmp_path / "x.png")]) == 2
    with pytest.raises(SystemExit) as exit_:   # refused as the command line is read
        main(["render", str(CORNELL), "--camera-path", str(f), "--min-blend", "0", "--out", str(out)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "a pattern with {frame}" in err and "need --temporal reproject" in err
    assert "argument --min-blend: must be above 0" in err


def test_shipped_camera_path_fits_the_cornell_box():
    path = load_camera_path(REPO / "scenes" / "paths" / "cornell_pan.toml")
    scene = load_scene(CORNELL)
    path.check_objects(scene)  # raises if the [[move]] names an object the scene lacks
    assert len(path.keyframes) == 2 and path.moves[0].name == "glass sphere"
    with pytest.raises(SceneError, match="no such ball"):
        dataclasses.replace(path, moves=[dataclasses.replace(path.moves[0], name="no such ball")]).check_objects(scene)


def test_viewer_session_reprojects_and_shows_the_views():
    from lift_gl.app.session import Resolution, ViewSession
    from lift_gl.gl.context import create_context

    s = ViewSession(create_context(), CORNELL, seed=4, resolution=Resolution(window=(32, 24)), temporal="reproject")
    try:
        for _ in range(3):
            s.step()
        before = s.aov_display("history")
        s.controller.set_camera(shifted(s.scene.camera, 0.1))
        s.apply_camera()
        s.step()
        assert s.renderer.stats.reprojected == 1
        after = s.aov_display("history")
        assert after is not before  # views of the accumulation follow the frames (not cached)
        assert s.aov("history").max() == 4  # 3 samples carried over + 1
        assert s.aov_display("rejection").shape == (24, 32, 3)
    finally:
        s.release()
