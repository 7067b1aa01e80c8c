"""The BVH traversal stack in shared memory (what GPUs run: lift_gl/passes/trace.py,
shaders/lift/bvh.glsl) gives the images of the local-array stack (what CPU rasterizers run),
with 8x4 work groups instead of 8x8."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LiftError
from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene


def _render(stack, scene, integrator, spp):
    r = Renderer(scene, size=(40, 32), integrator=integrator, seed=5, options=Options(bvh_stack=stack))
    try:
        shared = "#define LIFT_BVH_SHARED_STACK" in r.trace.source.text
        return r.render(spp=spp), shared, r.trace.local_size
    finally:
        r.release()


@pytest.mark.parametrize("scene_name, integrator", [
    ("cornell.toml", "pt"),          # closest hits and shadow rays
    ("showcase.toml", "pt"),         # spheres beside the triangles, textures
    ("cornell.toml", "drt"),         # camera rays: every primary hit traced
    ("motion_blur.toml", "drt"),     # moving boxes: the motion-blended node boxes
    ("cornell.toml", "bdpt"),        # light subpaths and splats
])
def test_shared_stack_renders_the_same_image(scene_name, integrator):
    scene = load_scene(REPO / "scenes" / scene_name)
    local, shared_a, shape_a = _render("local", scene, integrator, 4)
    shared, shared_b, shape_b = _render("shared", scene, integrator, 4)
    assert (shared_a, shape_a) == (False, (8, 8)) and (shared_b, shape_b) == (True, (8, 4))
    assert np.isfinite(local).all() and local.max() > 0
    if integrator == "bdpt":
        # splats are added by float atomics, in an order that the work-group shape changes
        np.testing.assert_allclose(shared, local, rtol=1e-5, atol=1e-6)
    else:
        np.testing.assert_array_equal(shared, local)


def test_bad_stack_setting_is_refused():
    with pytest.raises(LiftError, match="option bvh_stack: 'registers' is not allowed; use shared, local, auto"):
        Options(bvh_stack="registers")


