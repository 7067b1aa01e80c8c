"""Frame pairs for training a temporal denoiser: a scene seen at frame t (the camera of
random_scene, rendered as render_data renders a single-frame example) and at frame t-1 from a
camera moved a little, each with its noisy inputs at every spp level, guides and reference, and
where each pixel of frame t was in frame t-1.

The motion vectors come from the G-buffer's view depth (Renderer.aov("depth")): a pixel's
point, from frame t's camera and depth, projected through frame t-1's camera (the scenes hold
still, so the camera's motion is all the motion there is). A pixel has history where that point
was on screen and frame t-1 saw the same surface there: its view depth within DEPTH_TOLERANCE
and its normal within NORMAL_COS of what frame t-1's G-buffer holds at that pixel (the depth and
normal tests of the renderer's reprojection, lift_gl/passes/reproject.py).

A pair's file holds a single-frame example's arrays for frame t (render_data.example_arrays),
the same with the prefix prev_ for frame t-1, `source` (2, H, W: x, y of each pixel's point in
frame t-1, pixels from the top left, a pixel's centre at +0.5) and `history` (H, W: 1 where the
pixel has history).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from .render_data import F16_MAX, SPP_LEVELS, _worker_context, example_arrays, render_views, save_example, generate
from .scenes import random_scene

PREV_SEED_OFFSET = 10_000_000  # frame t-1's noise seeds: beyond every training and validation seed
CAMERA_MOVE = 0.015  # eye and target moved by this times the eye-target distance (a few pixels)
DEPTH_TOLERANCE = 0.03  # relative view depth difference that still counts as the same surface
NORMAL_COS = 0.9


def moved_camera(camera, seed: int):
    """Frame t-1's camera: eye and target each moved by a random offset of about CAMERA_MOVE of
    their distance (a pan and a small turn)."""
    rng = np.random.default_rng(PREV_SEED_OFFSET + seed)
    distance = float(np.linalg.norm(camera.target - camera.position))
    eye = camera.position + rng.normal(0, CAMERA_MOVE * distance, 3)
    target = camera.target + rng.normal(0, CAMERA_MOVE * distance, 3)
    return dataclasses.replace(camera, position=eye, target=target)


def _rays(camera, size):
    """Per pixel (row 0 at the top) the ray direction whose dot with forward is 1."""
    w, h = size
    right, up, forward = camera.basis()
    t = math.tan(math.radians(camera.fov_deg) / 2)
    x = (np.arange(w) + 0.5) / w * 2 - 1
    y = 1 - (np.arange(h) + 0.5) / h * 2  # row 0 at the top: y up is +1 there
    return forward + (x[None, :, None] * t * w / h) * right + (y[:, None, None] * t) * up


def reproject(depth: np.ndarray, camera, prev_camera, size) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(source (2, H, W) pixel position in frame t-1, its view depth there (H, W), seen (H, W):
    a surface in front of both cameras) for each pixel of frame t of view depth `depth`."""
    w, h = size
    points = camera.position + _rays(camera, size) * depth[..., None]
    right, up, forward = prev_camera.basis()
    t = math.tan(math.radians(prev_camera.fov_deg) / 2)
    q = points - prev_camera.position
    z = q @ forward
    safe_z = np.where(z > 1e-9, z, 1.0)
    x = ((q @ right) / (safe_z * t * w / h) + 1) / 2 * w
    y = (1 - (q @ up) / (safe_z * t)) / 2 * h
    seen = (depth > 0) & np.isfinite(depth) & (z > 1e-9)
    return np.stack([x, y]).astype(np.float32), z.astype(np.float32), seen


def history_mask(source, prev_depth_expected, seen, normal, prev_depth, prev_normal) -> np.ndarray:
    """1 where frame t's pixel has history in frame t-1 (see the module docstring)."""
    h, w = prev_depth.shape
    col, row = np.floor(source[0]).astype(np.int64), np.floor(source[1]).astype(np.int64)
    on_screen = seen & (col >= 0) & (col < w) & (row >= 0) & (row < h)
    c, r = np.clip(col, 0, w - 1), np.clip(row, 0, h - 1)
    found = prev_depth[r, c]
    same_depth = np.abs(found - prev_depth_expected) <= DEPTH_TOLERANCE * np.maximum(prev_depth_expected, 1e-9)
    same_normal = np.sum(normal * prev_normal[r, c], axis=-1) >= NORMAL_COS
    return (on_screen & same_depth & same_normal & (found > 0)).astype(np.float32)


def view_depth(scene, size, ctx) -> np.ndarray:
    """The G-buffer's view depth through the pixel centres (H, W), 0 on the background."""
    from ...renderer import Renderer
    r = Renderer(scene, size=size, integrator="pt", ctx=ctx)
    try:
        return r.aov("depth")[..., 0]
    finally:
        r.release()


def pair_arrays(scene, seed: int, size, ref_spp: int, ctx=None, spp_levels=SPP_LEVELS) -> dict:
    """One pair's arrays (the module docstring) of `scene`, frame t-1 from moved_camera."""
    prev_scene = dataclasses.replace(scene, camera=moved_camera(scene.camera, seed))
    frames = []
    for s, frame_seed in ((scene, seed), (prev_scene, PREV_SEED_OFFSET + seed)):
        noisy, albedo, normal, reference, _ = render_views(s, size, spp_levels, ref_spp, frame_seed, ctx)
        frames.append((example_arrays(noisy, albedo, normal, reference), normal, view_depth(s, size, ctx)))
    (current, normal, depth), (prev, prev_normal, prev_depth) = frames
    source, expected, seen = reproject(depth, scene.camera, prev_scene.camera, size)
    history = history_mask(source, expected, seen, normal, prev_depth, prev_normal)
    source = np.clip(np.nan_to_num(source, nan=-F16_MAX), -F16_MAX, F16_MAX)
    return {**current, **{f"prev_{k}": v for k, v in prev.items()}, "source": source,
            "history": history.astype(np.float16)}


def render_pair(path: Path, seed: int, size, ref_spp: int, backend: str, ctx=None, sampling: str = "independent") -> str:
    """Render scene `seed`'s pair into `path` (kept if it exists); a line for the log."""
    if sampling != "independent":
        raise ValueError("frame pairs are rendered with independent sampling")
    if path.exists():
        return f"scene {seed}: kept"
    arrays = pair_arrays(random_scene(seed), seed, size, ref_spp, ctx or _worker_context(backend))
    save_example(path, arrays)
    return f"scene {seed}: pair, {float(arrays['history'].astype(np.float32).mean()):.2f} with history"


def generate_pairs(out_dir: Path, seeds, size=(256, 256), ref_spp: int = 1024, backend: str = "auto", log=print,
                   workers: int = 1, minutes: float | None = None) -> list[Path]:
    """render_data.generate for frame pairs: out_dir/scene_SEED.npz, resumable scene by scene."""
    return generate(out_dir, seeds, size, ref_spp, backend, log, workers, minutes, render=render_pair)
