"""A cost model of the GLSL denoiser (lift_gl/denoise/glsl_net.py): each dispatch's time as

    t = launch + multiply_adds * seconds_per_multiply_add + bytes * seconds_per_byte

with the three coefficients fitted (least squares, none negative) to per-dispatch times
measured on one network (benchmarks/glsl_denoiser.py --per-dispatch, the shipped U-Net at
1920x1080), then used to predict another network's time at any size before it is trained:
    features = step_costs(net, 1920, 1080)           # one StepCost a dispatch
    model = CostModel.fit(features, measured_ms)
    model.predict_ms(step_costs(other_net, 1920, 1080))

Bytes moved are each tensor read once and written once (texel caches serve a conv's
overlapping taps) plus the conv's weights read once per work group of 8x8 invocations: the
traffic a dispatch cannot avoid. Multiply-adds count the padded channels the shaders compute
(4 a layer). A texel of the tensors (rgba32f) is 16 bytes.
"""
from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass

import numpy as np

from .onnx_graph import Step

GROUP_INVOCATIONS = 64  # shaders/denoise/tensor.glsl: 8x8 work groups


@dataclass
class StepCost:
    kind: str
    output: str
    multiply_adds: float
    bytes: float

    def as_dict(self) -> dict:
        return asdict(self)


def step_costs(net, width: int, height: int) -> list[StepCost]:
    """Each dispatch of `net` (a GlslNet) at an input of width x height: multiply-adds and bytes."""
    texel = 16  # rgba32f
    values = net.plan.values
    costs = []
    for step in net.plan.steps:
        out = values[step.output]
        out_pixels = int(width * out.scale) * int(height * out.scale)
        out_layers = -(-out.channels // 4)
        read = 0.0
        for name in net._inputs(step):
            v = values[name]
            read += int(width * v.scale) * int(height * v.scale) * -(-v.channels // 4) * texel
        macs, weights = 0.0, 0.0
        if step.kind in ("conv", "conv_transpose"):
            in_layers = sum(-(-c // 4) for c in step.params["part_channels"])
            kh, kw = step.params["weight"].shape[2:]
            taps = kh * kw if step.kind == "conv" else 1  # a transposed conv's pixel meets one tap
            macs = out_pixels * out_layers * in_layers * 16 * taps
            invocations = out_pixels / (net.pixels if step.kind == "conv" else 1)
            groups = invocations / GROUP_INVOCATIONS * -(-out_layers // net.out_block)  # x, y and z
            weights = groups * in_layers * kh * kw * net.out_block * 64  # mat4 of float32 per (layer, tap, j)
        costs.append(StepCost(step.kind, step.output, float(macs), float(read + out_pixels * out_layers * texel + weights)))
    return costs


@dataclass
class CostModel:
    launch_ms: float
    ms_per_gmac: float   # per 10^9 multiply-adds
    ms_per_gb: float     # per 10^9 bytes

    @classmethod
    def fit(cls, costs: list[StepCost], measured_ms) -> "CostModel":
        """The non-negative least-squares fit of measured per-dispatch times (ms) to the costs:
        every subset of the three terms is fitted and the best fit with no negative
        coefficient kept (three unknowns: the exhaustive active set is 7 small solves)."""
        features = np.array([[1.0, c.multiply_adds / 1e9, c.bytes / 1e9] for c in costs])
        y = np.asarray(measured_ms, np.float64)
        best, best_residual = np.zeros(3), float(np.sum(y ** 2))
        for size in (1, 2, 3):
            for subset in itertools.combinations(range(3), size):
                coef, *_ = np.linalg.lstsq(features[:, subset], y, rcond=None)
                if np.any(coef < 0):
                    continue
                residual = float(np.sum((features[:, subset] @ coef - y) ** 2))
                if residual < best_residual:
                    best, best_residual = np.zeros(3), residual
                    best[list(subset)] = coef
        return cls(*(float(c) for c in best))

    def step_ms(self, cost: StepCost) -> float:
        return self.launch_ms + self.ms_per_gmac * cost.multiply_adds / 1e9 + self.ms_per_gb * cost.bytes / 1e9

    def predict_ms(self, costs: list[StepCost]) -> float:
        return float(sum(self.step_ms(c) for c in costs))

    def as_dict(self) -> dict:
        return asdict(self)
