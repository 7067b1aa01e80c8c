"""The accumulation keeps the exact mean over very many frames in float32."""
from __future__ import annotations

import numpy as np

from lift_gl.gl.context import create_context
from lift_gl.passes.accumulate import AccumulatePass


def test_compensated_sum_keeps_the_mean_after_a_million_frames():
    ctx = create_context()
    size = (4, 2)
    acc = AccumulatePass(ctx, size)
    frames_before = 1_000_000
    value_before = np.float32(0.1)
    # The state after 10^6 frames of radiance 0.1 (one sample each): the float32 sum holds
    # 1e5 and an ulp of 1e5 is 0.0078, so a plain float32 sum would lose most of each 0.1.
    total = frames_before * 0.1
    state = np.zeros((size[1], size[0], 4), np.float32)
    state[..., :3] = np.float32(total)
    state[..., 3] = frames_before
    comp = np.zeros_like(state)
    comp[..., :3] = total - np.float64(np.float32(total))
    acc.sum.write(state.tobytes())
    acc.compensation.write(comp.tobytes())

    frame = ctx.texture(size, 4, dtype="f4")
    # 1000 more frames whose radiance spans 12 orders of magnitude across pixels.
    values = np.array([1e-6, 1e-3, 0.1, 0.37, 1.0, 10.0, 1e3, 1e6], np.float32).reshape(size[1], size[0])
    data = np.zeros((size[1], size[0], 4), np.float32)
    data[..., 0] = values
    data[..., 1] = 0.1
    data[..., 2] = np.float32(1.0 / 3.0)
    data[..., 3] = 1.0
    frame.write(data.tobytes())
    extra = 3000
    for _ in range(extra):
        acc.run(frame)
    totals = acc.read_totals()
    n = frames_before + extra
    exact_r = (total + extra * values.astype(np.float64)) / n
    mean = totals[..., :3] / totals[..., 3:4]
    assert np.all(totals[..., 3] == n)
    np.testing.assert_allclose(mean[..., 0], exact_r, rtol=1e-6)
    ours = np.abs(mean[..., 1] / 0.1 - 1).max()
    assert ours < 1e-6
    exact_b = (total + extra * np.float64(np.float32(1 / 3))) / n
    np.testing.assert_allclose(mean[..., 2], exact_b, rtol=1e-6)
    # The same frames added with plain float32 arithmetic drift far from it: the test can fail.
    naive = np.float32(total)
    for _ in range(extra):
        naive = np.float32(naive + np.float32(0.1))
    naive_error = abs(naive / n - 0.1) / 0.1
    assert naive_error > 20 * ours and naive_error > 2e-5


def test_high_dynamic_range_in_one_image():
    ctx = create_context()
    size = (8, 1)
    acc = AccumulatePass(ctx, size)
    frame = ctx.texture(size, 4, dtype="f4")
    values = np.logspace(-6, 6, 8).astype(np.float32)
    data = np.zeros((1, 8, 4), np.float32)
    data[..., :3] = values[None, :, None]
    data[..., 3] = 1.0
    frame.write(data.tobytes())
    for _ in range(100):
        acc.run(frame)
    mean = acc.read_mean()
    np.testing.assert_allclose(mean[0, :, 0], values, rtol=1e-6)
