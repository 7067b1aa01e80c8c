"""The viewer's live scene edits, headless (app/scene_editor.py over a ViewSession): picking
the object under a pixel, dragging a light in its own plane, light and material edits
reaching every renderer, saving. Images are compared with a fresh headless Renderer of the
edited scene (deterministic on one driver); geometry with numpy."""
from __future__ import annotations

import copy
import dataclasses
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO
from lift_gl import load_scene
from lift_gl.app.scene_editor import camera_ray
from lift_gl.app.session import Resolution, ViewSession
from lift_gl.gl.context import create_context
from lift_gl.renderer import Renderer
from lift_gl.scene import edit
from lift_gl.scene.diff import scene_differences
from lift_gl.scene.edit import ObjectRef
from test_viewer_window import display  # noqa: F401  (the Xvfb fixture)

CORNELL = REPO / "scenes" / "cornell.toml"
LIGHT = ObjectRef("mesh", 5)


def project(camera, size, point) -> tuple[int, int]:
    """The render pixel (x, y from the top left) that sees world point `point`."""
    right, up, forward = camera.basis()
    d = np.asarray(point, np.float64) - camera.position
    t = np.tan(np.radians(camera.fov_deg) / 2)
    w, h = size
    x = (d @ right) / (d @ forward) / (t * w / h)
    y = (d @ up) / (d @ forward) / t
    return int((x + 1) / 2 * w), int(h - (y + 1) / 2 * h)


def _cornell_session(tmp_path, options=None) -> ViewSession:
    scene_file = tmp_path / "cornell.toml"
    scene_file.write_text(CORNELL.read_text())
    return ViewSession(create_context(), scene_file, seed=3, resolution=Resolution(window=(48, 48)), options=options)


@pytest.fixture
def session(tmp_path):
    s = _cornell_session(tmp_path)
    yield s
    s.release()


def _assert_picks(session) -> None:
    """The light, the floor and the sphere picked where the camera sees their points."""
    editor, camera, size = session.editor, session.renderer.scene.camera, session.renderer.size
    assert editor.pick(project(camera, size, edit.object_center(session.scene, LIGHT))) == LIGHT
    assert editor.pick(project(camera, size, [0.0, 0.01, 0.5])) == ObjectRef("mesh", 0)  # the floor
    assert editor.pick(project(camera, size, [0.4, 0.4, 0.7])) == ObjectRef("sphere", 0)


def _fresh_image(session, spp):
    scene = dataclasses.replace(copy.deepcopy(session.scene), camera=session.renderer.scene.camera)
    r = Renderer(scene, size=session.renderer.size, seed=session.seed)
    image = r.render(spp=spp)
    r.release()
    return image


def test_camera_ray_goes_through_the_projected_pixel(session):
    camera, size = session.renderer.scene.camera, session.renderer.size
    point = np.array([0.3, 0.7, -0.2])
    x, y = project(camera, size, point)
    origin, direction = camera_ray(camera, size, (x, y))
    # The ray passes within a pixel's footprint of the point.
    distance = np.linalg.norm(np.cross(point - origin, direction))
    pixel_size = 2 * np.tan(np.radians(camera.fov_deg) / 2) * np.linalg.norm(point - origin) / size[1]
    assert distance < pixel_size


def test_pick_with_a_ray_cast_gbuffer(tmp_path, monkeypatch):
    """GPUs with few raster units cast the G-buffer's rays (passes/gbuffer.py TracedGBufferPass):
    picking reads the same visibility there."""
    from lift_gl.options import Options
    from lift_gl.passes.gbuffer import TracedGBufferPass

    s = _cornell_session(tmp_path, Options(gbuffer="traced"))
    try:
        assert isinstance(s.renderer.gbuffer, TracedGBufferPass)
        s.step()
        _assert_picks(s)
    finally:
        s.release()


def test_pick_select_and_drag_a_light_in_its_plane(session):
    editor = session.editor
    camera, size = session.renderer.scene.camera, session.renderer.size
    session.step()
    _assert_picks(session)
    center = edit.object_center(session.scene, LIGHT)
    start = project(camera, size, center)

    assert editor.press(start)  # an emitter: the drag starts at once
    assert editor.selected == LIGHT and editor.selected_is_emitter
    end = (start[0] + 6, start[1] + 4)
    editor.drag((start[0] + 3, start[1] + 1))
    editor.drag(end)
    editor.release()
    assert editor.apply_pending() and not editor.apply_pending()  # applied once
    moved = edit.object_center(session.scene, LIGHT)
    # The camera sees the ceiling light edge-on, so the mouse moves in the view plane through
    # the light's centre (facing -z), and right/up there become +x/-z on the ceiling: the
    # light slides along the ceiling, never off it.
    def on_view_plane(pixel):
        o, d = camera_ray(camera, size, pixel)
        return o + d * (center[2] - o[2]) / d[2]

    shift = on_view_plane(end) - on_view_plane(start)
    np.testing.assert_allclose(moved - center, [shift[0], 0.0, -shift[1]], atol=1e-6)
    assert shift[0] > 0 and shift[1] < 0  # right and down on the screen: +x, towards the camera
    assert editor.dirty and session.renderer.stats.spp == 0

    session.step()
    np.testing.assert_array_equal(session.renderer.image(), _fresh_image(session, 1))


def test_a_wall_is_selected_but_not_dragged_by_the_first_click(session):
    editor = session.editor
    camera, size = session.renderer.scene.camera, session.renderer.size
    back_wall = project(camera, size, [0.0, 1.4, -1.0])
    assert not editor.press(back_wall)  # selects only: the drag turns the camera as usual
    assert editor.selected == ObjectRef("mesh", 2) and not editor.dragging
    assert editor.press(back_wall)  # the second press on the selected object drags it


def test_light_and_material_edits_reach_both_sides_of_the_split_view_and_save(session, tmp_path):
    editor = session.editor
    session.set_compare("pt", {"max_depth": 2})
    editor.select(LIGHT)
    assert editor.set_light(10.0, [1.0, 0.2, 0.2])
    assert editor.scale(1.3)
    gold = session.scene.material_index("gold")
    editor.material = gold
    assert editor.set_roughness(0.6) and editor.set_colour([0.9, 0.9, 0.2])
    for renderer in session.renderers:
        assert np.array_equal(renderer.packed.materials, session.renderer.packed.materials)
        assert renderer.scene.materials[gold].alpha == pytest.approx(0.36)
    session.step()
    np.testing.assert_array_equal(session.renderer.image(), _fresh_image(session, 1))

    assert not editor.set_roughness(2.0)  # out of range: an error in the log, nothing changes
    assert "roughness" in session.errors.entries[-1]
    saved = editor.save(tmp_path / "lab" / "mine.toml")
    assert saved.is_file() and not editor.dirty
    assert scene_differences(session.scene, load_scene(saved)) == []
    # Another scene: the editor starts over.
    assert session.open_scene(REPO / "scenes" / "furnace.toml")
    assert session.editor.selected is None and session.editor.emitters() == []


def test_the_edit_panel_draws_in_a_real_window(display, tmp_path):
    """`lift-gl view --panels edit` under Xvfb: the panel is drawn (its rectangle is in the
    screenshot's JSON) and nothing went to the error log."""
    env = dict(os.environ, DISPLAY=display)
    out = tmp_path / "edit.png"
    cmd = [sys.executable, "-m", "lift_gl", "view", str(CORNELL), "--size", "480x320", "--scale", "0.25",
           "--panels", "edit,help", "--frames", "1", "--screenshot", str(out)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(out.with_suffix(".json").read_text())
    assert "Edit" in report["panels"] and report["errors"] == []
    x, y, w, h = report["panels"]["Edit"]
    assert w > 100 and h > 100
