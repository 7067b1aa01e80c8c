"""Temporal training's data and warp (lift_gl/denoise/train/temporal_data.py, temporal.py): the
motion vectors computed from frame t's G-buffer depth carry frame t-1's G-buffer onto frame t's
(two renders the motion vectors did not see), also through the training batch's rotations and
flips; a two-frame training step runs and learns."""
from __future__ import annotations

import numpy as np
import pytest

SIZE = (48, 48)


@pytest.fixture(scope="module")
def pairs():
    from lift_gl.denoise.train.scenes import random_scene
    from lift_gl.denoise.train.temporal_data import pair_arrays
    return {seed: pair_arrays(random_scene(seed), seed, SIZE, 16, spp_levels=(1, 4)) for seed in (3, 5)}


def _sample_nearest(image, source):
    """image (C, H, W) at the source positions (2, H, W), nearest pixel; NaN off screen."""
    _, h, w = image.shape
    col, row = np.floor(source[0]).astype(int), np.floor(source[1]).astype(int)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    out = image[:, np.clip(row, 0, h - 1), np.clip(col, 0, w - 1)]
    return np.where(inside, out, np.nan)


def test_motion_vectors_carry_the_previous_gbuffer_onto_this_frame(pairs):
    """Where a pixel has history, frame t-1's albedo and normal fetched at its motion vector
    match frame t's: better than with the motion off by a pixel in any of the eight directions,
    and a small part of the error without the warp (the camera moves a few pixels; nearest
    sampling leaves only pixels on an edge different)."""
    for seed, a in pairs.items():
        cur, prev = a["guides"].astype(np.float32), a["prev_guides"].astype(np.float32)
        has = a["history"].astype(bool)
        assert 0.5 < has.mean() < 1.0, (seed, has.mean())  # most pixels, not the disoccluded or off screen
        err = lambda img: float(np.nanmean(np.abs(img - cur)[:, has]))
        moved = float(np.abs(a["source"] - (np.mgrid[0:SIZE[1], 0:SIZE[0]][::-1] + 0.5)).mean())
        assert moved > 1.0, moved  # the motion is more than the one-pixel shifts compared below
        warped = err(_sample_nearest(prev, a["source"]))
        for dx, dy in ((dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy):
            off = err(_sample_nearest(prev, a["source"] + np.array([dx, dy])[:, None, None]))
            assert warped < off, (seed, dx, dy, warped, off)
        assert warped < 0.25 * err(prev), (seed, warped, err(prev))


def test_training_batches_warp_through_their_augmentation(pairs, tmp_path):
    """In a batch of rotated and flipped crops, temporal.warp carries frame t-1's albedo guide
    onto frame t's where the batch says it is valid, as well as the unaugmented warp does."""
    torch = pytest.importorskip("torch")
    from lift_gl.denoise.train.temporal import PairExamples, warp
    paths = []
    for seed, a in pairs.items():
        paths.append(tmp_path / f"scene_{seed}.npz")
        np.savez(paths[-1], **a)
    examples = PairExamples(paths, "cpu")
    b = examples.pair_batch(torch.Generator().manual_seed(0), 8, 32, history_drop=0.0)
    assert {k for k, _ in b["aug"]} != {0}  # the rotations were drawn
    albedo_prev, albedo = b["x_prev"][:, 3:6], b["x"][:, 3:6]
    warped = warp(albedo_prev, b["grid"], b["aug"])
    valid = b["valid"].expand_as(albedo).bool()
    assert valid.float().mean() > 0.5
    err = float((warped - albedo).abs()[valid].mean())
    err_unwarped = float((albedo_prev - albedo).abs()[valid].mean())
    assert err < 0.35 * err_unwarped, (err, err_unwarped)  # bilinear taps across edges: above nearest's
    dropped = examples.pair_batch(torch.Generator().manual_seed(0), 8, 32, history_drop=1.0)
    assert float(dropped["valid"].abs().sum()) == 0.0


def test_a_temporal_training_step_runs_and_learns(pairs, tmp_path):
    """fit on frame pairs with the real-time temporal model: the loss of a fixed batch falls."""
    torch = pytest.importorskip("torch")
    from lift_gl.denoise.train.model import build_model
    from lift_gl.denoise.train.temporal import PairExamples, temporal_step
    from lift_gl.denoise.train.train import Stage, fit
    paths = []
    for seed, a in pairs.items():
        paths.append(tmp_path / f"scene_{seed}.npz")
        np.savez(paths[-1], **a)
    examples = PairExamples(paths, "cpu")
    torch.manual_seed(0)
    model = build_model("rt", temporal=True)
    amp = torch.autocast("cpu", enabled=False)
    stage = Stage(30, 2e-3, mean_weight=1.0)
    loss_at = lambda: float(temporal_step(model, examples, torch.Generator().manual_seed(5), 4, 32, stage, amp,
                                          "log", 0.25))
    before = loss_at()
    result = fit(model, examples, examples, [stage], tmp_path / "ckpt.pt", batch=4, crop=32, log=lambda m: None)
    assert result["steps"] == 30
    assert loss_at() < before
