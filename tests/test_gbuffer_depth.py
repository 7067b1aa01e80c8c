"""The G-buffer's depth test separates surfaces millimetres apart even when the camera is
inside the scene (a near plane of far / 100000): thin double-sided shells in imported scenes
(lamp shades, chairs) showed their inner side through z-fighting before."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene, Sphere
from lift_gl.scene import primitives as prim


@pytest.mark.parametrize("gap", [2e-3, 2e-5])
def test_nearly_coincident_surfaces_keep_their_order(gap):
    materials = [Material("front", base_color=[1, 0, 0]), Material("back", base_color=[0, 1, 0]),
                 Material("room"), Material("ball", base_color=[0, 0, 1])]
    # The room around the camera puts the near plane at far * 1e-5.
    meshes = [prim.box([0, 0, 0], [40, 40, 40], material=2),
              prim.quad_centered([0, 0, -8 - gap], [4, 0, 0], [0, 4, 0], material=1),
              prim.quad_centered([0, 0, -8], [4, 0, 0], [0, 4, 0], material=0)]
    # A sphere just in front of the quads, over the image's right half: spheres and
    # triangles share the same depth convention.
    spheres = [Sphere([0.6, 0.0, -7.0 + gap - 0.6], 0.6, 3)]
    scene = Scene(camera=Camera(position=[0, 0, 0], target=[0, 0, -1], fov_deg=20),
                  materials=materials, meshes=meshes, spheres=spheres)
    r = Renderer(scene, size=(48, 48))
    albedo = r.aov("albedo")
    r.release()
    blue = albedo[..., 2] > 0.5
    assert 100 < blue.sum() < 1000  # the sphere covers part of the view
    assert (albedo[~blue, 0] > 0.99).all() and (albedo[~blue, 1] == 0).all(), "the back quad showed through"
