"""Camera navigation for the viewer: fly (WASD/QE + mouse look) and orbit, in plain numpy.

The controller holds a position, a unit forward vector and the scene's up axis, and turns
them into a `Camera` (lift_gl/scene/model.py) whenever something changed. It knows nothing of
windows or GL, so its maths is tested without a display.

Conventions: mouse deltas are in window pixels with y pointing down (as moderngl-window
reports them); angles in degrees; lengths in scene units; speed in scene units per second.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.model import Camera

MODES = ("fly", "orbit")
MIN_ANGLE_TO_UP = math.radians(1.0)  # looking straight up or down would make the basis singular

# Fly keys: name -> (right, up, forward) direction of motion in the camera's frame.
MOVE_KEYS = {"w": (0, 0, 1), "s": (0, 0, -1), "a": (-1, 0, 0), "d": (1, 0, 0), "q": (0, -1, 0), "e": (0, 1, 0)}


def rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of v about the unit axis by angle (radians, right-handed)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


@dataclass
class CameraSettings:
    """What the settings panel edits besides the pose."""

    speed: float = 1.0  # scene units per second
    sensitivity: float = 0.2  # degrees per pixel of mouse motion
    fov_deg: float = 40.0  # vertical
    aperture_radius: float = 0.0  # thin lens; 0 = pinhole
    focus_distance: float = 1.0  # along the view direction


class CameraController:
    def __init__(self, camera: Camera, scene_size: float = 1.0):
        """`scene_size` (the diagonal of the scene's bounds) sets the default speed."""
        self.scene_size = max(float(scene_size), 1e-6)
        self.mode = "fly"
        self.set_camera(camera)
        self.settings.speed = 0.25 * self.scene_size  # crosses the scene in about 4 s

    def set_camera(self, camera: Camera) -> None:
        """Jump to a camera (the scene's, or a bookmark); speed and sensitivity stay."""
        keep = getattr(self, "settings", None)
        self.position = np.array(camera.position, dtype=np.float64)
        self.forward = _unit(camera.target - camera.position)
        self.world_up = _unit(camera.up)
        # The orbit pivot: the target, at the distance the camera had from it.
        self.distance = float(np.linalg.norm(camera.target - camera.position))
        self.settings = CameraSettings(
            speed=keep.speed if keep else 1.0, sensitivity=keep.sensitivity if keep else 0.2,
            fov_deg=float(camera.fov_deg), aperture_radius=float(camera.aperture_radius),
            focus_distance=float(camera.focus))

    # ---- the camera this describes ----
    @property
    def pivot(self) -> np.ndarray:
        return self.position + self.forward * self.distance

    def camera(self) -> Camera:
        s = self.settings
        return Camera(position=self.position.copy(), target=self.pivot, up=self.world_up.copy(),
                      fov_deg=float(s.fov_deg), aperture_radius=float(s.aperture_radius),
                      focus_distance=float(s.focus_distance))

    def basis(self):
        right = _unit(np.cross(self.forward, self.world_up))
        return right, np.cross(right, self.forward), self.forward

    # ---- input ----
    def move(self, keys, dt: float, boost: float = 1.0) -> bool:
        """Fly along the camera's axes for held keys ('w', 'a', ... from MOVE_KEYS); True if moved.

        In orbit mode W/S dolly towards and away from the pivot, and A/D/Q/E move the pivot too.
        """
        direction = np.zeros(3)
        for key in keys:
            direction += MOVE_KEYS.get(key, (0, 0, 0))
        if not direction.any() or dt <= 0:
            return False
        right, up, forward = self.basis()
        step = self.settings.speed * boost * dt
        if self.mode == "orbit" and direction[2] and not direction[:2].any():
            self._dolly(step * direction[2])
            return True
        self.position = self.position + step * (direction[0] * right + direction[1] * up + direction[2] * forward)
        return True

    def look(self, dx: float, dy: float) -> bool:
        """Mouse motion: fly mode turns the view; orbit mode turns the camera about the pivot."""
        if dx == 0 and dy == 0:
            return False
        pivot = self.pivot
        sens = math.radians(self.settings.sensitivity)
        # Dragging right turns the view right (a negative turn about up); dragging down looks down.
        forward = rotate(self.forward, self.world_up, -dx * sens)
        right = _unit(np.cross(forward, self.world_up))
        pitched = rotate(forward, right, -dy * sens)
        angle_to_up = math.acos(max(-1.0, min(1.0, float(pitched @ self.world_up))))
        if MIN_ANGLE_TO_UP < angle_to_up < math.pi - MIN_ANGLE_TO_UP:
            forward = pitched
        self.forward = _unit(forward)
        if self.mode == "orbit":
            self.position = pivot - self.forward * self.distance
        return True

    def scroll(self, amount: float) -> bool:
        """Mouse wheel: orbit mode zooms towards the pivot; fly mode changes the speed."""
        if amount == 0:
            return False
        factor = 0.9 ** amount
        if self.mode == "orbit":
            self._dolly(self.distance * (1.0 - factor))
            return True
        self.settings.speed = float(np.clip(self.settings.speed / factor, 1e-4 * self.scene_size,
                                            1e2 * self.scene_size))
        return False  # the view did not change

    def _dolly(self, step: float) -> None:
        """Move along forward keeping the pivot; never through it."""
        new_distance = max(self.distance - step, 1e-3 * self.scene_size)
        self.position = self.pivot - self.forward * new_distance
        self.distance = new_distance
