"""The viewer's camera navigation (lift_gl/app/camera_controller.py) against closed-form poses."""
from __future__ import annotations

import math

import numpy as np
import pytest

from lift_gl.app.camera_controller import CameraController
from lift_gl.scene import Camera


def _angle_deg(a, b) -> float:
    a, b = np.asarray(a) / np.linalg.norm(a), np.asarray(b) / np.linalg.norm(b)
    return math.degrees(math.acos(np.clip(a @ b, -1.0, 1.0)))


@pytest.mark.parametrize("camera", [
    Camera(position=[0, 1, 6.8], target=[0, 1, 0], fov_deg=19.5),  # y up (the Cornell box)
    Camera(position=[3, -4, 2], target=[0, 0, 0.5], up=[0, 0, 1], fov_deg=55, aperture_radius=0.1,
           focus_distance=4.0),  # z up, a thin lens
])
def test_controller_reproduces_the_camera_it_starts_from(camera):
    out = CameraController(camera, scene_size=3.0).camera()
    np.testing.assert_allclose(out.position, camera.position, atol=1e-12)
    for got, want in zip(out.basis(), camera.basis()):
        np.testing.assert_allclose(got, want, atol=1e-12)
    assert out.fov_deg == camera.fov_deg
    assert out.aperture_radius == camera.aperture_radius
    assert out.focus == pytest.approx(camera.focus)


def test_fly_keys_move_along_the_camera_axes_at_the_set_speed():
    c = CameraController(Camera(position=[0, 0, 5], target=[0, 0, 0]), scene_size=4.0)
    c.settings.speed = 2.0
    assert c.move(["w"], dt=0.5)
    np.testing.assert_allclose(c.position, [0, 0, 4])  # forward is -z: 2 units/s for 0.5 s
    c.move(["d"], dt=0.25)
    np.testing.assert_allclose(c.position, [0.5, 0, 4])  # right is +x
    c.move(["e"], dt=1.0, boost=4.0)
    np.testing.assert_allclose(c.position, [0.5, 8, 4])  # up, 4x
    assert not c.move(["w", "s"], dt=1.0)  # opposite keys cancel
    assert not c.move(["x"], dt=1.0)


def test_mouse_look_turns_by_sensitivity_times_pixels():
    c = CameraController(Camera(position=[0, 0, 0], target=[0, 0, -1]), scene_size=1.0)
    c.settings.sensitivity = 0.25  # degrees per pixel
    right_before = c.basis()[0]
    c.look(80, 0)  # 20 degrees to the right
    assert _angle_deg(c.forward, [0, 0, -1]) == pytest.approx(20.0)
    assert c.forward @ right_before > 0  # turned towards the right
    c.look(0, 40)  # 10 degrees down (window y grows downwards)
    assert c.forward[1] == pytest.approx(-math.sin(math.radians(10)))


def test_pitch_stops_short_of_the_up_axis():
    c = CameraController(Camera(position=[0, 0, 0], target=[0, 0, -1]), scene_size=1.0)
    for _ in range(50):
        c.look(0, -100)  # keep looking up
    angle = _angle_deg(c.forward, c.world_up)
    assert 0.99 < angle < 30  # close to straight up, never past it (the basis stays defined)
    assert np.isfinite(c.camera().basis()[0]).all()


def test_orbit_turns_about_the_pivot_at_a_fixed_distance():
    c = CameraController(Camera(position=[0, 1, 5], target=[0, 1, 0]), scene_size=2.0)
    c.mode = "orbit"
    c.settings.sensitivity = 0.5
    c.look(180, 0)  # 90 degrees about the pivot
    np.testing.assert_allclose(c.pivot, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(c.position, [-5, 1, 0], atol=1e-12)  # dragging right orbits to the left
    c.scroll(1.0)  # zoom in by 10 %
    assert np.linalg.norm(c.position - c.pivot) == pytest.approx(4.5)
    np.testing.assert_allclose(c.pivot, [0, 1, 0], atol=1e-12)


def test_fly_scroll_changes_speed_not_the_view():
    c = CameraController(Camera(position=[0, 0, 5], target=[0, 0, 0]), scene_size=4.0)
    speed, position = c.settings.speed, c.position.copy()
    assert speed == pytest.approx(1.0)  # a quarter of the scene's size per second
    assert not c.scroll(2.0)
    assert c.settings.speed == pytest.approx(speed / 0.81)
    np.testing.assert_array_equal(c.position, position)


def test_set_camera_keeps_speed_and_sensitivity():
    c = CameraController(Camera(position=[0, 0, 5], target=[0, 0, 0]), scene_size=4.0)
    c.settings.speed, c.settings.sensitivity = 7.0, 0.5
    c.set_camera(Camera(position=[1, 2, 3], target=[1, 2, 0], fov_deg=30))
    assert (c.settings.speed, c.settings.sensitivity, c.settings.fov_deg) == (7.0, 0.5, 30.0)
