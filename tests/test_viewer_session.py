"""What the viewer adds to Renderer (ctx=, set_camera, resize, pixel, no-readback display) and the
viewer's session logic, headless: every check compares against a fresh headless Renderer with
the same seed, which is deterministic on one driver (tests/test_render_e2e.py)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import REPO
from lift_gl.app.session import Resolution, ViewSession
from lift_gl.gl.context import create_context
from lift_gl.image_io import read_image
from lift_gl.renderer import Renderer
from lift_gl import load_scene
from lift_gl.scene import Camera

CORNELL = REPO / "scenes" / "cornell.toml"
FURNACE = REPO / "scenes" / "furnace.toml"
MOVED = Camera(position=[0.4, 1.2, 4.0], target=[0.1, 0.8, 0.0], fov_deg=35.0)


# ---- Renderer additions -----------------------------------------------------------------------
def test_set_camera_renders_what_a_fresh_renderer_with_that_camera_renders():
    scene = load_scene(CORNELL)
    ctx = create_context()
    r = Renderer(scene, size=(32, 24), seed=5, ctx=ctx)
    assert r.ctx is ctx
    r.render(spp=2)
    r.set_camera(MOVED)
    assert r.stats.spp == 0  # accumulation restarted
    moved = r.render(spp=3)
    assert scene.camera.fov_deg == 19.5  # the caller's scene is left alone
    fresh = Renderer(dataclasses.replace(scene, camera=MOVED), size=(32, 24), seed=5).render(spp=3)
    np.testing.assert_array_equal(moved, fresh)


def test_resize_renders_what_a_fresh_renderer_of_that_size_renders():
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=(32, 32), seed=2, timers=True)
    r.render(spp=1)
    r.display()
    r.resize((40, 24))
    assert r.size == (40, 24) and r.stats.spp == 0
    image = r.render(spp=3)
    np.testing.assert_array_equal(image, Renderer(scene, size=(40, 24), seed=2).render(spp=3))
    assert r.display().shape == (24, 40, 3)
    assert set(r.stats.pass_ms) >= {"gbuffer", "trace", "accumulate"}
    # Every pass was timed and took some time (llvmpipe's timer queries read 0 for compute
    # dispatches, so there the passes are timed by the wall clock).
    assert all(t.count > 0 and t.last_ns > 0 for t in r.timers.values())


def test_pixel_and_gpu_only_display_agree_with_the_read_back_image():
    r = Renderer(load_scene(CORNELL), size=(24, 16), seed=1)
    image = r.render(spp=3)
    for x, y in [(0, 0), (23, 0), (5, 11), (23, 15)]:
        radiance, count = r.pixel(x, y)
        assert count == 3
        np.testing.assert_allclose(radiance, image[y, x], rtol=1e-6, atol=1e-7)
    assert r.display(1.0, "reinhard", readback=False) is None
    on_gpu = np.frombuffer(r.tonemap.display.read(), np.uint8).reshape(16, 24, 4)[::-1, :, :3]
    np.testing.assert_array_equal(on_gpu, r.display(1.0, "reinhard"))


# ---- the session --------------------------------------------------------------------------------
@pytest.fixture
def session():
    s = ViewSession(create_context(), CORNELL, seed=4, resolution=Resolution(window=(64, 48), scale=0.5))
    yield s
    s.release()


def test_resolution_follows_window_scale_motion_and_reference(session, tmp_path):
    assert session.renderer.size == (32, 24)
    session.set_window_size((100, 60))
    assert session.renderer.size == (50, 30)
    session.resolution.moving_scale = 0.5
    session.set_moving(True)
    assert session.renderer.size == (25, 15)
    session.set_moving(False)
    assert session.renderer.size == (50, 30)
    # A 200x120 reference: the smallest integer factor that fits 50x30 pixels is 4.
    np.save(tmp_path / "ref.npy", np.ones((120, 200, 3), np.float32))
    assert session.load_reference(tmp_path / "ref.npy")
    assert session.reference_factor == 4 and session.renderer.size == (50, 30)
    session.set_window_size((64, 48))
    assert session.renderer.size == (50, 30)  # locked to the reference
    # Moving with a reference loaded: 35x21 is not 200x120 over an integer. The inspector
    # shows no reference value then (it raised ValueError), and the error curve skips the frame.
    session.resolution.moving_scale = 0.7
    session.set_moving(True)
    assert session.renderer.size == (35, 21)
    session.step()
    assert "reference" not in session.inspect(3, 4)
    session.set_moving(False)
    session.step()
    assert session.inspect(3, 4)["reference"] == pytest.approx([1.0, 1.0, 1.0])
    session.clear_reference()
    assert session.renderer.size == (32, 24)


def test_targets_freeze_the_image(session):
    session.sampling.samples_per_frame = 2
    session.sampling.target_spp = 5
    steps = 0
    while session.step():
        steps += 1
    assert (steps, session.renderer.stats.spp, session.renderer.stats.frames) == (3, 5, 3)  # 2 + 2 + 1
    assert session.frozen and session.target_reached
    session.sampling.target_spp = 0
    session.sampling.target_frames = 4
    assert session.step() and not session.step()
    assert session.renderer.stats.frames == 4


def test_accumulation_off_shows_one_frame(session):
    session.sampling.accumulate = False
    session.sampling.samples_per_frame = 3
    for _ in range(3):
        assert session.step()
    assert session.renderer.stats.spp == 3
    # The last frame alone: what a fresh renderer's third frame is not, but its spp count is.
    assert session.renderer.pixel(3, 3)[1] == 3


def test_a_plugin_that_does_not_compile_leaves_the_last_good_one_running(session, tmp_path):
    folder = tmp_path / "broken"
    folder.mkdir()
    (folder / "plugin.toml").write_text('name = "broken"\nentry = "broken.glsl"\n')
    (folder / "broken.glsl").write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) {\n"
                                        "    return vec3(undefined_name);\n}\n")
    session.step()
    good = session.renderer
    assert not session.set_integrator(str(folder))
    assert session.renderer is good
    assert len(session.errors.entries) == 1
    assert f"{folder / 'broken.glsl'}:2:" in session.errors.entries[0]
    assert session.step()  # still renders
    assert not session.set_integrator("no-such-plugin")
    assert "no plugin named 'no-such-plugin'" in session.errors.entries[-1]
    assert session.set_integrator("debug") and session.renderer.plugin.name == "debug"


def test_camera_bookmarks_and_reset(session, tmp_path):
    scene_copy = tmp_path / "cornell.toml"
    scene_copy.write_text(CORNELL.read_text())
    assert session.open_scene(scene_copy)
    session.controller.look(40, 10)
    session.apply_camera()
    moved = session.controller.camera()
    assert session.add_bookmark("corner")
    assert (tmp_path / "cornell.toml.bookmarks.toml").is_file()
    session.reset_camera()
    np.testing.assert_allclose(session.renderer.scene.camera.position, [0, 1, 6.8])
    again = ViewSession(create_context(), scene_copy, resolution=Resolution(window=(16, 16)))
    assert [b.name for b in again.bookmarks] == ["corner"]
    again.go_to_bookmark(0)
    np.testing.assert_allclose(again.renderer.scene.camera.target, moved.target)
    again.release()


def test_split_view_renders_both_integrators_like_headless_ones(session):
    assert session.set_compare("debug")
    for _ in range(2):
        session.step()
    scene = dataclasses.replace(session.scene, camera=session.controller.camera())
    for renderer, name in ((session.renderer, "pt"), (session.compare, "debug")):
        fresh = Renderer(scene, size=(32, 24), integrator=name, seed=4).render(spp=2)
        np.testing.assert_array_equal(renderer.image(), fresh)
    session.update_display()
    assert len(session.display_textures()) == 2


def test_convergence_points_are_the_error_of_the_image_at_that_spp(session, tmp_path):
    reference = Renderer(load_scene(CORNELL), size=(32, 24), seed=99).render(spp=16)
    np.save(tmp_path / "ref.npy", reference)
    session.load_reference(tmp_path / "ref.npy")
    session.sampling.target_spp = 6
    while session.step():
        pass
    points = session.convergence
    assert [p.spp for p in points] == [1, 2, 3, 4, 5, 6]  # x1.25 (rounded up, at least +1), and the last frame
    assert all(b.seconds > a.seconds for a, b in zip(points, points[1:]))
    from lift_gl.metrics import rel_mse
    for p in (points[0], points[-1]):
        image = Renderer(load_scene(CORNELL), size=(32, 24), seed=4).render(spp=p.spp)
        assert p.rel_mse == pytest.approx(rel_mse(image, reference), rel=1e-12)


def test_screenshot_writes_the_displayed_png_and_the_linear_exr(session, tmp_path):
    session.display.exposure = 1.0
    session.step()
    paths = session.screenshot(tmp_path / "shot")
    assert [p.name for p in paths] == ["shot.png", "shot.exr"]
    np.testing.assert_array_equal(read_image(paths[1]), session.renderer.image())
    from PIL import Image
    np.testing.assert_array_equal(np.asarray(Image.open(paths[0])), session.renderer.display(1.0, "aces"))
    session.display.view = "normal"
    png, exr = session.screenshot(tmp_path / "normal")
    np.testing.assert_array_equal(read_image(exr), session.renderer.aov("normal"))


def test_pixel_inspector_reads_radiance_and_gbuffer(session):
    session.step()
    info = session.inspect(16, 12)
    np.testing.assert_allclose(info["radiance"], session.renderer.image()[12, 16], rtol=1e-6, atol=1e-7)
    assert info["samples"] == 1
    assert abs(np.linalg.norm(info["normal"]) - 1.0) < 1e-3 and info["depth"][0] > 0
    assert session.inspect(32, 0) is None


def test_hot_reload_plugs_in_where_the_renderer_offers_it(session):
    """The session polls Renderer.reload() (which restarts accumulation when it recompiled)
    and shows its ShaderError, keeping the renderer."""
    from lift_gl.errors import ShaderError

    session.step()
    calls = []

    def changed(force=False):
        calls.append("changed")
        session.renderer.reset()
        return True

    session.renderer.reload = changed
    session._last_reload_poll = -1e9
    session.step()
    assert calls == ["changed"] and session.renderer.stats.spp == 1  # restarted, then one frame

    def broken(force=False):
        raise ShaderError("undeclared identifier", "plugins/pt/pt.glsl", 12)

    session.renderer.reload = broken
    session._last_reload_poll = -1e9
    renderer = session.renderer
    assert session.step() and session.renderer is renderer
    assert session.errors.entries == ["plugins/pt/pt.glsl:12: undeclared identifier"]
