"""Temporal reprojection, host side: what moved since the last frame, and what the
G-buffer's motion vectors need (the previous camera, where each object was).

The GPU side is the G-buffer's motion vectors (shaders/passes/motion_vectors.glsl) and the
reprojection pass (passes/reproject.py); docs/temporal.md tells the whole story.

Objects moving between frames are matched by their place in the scene: mesh i of the last
frame's scene is mesh i of this one when both have the same triangles (the viewer's editor
and a camera path's `[[move]]` tables move objects without changing that), and the
difference of their corners is each corner's motion, rigid or not. A mesh without such a
counterpart gets no motion vector: its pixels find the depth of whatever was there before
and are rejected, which costs history, never correctness. Spheres likewise.
"""
from __future__ import annotations

import numpy as np

from .passes.camera import view_projection
from .scene.instances import split_instances
from .scene.model import Camera, Scene
from .scene.pack import PackedScene

MODES = ("reset", "reproject")
DEFAULT_MIN_BLEND = 0.1  # the history's weight stays <= 90%: a ghost fades by 10% a frame at least


def history_cap(min_blend: float, samples_per_frame: int) -> float:
    """The longest history (in samples) a moving frame keeps, so that the new frame's
    samples weigh at least `min_blend` in the exponential moving average."""
    if not 0.0 < min_blend <= 1.0:
        raise ValueError(f"min_blend must be in (0, 1], not {min_blend!r}")
    return samples_per_frame * (1.0 - min_blend) / min_blend


def same_camera(a: Camera | None, b: Camera | None) -> bool:
    if a is None or b is None:
        return a is b
    return (np.array_equal(a.position, b.position) and np.array_equal(a.target, b.target)
            and np.array_equal(a.up, b.up) and a.fov_deg == b.fov_deg
            and a.aperture_radius == b.aperture_radius and a.focus_distance == b.focus_distance)


def _corners(scene: Scene) -> list[np.ndarray]:
    """Each world mesh's corners, float64 (T_i, 3, 3), in pack.py's order (flattened
    instances after the scene's meshes)."""
    meshes = list(scene.meshes) + (split_instances(scene)[0] if scene.instances else [])
    return [mesh.positions[mesh.indices] for mesh in meshes]


def objects_moved(previous: Scene, scene: Scene) -> bool:
    """Whether any mesh corner or sphere centre differs between the two scenes."""
    if previous is scene:
        return False
    if len(previous.meshes) != len(scene.meshes) or len(previous.spheres) != len(scene.spheres):
        return True
    for old, new in zip(previous.meshes, scene.meshes):
        if old.positions is not new.positions and (old.indices.shape != new.indices.shape
                                                   or not np.array_equal(old.positions[old.indices],
                                                                         new.positions[new.indices])):
            return True
    if len(previous.instances) != len(scene.instances) or any(
            not np.array_equal(o.transform, n.transform) for o, n in zip(previous.instances, scene.instances)):
        return True
    return any(not np.array_equal(o.center, n.center) for o, n in zip(previous.spheres, scene.spheres))


def previous_positions(packed: PackedScene, previous: Scene | None, scene: Scene) -> np.ndarray:
    """The G-buffer's `prev_positions` rows, float32 (3T + S + 3K, 4): each packed triangle
    corner where the previous frame saw it (GPU coordinates of this frame), then each sphere's
    displacement back to the previous frame, then each instance record's object -> world
    transform in the previous frame (three rows of a 3x4 matrix; instances are matched by
    their place in Scene.instances)."""
    T, S, K = packed.num_triangles, packed.num_spheres, packed.num_instances
    rows = np.zeros((3 * T + S + 3 * K, 4), np.float32)
    if T:
        rows[:3 * T, :3] = packed.tri_pos[:T, :, :3].reshape(-1, 3)
    if K:  # each instance record's transform (object -> GPU world) in the previous frame
        records = packed.instances[packed.instance_table.record_base:].reshape(K, -1, 4)
        rows[3 * T + S:] = records[:, 0:3].reshape(-1, 4)
        if previous is not None and previous is not scene and len(previous.instances) == len(scene.instances):
            rebase = np.eye(4)
            rebase[:3, 3] = -packed.origin
            before = np.array([(rebase @ previous.instances[i].transform)[:3] for i in packed.instance_table.order])
            rows[3 * T + S:] = before.reshape(-1, 4)
    if previous is None or previous is scene:
        return rows
    now, before = _corners(scene), _corners(previous)
    deltas = [np.zeros_like(c) for c in now]
    for i, corners in enumerate(now):
        if i < len(before) and before[i].shape == corners.shape:
            deltas[i] = before[i] - corners  # float64: the motion, not two rounded positions
    W = packed.num_world_triangles  # the instances' BLAS triangles move with their transforms
    if W:
        delta = np.concatenate(deltas)[packed.tri_order]
        rows[:3 * W, :3] = (packed.tri_pos[:W, :, :3].astype(np.float64) + delta).reshape(-1, 3)
    for i, sphere in enumerate(scene.spheres):
        if i < len(previous.spheres):
            rows[3 * T + i, :3] = previous.spheres[i].center - sphere.center
    return rows


def motion_uniforms(previous_camera: Camera, camera: Camera, size, bounds) -> dict:
    """The motion vectors' uniforms; both cameras in this frame's GPU coordinates."""
    return {"u_cur_view_proj": view_projection(camera, size, bounds).ravel(),
            "u_prev_view_proj": view_projection(previous_camera, size, bounds).ravel(),
            "u_prev_cam_pos": tuple(float(v) for v in previous_camera.position),
            "u_prev_cam_forward": tuple(float(v) for v in previous_camera.basis()[2])}
