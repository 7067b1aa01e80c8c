"""The training loss's mean term (lift_gl/denoise/train/loss.py mean_loss) against statistics
known in closed form: over targets with heavy-tailed pixels, the best constant output under the
log-domain L1 loss is the pixels' median, and under the mean term the pixels' mean."""
from __future__ import annotations

import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lift_gl.denoise.train.loss import MEAN_EPS, denoise_loss, mean_loss  # noqa: E402

SIGMA = 1.0  # lognormal pixels: median 1, mean e^(sigma^2 / 2) = 1.649
MEAN = math.exp(SIGMA ** 2 / 2)


def _targets(n=64, size=32, seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.exp(SIGMA * torch.randn(n, 3, size, size, generator=g, dtype=torch.float64))


def _best_constant(loss_of, targets, grid) -> float:
    losses = [float(loss_of(torch.full_like(targets, float(c)), targets)) for c in grid]
    return float(grid[int(np.argmin(losses))])


def test_mean_loss_of_a_scaled_target_is_the_squared_relative_error():
    """pred = c x target, noisy = target: each block's error (c - 1) T over a scale of
    max(T, c T) + eps, squared, where T is the block's mean."""
    t = _targets(n=2, size=32)
    for c in (0.5, 1.0, 1.3):
        expected = []
        for b in (8, 16):
            tb = torch.nn.functional.avg_pool2d(t, b)
            expected.append(float(((((c - 1) * tb) / (torch.maximum(tb, c * tb) + MEAN_EPS)) ** 2).mean()))
        assert float(mean_loss(c * t, t, t)) == pytest.approx(np.mean(expected), rel=1e-9, abs=1e-15)


def test_l1_keeps_the_median_and_the_mean_term_keeps_the_mean():
    """The best constant output c over lognormal targets. Under the log-domain L1 (SSIM off; the
    gradient term is the same for every constant) the best on a grid of 0.5 % steps is the
    median 1: the sample median of 196,608 pixels has a standard error of sqrt(pi/2) / sqrt(n)
    = 0.3 %, so 2 % holds it with the grid. Under the mean term, descending its gradient (the
    scale detached, as in training) from the median, c settles at the mean e^0.5: the noisy
    input that sets the scale is an independent draw, so the weights do not depend on the
    target and the fixed point is a weighted mean of the block means. Its standard error,
    computed here from the weights and the block means' spread, is held within 5 of them."""
    t = _targets()
    grid = np.arange(0.6, 2.4, 0.005)
    median = _best_constant(lambda p, tt: denoise_loss(p, tt, ssim_weight=0.0), t, grid)
    assert median == pytest.approx(1.0, abs=0.02), median

    noisy = _targets(seed=1)
    c = torch.tensor(1.0, dtype=torch.float64, requires_grad=True)
    opt = torch.optim.SGD([c], lr=0.5)
    for _ in range(300):
        opt.zero_grad()
        mean_loss(c * torch.ones_like(t), t, noisy).backward()
        opt.step()
    blocks = [torch.nn.functional.avg_pool2d(t, b).flatten() for b in (8, 16)]
    scales = [torch.maximum(torch.nn.functional.avg_pool2d(noisy, b).flatten(), c.detach()) + MEAN_EPS
              for b in (8, 16)]
    weights = [1 / s ** 2 / len(s) for s in scales]  # each block size's term is a mean over its blocks
    w, tb = torch.cat(weights), torch.cat(blocks)
    fixed_point = float((w * tb).sum() / w.sum())
    spread = torch.cat([x.std() * torch.ones_like(x) for x in blocks])
    standard_error = float(torch.sqrt((w ** 2 * spread ** 2).sum()) / w.sum())
    assert float(c) == pytest.approx(fixed_point, rel=1e-3)  # the descent converged
    assert abs(float(c) - MEAN) < 5 * standard_error, (float(c), MEAN, standard_error)
    assert float(c) / median > 1.5  # the gap the term closes: the mean is 65 % above the median


def test_mean_ratios_whole_and_per_channel():
    """A model that scales the colour by (2, 1, 0.5) against a reference equal to its input: the
    per-channel ratios are those factors, the whole-image ratio their mean weighted by the
    reference's channel means."""
    from lift_gl.denoise.train.train import mean_ratios

    class Scale(torch.nn.Module):
        in_channels = 9

        def forward(self, x):
            return x[:, :3] * torch.tensor([2.0, 1.0, 0.5])[None, :, None, None]

    class Val:  # what mean_ratios reads of train.Examples
        gen = torch.Generator().manual_seed(3)
        noisy = torch.rand(2, 3, 3, 8, 8, generator=gen)  # scene, spp level, channel, y, x
        exposure = torch.full((2, 3), 0.5)
        guides = torch.rand(2, 6, 8, 8, generator=gen)
        divisor = torch.rand(2, 3, 8, 8, generator=gen) + 0.5
        target = noisy[:, 2].clone()

        def __len__(self):
            return 2

    val = Val()
    per_channel = np.array(mean_ratios(Scale(), val, level=2, per_channel=True))
    np.testing.assert_allclose(per_channel, [[2.0, 1.0, 0.5]] * 2, rtol=1e-6)
    whole = np.array(mean_ratios(Scale(), val, level=2))
    ref_means = (val.target * val.divisor).mean(dim=(2, 3)).numpy()
    np.testing.assert_allclose(whole, (per_channel * ref_means).sum(1) / ref_means.sum(1), rtol=1e-6)
