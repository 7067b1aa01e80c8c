"""The GPU tonemap pass agrees with the numpy reference (lift_gl/tonemap.py) to 1/255."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.gl.context import create_context
from lift_gl.passes.accumulate import AccumulatePass
from lift_gl.passes.tonemap import TonemapPass
from lift_gl.tonemap import to_srgb8


@pytest.mark.parametrize("operator", ["aces", "reinhard", "clamp"])
@pytest.mark.parametrize("exposure", [0.0, -2.0, 1.5])
@pytest.mark.parametrize("gamma", [None, 2.2, 1.0])
def test_gpu_tonemap_matches_numpy(operator, exposure, gamma):
    ctx = create_context()
    size = (16, 8)
    rng = np.random.default_rng(3)
    linear = (10.0 ** rng.uniform(-5, 4, size=(size[1], size[0], 3))).astype(np.float32)
    linear[0, 0] = [0.0, -1.0, np.nan]  # sanitised to 0
    linear[0, 1] = [np.inf, 1e30, 0.5]
    acc = AccumulatePass(ctx, size)
    totals = np.zeros((size[1], size[0], 4), np.float32)
    totals[..., :3] = linear[::-1] * 2.0  # two samples' worth, GL rows bottom-up
    totals[..., 3] = 2.0
    acc.sum.write(totals.tobytes())
    tonemap = TonemapPass(ctx, size)
    tonemap.run(acc, exposure, operator, gamma)
    gpu = tonemap.read().astype(int)
    cpu = to_srgb8(linear, exposure=exposure, operator=operator, gamma=gamma).astype(int)
    assert np.abs(gpu - cpu).max() <= 1
