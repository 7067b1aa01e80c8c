"""Camera uniforms for the compute passes, and the matching raster projection.

Both describe the same pinhole: a pixel position (x, y) in pixels, y up, maps to the ray
forward + ndc.x * tan(fov/2) * aspect * right + ndc.y * tan(fov/2) * up with
ndc = position / resolution * 2 - 1 (shaders/lift/camera.glsl).
"""
from __future__ import annotations

import math

import numpy as np

from ..scene.model import Camera


def camera_uniforms(camera: Camera, size: tuple[int, int]) -> dict:
    right, up, forward = camera.basis()
    return {
        "u_cam_pos": tuple(camera.position), "u_cam_right": tuple(right), "u_cam_up": tuple(up),
        "u_cam_forward": tuple(forward), "u_tan_half_fov": math.tan(math.radians(camera.fov_deg) / 2),
        "u_resolution": (float(size[0]), float(size[1])), "u_lens_radius": float(camera.aperture_radius),
        "u_focus_distance": camera.focus,
    }


def near_far(camera: Camera, bounds: np.ndarray) -> tuple[float, float]:
    """Clip planes that hold the whole scene, for the G-buffer's depth test."""
    corners = np.array([[bounds[i][0], bounds[j][1], bounds[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    _, _, forward = camera.basis()
    depths = (corners - camera.position) @ forward
    far = max(float(depths.max()) * 1.01, 1e-3)
    # The G-buffer writes its own depth (depth_uniforms), so the near plane only clips: it may
    # come very close, and must never pass the nearest geometry (a floor 1e9 wide must not
    # clip the ball lying on it, as a near plane of far / 1e5 did).
    near = max(float(depths.min()) * 0.99, far * 2.0 ** -48)
    return near, far


# The G-buffer's depth test compares log2(1 + d / s) / log2(1 + far / s) of the view depth d,
# s = far / DEPTH_STEPS: linear up to s, logarithmic beyond. Its 24-bit depth buffer then
# resolves 6e-14 of far near the camera and 1e-6 of the depth from s on: surfaces 2e-5 apart
# at 8 in a room of 20 (2.5 steps; view depth / far gave 16), and a unit ball on a floor 2e10
# wide seen from 3 (steps of 6e-4; view depth / far gave 1200, larger than the ball).
DEPTH_STEPS = 2.0 ** 24


def depth_uniforms(camera: Camera, bounds: np.ndarray) -> dict:
    """The uniforms of gbuffer.frag's depth: see DEPTH_STEPS."""
    far = near_far(camera, bounds)[1]
    return {"u_inv_depth_scale": DEPTH_STEPS / far, "u_inv_log_depth_range": 1.0 / math.log2(1.0 + DEPTH_STEPS)}


def view_projection(camera: Camera, size: tuple[int, int], bounds: np.ndarray,
                    jitter=(0.5, 0.5)) -> np.ndarray:
    """Column-major 4x4 (as GLSL reads it) that rasterizes pixel x at position x + jitter."""
    width, height = size
    right, up, forward = camera.basis()
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = right, up, -forward
    view[:3, 3] = -view[:3, :3] @ camera.position
    near, far = near_far(camera, bounds)
    t = math.tan(math.radians(camera.fov_deg) / 2)
    aspect = width / height
    proj = np.zeros((4, 4))
    proj[0, 0] = 1.0 / (t * aspect)
    proj[1, 1] = 1.0 / t
    proj[2, 2] = -(far + near) / (far - near)
    proj[2, 3] = -2.0 * far * near / (far - near)
    proj[3, 2] = -1.0
    # Shift the image so that the raster's sample point (pixel centre) sees position x + jitter.
    shift = np.eye(4)
    shift[0, 3] = (0.5 - jitter[0]) * 2.0 / width
    shift[1, 3] = (0.5 - jitter[1]) * 2.0 / height
    return (shift @ proj @ view).astype(np.float32).T.copy()


def halton(index: int, base: int) -> float:
    result, f = 0.0, 1.0
    while index > 0:
        f /= base
        result += f * (index % base)
        index //= base
    return result


def frame_jitter(frame: int, seed: int) -> tuple[float, float]:
    """Subpixel offset of a frame: Halton (2, 3), rotated per seed so seeds differ."""
    rng = np.random.default_rng(seed)
    offset = rng.random(2) if seed else np.zeros(2)
    return ((halton(frame + 1, 2) + offset[0]) % 1.0, (halton(frame + 1, 3) + offset[1]) % 1.0)
