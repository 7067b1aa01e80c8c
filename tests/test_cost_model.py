"""The GLSL denoiser's cost model (lift_gl/denoise/cost_model.py): its multiply-add count
against random_unet's own, and its fit recovering known coefficients."""
from __future__ import annotations

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")

from lift_gl.denoise.cost_model import CostModel, StepCost, step_costs  # noqa: E402
from lift_gl.denoise.random_unet import multiply_adds_per_pixel, random_unet  # noqa: E402


@pytest.fixture(scope="module")
def gl_ctx():
    from lift_gl.gl.context import create_context

    return create_context()


@pytest.mark.parametrize("arch", ["unet", "rt"])
def test_multiply_adds_match_the_graphs_count(gl_ctx, tmp_path, arch):
    """Channels in whole layers of 4 (nothing padded): the dispatches' multiply-adds are the
    graph's, counted by random_unet.multiply_adds_per_pixel from the ONNX weights."""
    from lift_gl.denoise.glsl_net import GlslNet

    model = random_unet(in_channels=8, out_channels=4, encoder=(8, 12, 16), bottleneck=20, arch=arch)
    onnx.save(model, tmp_path / "m.onnx")
    net = GlslNet(gl_ctx, tmp_path / "m.onnx")
    try:
        costs = step_costs(net, 64, 48)
    finally:
        net.release()
    assert sum(c.multiply_adds for c in costs) == multiply_adds_per_pixel(model) * 64 * 48
    assert all(c.bytes > 0 for c in costs)


def test_fit_recovers_coefficients_and_keeps_them_non_negative():
    rng = np.random.default_rng(0)
    costs = [StepCost("conv", str(i), float(m), float(b))
             for i, (m, b) in enumerate(zip(rng.uniform(1e8, 5e9, 20), rng.uniform(1e7, 5e8, 20)))]
    truth = CostModel(launch_ms=0.004, ms_per_gmac=0.05, ms_per_gb=0.3)
    fitted = CostModel.fit(costs, [truth.step_ms(c) for c in costs])
    np.testing.assert_allclose([fitted.launch_ms, fitted.ms_per_gmac, fitted.ms_per_gb],
                               [truth.launch_ms, truth.ms_per_gmac, truth.ms_per_gb], rtol=1e-8)
    # times that fall with the bytes: the best fit with no negative term drops that term
    falling = CostModel.fit(costs, [0.1 + 0.05 * c.multiply_adds / 1e9 - 0.01 * c.bytes / 1e9 for c in costs])
    assert falling.ms_per_gb == 0.0 and falling.ms_per_gmac > 0
