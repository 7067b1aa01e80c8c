"""Shared fixtures: the ../shared data folder (skipped where absent) and small scenes."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared"


@pytest.fixture
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent (the course's shared data folder; CI has it)")
    return SHARED


@pytest.fixture
def as_if_gpu(monkeypatch):
    """Renderers made in the test resolve their options as on a GPU (lift_gl/options.py
    Device.of), whatever GL runs them: the GPUs' choices (shared stacks, the pixel queue, ...)
    render on llvmpipe too."""
    from lift_gl.options import Device

    monkeypatch.setattr(Device, "of", classmethod(lambda cls, ctx: cls(software=False, renderer="a GPU (emulated)")))


def skip_without_shared(scene_path) -> None:
    """Skip a test of a shipped scene whose files lie in ../shared where that folder is absent
    (a user's own clone); CI has it."""
    if not SHARED.is_dir() and "../../shared/" in Path(scene_path).read_text(encoding="utf-8"):
        pytest.skip(f"{SHARED} is absent ({Path(scene_path).name} reads its files from there; CI has it)")


def furnace_scene(material, radiance=1.0, size=(48, 48)):
    """A unit sphere of one material in a constant environment, filling most of the view."""
    from lift_gl.scene import Camera, Environment, Scene, Sphere

    camera = Camera(position=[0.0, 0.0, 3.0], target=[0.0, 0.0, 0.0], fov_deg=45.0)
    return Scene(camera=camera, materials=[material], spheres=[Sphere(center=[0, 0, 0], radius=1.0, material=0)],
                 environment=Environment(radiance=[radiance] * 3), film_size=size)


def sphere_pixel_cosines(scene, size, subpixels=4):
    """For every pixel, cos(theta_o) at the sphere for a grid of subpixel rays (NaN: a miss).

    Returns (H, W, subpixels**2), row 0 = top, computed in numpy from the camera alone.
    """
    normals, dirs = sphere_pixel_normals(scene, size, subpixels)
    return -(normals * dirs).sum(-1)


def sphere_pixel_normals(scene, size, subpixels=4):
    """The sphere's normals (NaN: a miss) and the ray directions for a grid of subpixel rays:
    two (H, W, subpixels**2, 3) arrays, row 0 = top, from the camera alone."""
    cam = scene.camera
    right, up, forward = cam.basis()
    w, h = size
    t = np.tan(np.radians(cam.fov_deg) / 2)
    offsets = (np.arange(subpixels) + 0.5) / subpixels
    xs = (np.arange(w)[:, None] + offsets[None, :]).ravel()
    ys = (np.arange(h)[:, None] + offsets[None, :]).ravel()
    ndc_x = xs / w * 2 - 1
    ndc_y = ys / h * 2 - 1
    d = (forward[None, None] + ndc_x[None, :, None] * t * (w / h) * right[None, None]
         + ndc_y[:, None, None] * t * up[None, None])
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    sphere = scene.spheres[0]
    oc = cam.position - sphere.center
    b = d @ oc
    c = oc @ oc - sphere.radius ** 2
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        t_hit = -b - np.sqrt(disc)
        p = cam.position + t_hit[..., None] * d
        n = np.where((disc > 0)[..., None], (p - sphere.center) / sphere.radius, np.nan)

    def per_pixel(a):
        return a.reshape(h, subpixels, w, subpixels, 3).transpose(0, 2, 1, 3, 4).reshape(h, w, subpixels ** 2, 3)[::-1]
    return per_pixel(n), per_pixel(d)
