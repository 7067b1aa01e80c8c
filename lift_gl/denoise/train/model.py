"""The denoiser's network: a small U-Net in the manner of OIDN's (encoder and decoder with
skip connections, 3x3 convolutions and ReLU, 2x2 max pooling, nearest upsampling, HDR colour
through a log curve), narrow at full resolution so that a 1080p frame stays cheap on a CPU.

Colour transform (`transform`, inside the graph, inverted on the output):
- "log": t(x) = log(1 + x/eps) / log(1 + 1/eps) with eps = LOG_EPS, the loss's steep curve
  (0 at 0, 1 at 1, slope 22 at 0): dark regions (exposed radiance 0.005-0.05) get as much of
  the input's and the output's range as bright ones. The output y is mapped back by
  eps * exp(y), so that an error in y is a relative error of the radiance, and no output has
  a zero gradient (an earlier relu(eps * (exp(y) - 1)) let a wider network die at the start
  of training: every y below 0, so every output 0 with no gradient).
- "log1p": log(1 + x) in, exp(y) - 1 out, the first shipped model's: almost linear below
  0.2, so that a small offset in y is an additive haze in the dark.

Multiples: H and W must be multiples of MULTIPLE (four poolings); the onnx denoiser pads.
RECEPTIVE_RADIUS bounds how far a pixel's output looks, so tiles overlapping by that much
give the untiled result.
"""
from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

ENCODER = (32, 48, 64, 80)  # channels at 1, 1/2, 1/4, 1/8 resolution (the first model: 16, 32, 48, 64)
BOTTLENECK = 80  # at 1/16
TRANSFORM = "log"
TRANSFORMS = ("log", "log1p")
LOG_EPS = 0.01  # the "log" transform's toe, as the loss's (loss.DARK_EPS)
MULTIPLE = 16
# An impulse moves outputs up to 64 px away (measured), up to 79 px for a pixel at the far end
# of a 16-px pooling block; rounded up to a multiple of MULTIPLE. An extra full-resolution conv
# each side adds 2 px: still within.
RECEPTIVE_RADIUS = 96
IN_CHANNELS = 9
LOG_CLAMP = 25.0  # output log value cap: eps * exp(25) ~ 7e8, far above any exposed radiance


def conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, padding=1)


class DenoiseUNet(nn.Module):
    def __init__(self, encoder=ENCODER, bottleneck=BOTTLENECK, transform=TRANSFORM, full_res_convs: int = 1):
        super().__init__()
        if transform not in TRANSFORMS:
            raise ValueError(f"unknown colour transform {transform!r} (one of {', '.join(TRANSFORMS)})")
        c = list(encoder)
        self.arch = {"encoder": c, "bottleneck": int(bottleneck), "transform": transform,
                     "full_res_convs": int(full_res_convs)}
        self.enc = nn.ModuleList([conv(IN_CHANNELS, c[0])] + [conv(c[i - 1], c[i]) for i in range(1, len(c))])
        # further convs at full resolution after the first encoder and the last decoder conv
        self.enc_extra = nn.ModuleList([conv(c[0], c[0]) for _ in range(full_res_convs - 1)])
        self.bottleneck = nn.Sequential(conv(c[-1], bottleneck), nn.ReLU(inplace=True),
                                        conv(bottleneck, bottleneck), nn.ReLU(inplace=True))
        ups, prev = [], bottleneck
        for ch in reversed(c):
            ups.append(conv(prev + ch, ch))
            prev = ch
        self.dec = nn.ModuleList(ups)
        self.dec_extra = nn.ModuleList([conv(c[0], c[0]) for _ in range(full_res_convs - 1)])
        self.out = conv(c[0], 3)

    def _color_in(self, x: torch.Tensor) -> torch.Tensor:
        v = torch.relu(x)
        if self.arch["transform"] == "log":
            return torch.log(1.0 + v * (1.0 / LOG_EPS)) * (1.0 / math.log1p(1.0 / LOG_EPS))
        return torch.log(1.0 + v)  # log1p: not in ONNX opset 17

    def _color_out(self, y: torch.Tensor) -> torch.Tensor:
        e = torch.exp(torch.clamp(y, max=LOG_CLAMP))
        return e * LOG_EPS if self.arch["transform"] == "log" else torch.relu(e - 1.0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = torch.cat([self._color_in(x[:, :3]), x[:, 3:]], dim=1)
        skips = []
        for i, layer in enumerate(self.enc):
            if i:
                h = F.max_pool2d(h, 2)
            h = torch.relu(layer(h))
            if i == 0:
                for extra in self.enc_extra:
                    h = torch.relu(extra(h))
            skips.append(h)
        h = self.bottleneck(F.max_pool2d(h, 2))
        for layer, skip in zip(self.dec, reversed(skips)):
            h = F.interpolate(h, scale_factor=2.0, mode="nearest")
            h = torch.relu(layer(torch.cat([h, skip], dim=1)))
        for extra in self.dec_extra:
            h = torch.relu(extra(h))
        # the output conv in float32 even under autocast: a bfloat16 y would quantise the
        # radiance in steps of ~2% (y is a log)
        with torch.autocast(device_type=h.device.type, enabled=False):
            y = self.out(h.float())
        return self._color_out(y)


def macs_per_pixel(model: DenoiseUNet) -> float:
    """Multiply-adds per output pixel (each level's convs weighted by its share of the pixels)."""
    total = 0.0
    levels = [1] + [4 ** i for i in range(1, len(model.enc))]
    for layer, scale in zip(model.enc, levels):
        total += layer.weight.numel() / scale
    total += sum(m.weight.numel() for m in list(model.enc_extra) + list(model.dec_extra))
    total += sum(m.weight.numel() for m in model.bottleneck if isinstance(m, nn.Conv2d)) / 4 ** len(model.enc)
    for layer, scale in zip(model.dec, reversed(levels)):
        total += layer.weight.numel() / scale
    return total + model.out.weight.numel()
