"""Ambient occlusion (ao, and its OpenCL twin ao_cl) against analytic values.

AO(p) = 1/pi * integral of V(p, w) cos(theta) dw, with V = 0 where something lies within
the radius. Under cosine-weighted sampling cos^2(theta) is uniform on [0, 1] (Malley: the
projected disk point is uniform), so for a point on a floor under a parallel ceiling at
height h, a direction reaches the ceiling within r exactly when h / cos(theta) < r:

    AO = P(cos(theta) < h / r) = (h / r)^2  for r > h,   and 1 for r <= h.

Each sample is exactly 0 or 1, so a configuration without occluders in reach is exact; the
others are tested within 4 standard errors of the pixel mean (pixels are independent).
"""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Mesh, Scene
from lift_gl.testing import assert_mean_is, require_opencl

SIZE = (32, 32)
SPP = 16
HALF = 10.0  # planes are 20 x 20; the camera sees points within 0.71 of the centre
PLUGINS = ["ao", "ao_cl"]


def renderer(scene, plugin, **kwargs) -> Renderer:
    if plugin.endswith("_cl"):
        require_opencl()
    return Renderer(scene, size=SIZE, integrator=plugin, **kwargs)


def plane(y: float, facing: float) -> Mesh:
    """A square in y = const, facing +y (facing = 1) or -y (facing = -1)."""
    corners = np.array([[-HALF, y, -HALF], [HALF, y, -HALF], [HALF, y, HALF], [-HALF, y, HALF]])
    triangles = [[0, 2, 1], [0, 3, 2]] if facing > 0 else [[0, 1, 2], [0, 2, 3]]
    return Mesh("plane", corners, triangles, material=0)


def planes_scene(ceiling_height: float | None) -> Scene:
    """A floor at y = 0, seen from above with a 90 degree view, and optionally a ceiling."""
    meshes = [plane(0.0, +1)]
    height = 0.5 if ceiling_height is None else ceiling_height / 2  # the camera floats between
    if ceiling_height is not None:
        meshes.append(plane(ceiling_height, -1))
    camera = Camera(position=[0.0, height, 0.0], target=[0.0, 0.0, 0.0], up=[0.0, 0.0, -1.0], fov_deg=90.0)
    return Scene(camera=camera, materials=[Material("grey")], meshes=meshes, film_size=SIZE)


@pytest.mark.parametrize("plugin", PLUGINS)
def test_a_plane_alone_is_unoccluded(plugin):
    r = renderer(planes_scene(None), plugin, seed=1, params={"radius": 0.0})
    image = r.render(spp=SPP)
    assert r.stats.dropped_samples == 0
    assert np.all(image == 1.0)  # every sample escapes: exactly 1, no noise
    r.release()


@pytest.mark.parametrize("plugin", PLUGINS)
def test_under_a_parallel_plane_ao_is_h_over_r_squared(plugin):
    h = 1.0
    r = renderer(planes_scene(h), plugin, seed=2)
    for radius in (0.9, 1.25, 2.0, 4.0):
        r.set_params(radius=radius)  # restarts accumulation: only this radius is in the image
        image = r.render(spp=SPP)
        assert r.stats.dropped_samples == 0 and r.stats.spp == SPP
        if radius <= h:
            assert np.all(image == 1.0), radius
        else:
            assert_mean_is(image[..., 0], (h / radius) ** 2, sigmas=4.0)
            assert np.all(image[..., 0] == image[..., 2])  # grey: one visibility per sample
    r.release()


def test_background_is_black_and_radius_bounds_are_enforced():
    scene = planes_scene(None)
    scene.camera = Camera(position=[0.0, 0.5, 0.0], target=[0.0, 1.0, 0.0], up=[0.0, 0.0, -1.0], fov_deg=60.0)
    r = Renderer(scene, size=(8, 8), integrator="ao")
    assert np.all(r.render(spp=2) == 0.0)  # looking up at nothing
    from lift_gl.errors import PluginError

    with pytest.raises(PluginError):
        r.set_params(radius=-1.0)
    r.release()
