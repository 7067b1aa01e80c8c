"""The viewer's pieces that need no GL: bookmarks, image placement, AOV colours, the scene list."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.app.aov_view import aov_to_display
from lift_gl.app.bookmarks import Bookmark, BookmarkError, bookmarks_path, load_bookmarks, save_bookmarks
from lift_gl.app.image_view import fit_rect, window_to_pixel
from lift_gl.app.scene_catalog import find_scenes
from lift_gl.scene import Camera
from lift_gl.tonemap import srgb_encode


# ---- bookmarks ---------------------------------------------------------------------------
def test_bookmarks_round_trip_beside_the_scene(tmp_path):
    scene = tmp_path / "room.toml"
    path = bookmarks_path(scene)
    assert path == tmp_path / "room.toml.bookmarks.toml"
    assert load_bookmarks(path) == []
    marks = [Bookmark('door "A"', Camera(position=[1, 2, 3], target=[0, 1, 0], fov_deg=33.3)),
             Bookmark("lens", Camera(position=[0, 0, 1e-3], target=[0, 0, -1], up=[0, 0, 1.0 / 3],
                                     aperture_radius=0.05, focus_distance=2.5))]
    save_bookmarks(path, marks, scene.name)
    loaded = load_bookmarks(path)
    assert [b.name for b in loaded] == ['door "A"', "lens"]
    for got, want in zip(loaded, marks):
        for key in ("position", "target", "up"):
            np.testing.assert_array_equal(getattr(got.camera, key), getattr(want.camera, key))  # repr: exact
        assert (got.camera.fov_deg, got.camera.aperture_radius, got.camera.focus) == \
            (want.camera.fov_deg, want.camera.aperture_radius, want.camera.focus)


def test_malformed_bookmarks_name_the_file_and_line(tmp_path):
    path = tmp_path / "s.toml.bookmarks.toml"
    path.write_text('[[bookmark]]\nname = "a"\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n\n'
                    '[[bookmark]]\nname = "b"\nposition = [0, 0]\ntarget = [0, 0, 0]\n')
    with pytest.raises(BookmarkError) as info:
        load_bookmarks(path)
    assert str(info.value).startswith(f"{path}:6: bookmark 2: position must be 3 finite numbers")
    path.write_text('[[bookmark]]\nname = "a"\nfov = = 3\n')
    with pytest.raises(BookmarkError) as info:
        load_bookmarks(path)
    assert (info.value.path, info.value.line) == (str(path), 3) and "malformed TOML" in str(info.value)


def test_unwritable_bookmarks_are_an_error_not_a_traceback(tmp_path):
    with pytest.raises(BookmarkError) as info:
        save_bookmarks(tmp_path / "missing-folder" / "x.bookmarks.toml", [], "x")
    assert "cannot write bookmarks" in str(info.value)


# ---- where the image goes in the window ----------------------------------------------------
def test_fit_rect_letterboxes_and_maps_window_points_to_pixels():
    assert fit_rect((640, 360), (1280, 720)) == (0, 0, 1280, 720)  # same aspect: fills
    assert fit_rect((512, 512), (1280, 720)) == (280, 0, 720, 720)  # square: bars left and right
    assert fit_rect((400, 100), (800, 600)) == (0, 200, 800, 200)
    rect = fit_rect((320, 200), (640, 400))
    assert window_to_pixel((0, 0), rect, (320, 200)) == (0, 0)
    assert window_to_pixel((639, 399), rect, (320, 200)) == (319, 199)
    assert window_to_pixel((3, 5), rect, (320, 200)) == (1, 2)
    assert window_to_pixel((100, 10), fit_rect((512, 512), (1280, 720)), (512, 512)) is None  # on a bar


# ---- AOV colours ----------------------------------------------------------------------------
def test_aov_colours():
    normal = np.zeros((2, 2, 3), np.float32)
    normal[0, 0] = [0, 0, 1]
    normal[0, 1] = [-1, 0, 0]
    shown = aov_to_display("normal", normal)
    assert shown[0, 0].tolist() == [128, 128, 255] and shown[0, 1].tolist() == [0, 128, 128]
    assert shown[1, 1].tolist() == [0, 0, 0]  # background

    depth = np.zeros((1, 3, 3), np.float32)
    depth[0, :, :] = np.array([0.0, 2.0, 4.0])[:, None]
    assert aov_to_display("depth", depth)[0, :, 0].tolist() == [0, 128, 255]

    albedo = np.full((1, 1, 3), 0.2, np.float32)
    expected = int(np.rint(srgb_encode(np.float32(0.2)) * 255))
    assert aov_to_display("albedo", albedo)[0, 0].tolist() == [expected] * 3
    with pytest.raises(ValueError):
        aov_to_display("no such view", albedo)
    # Views of the accumulation (docs/temporal.md): history over its largest value, the
    # rejection mask as it is.
    history = np.zeros((1, 3, 3), np.float32)
    history[0, :, :] = np.array([1.0, 5.0, 10.0])[:, None]
    assert aov_to_display("history", history)[0, :, 0].tolist() == [26, 128, 255]
    rejection = np.array([[[1.0, 0.0, 0.5]]], np.float32)
    assert aov_to_display("rejection", rejection)[0, 0].tolist() == [255, 0, 128]


# ---- the scene picker's list ----------------------------------------------------------------
def test_scene_list_has_the_shipped_scenes_and_the_lift_folder(tmp_path, monkeypatch):
    (tmp_path / "kitchen").mkdir()
    (tmp_path / "kitchen" / "scene.pbrt").write_text("WorldBegin\nWorldEnd\n")
    (tmp_path / "kitchen" / "LICENSE.txt").write_text("CC0\n")
    (tmp_path / "a.toml.bookmarks.toml").write_text("")
    monkeypatch.setenv("LIFT_GL_SCENES", str(tmp_path))
    labels = [label for label, _ in find_scenes()]
    assert "scenes/cornell.toml" in labels and "scenes/furnace.toml" in labels
    assert f"{tmp_path.name}/kitchen/scene.pbrt" in labels
    assert not any("LICENSE" in label or "bookmarks" in label for label in labels)


# ---- the convergence plot's log ticks --------------------------------------------------------
def test_log_ticks_label_short_and_long_ranges():
    from lift_gl.app.panels.convergence import log_ticks

    assert log_ticks(2.4, 99.8) == [5.0, 10.0, 20.0, 50.0]
    ticks = log_ticks(0.0022, 0.0061)  # less than a decade: 1..9 per decade
    assert ticks == pytest.approx([0.003, 0.004, 0.005, 0.006])
    assert log_ticks(0.0, 1.0) == [] and log_ticks(1e-3, 1e3)[:3] == pytest.approx([1e-3, 2e-3, 5e-3])


def test_fit_rect_places_the_image_in_the_area_beside_the_panels_at_a_whole_enlargement():
    # The area right of a 385-pixel column: same centring, offset by the area's corner.
    assert fit_rect((512, 512), (895, 720), (385, 0)) == (385 + 87, 0, 720, 720)
    # 223 x 180 render pixels in 895 x 720: 4.013x across, 4x down -> 4x both ways, a 3-pixel bar.
    assert fit_rect((223, 180), (895, 720), (385, 0)) == (385 + 1, 0, 892, 720)
    # 2.2x is not taken down to 2x: that would give up 20 render pixels' blocks of room.
    assert fit_rect((100, 100), (220, 220)) == (0, 0, 220, 220)
    # Below 1x (a large fixed render size) the image is only shrunk to fit.
    assert fit_rect((2000, 1000), (1000, 800)) == (0, 150, 1000, 500)
