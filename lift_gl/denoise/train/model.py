"""The denoiser's network: a small U-Net in the manner of OIDN's (encoder and decoder with
skip connections, 3x3 convolutions and ReLU, 2x2 max pooling, nearest upsampling, HDR colour
through log1p), narrow at full resolution so that a 1080p frame stays cheap on a CPU.

Multiples: H and W must be multiples of MULTIPLE (four poolings); the onnx denoiser pads.
RECEPTIVE_RADIUS bounds how far a pixel's output looks, so tiles overlapping by that much
give the untiled result.
"""
from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

ENCODER = (16, 32, 48, 64)  # channels at 1, 1/2, 1/4, 1/8 resolution
BOTTLENECK = 80  # at 1/16
MULTIPLE = 16
# An impulse moves outputs up to 64 px away (measured), up to 79 px for a pixel at the far end
# of a 16-px pooling block; rounded up to a multiple of MULTIPLE.
RECEPTIVE_RADIUS = 96
IN_CHANNELS = 9
LOG_CLAMP = 20.0  # output log1p value cap: expm1(20) ~ 5e8, far above any exposed radiance


def conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, padding=1)


class DenoiseUNet(nn.Module):
    def __init__(self, encoder=ENCODER, bottleneck=BOTTLENECK):
        super().__init__()
        c = list(encoder)
        self.enc = nn.ModuleList([conv(IN_CHANNELS, c[0])] + [conv(c[i - 1], c[i]) for i in range(1, len(c))])
        self.bottleneck = nn.Sequential(conv(c[-1], bottleneck), nn.ReLU(inplace=True),
                                        conv(bottleneck, bottleneck), nn.ReLU(inplace=True))
        ups, prev = [], bottleneck
        for ch in reversed(c):
            ups.append(conv(prev + ch, ch))
            prev = ch
        self.dec = nn.ModuleList(ups)
        self.out = conv(c[0], 3)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # HDR colour into a log domain (OIDN uses a PU curve; log1p serves the same purpose).
        h = torch.cat([torch.log(1.0 + torch.relu(x[:, :3])), x[:, 3:]], dim=1)  # log1p: not in ONNX
        skips = []
        for i, layer in enumerate(self.enc):
            if i:
                h = F.max_pool2d(h, 2)
            h = torch.relu(layer(h))
            skips.append(h)
        h = self.bottleneck(F.max_pool2d(h, 2))
        for layer, skip in zip(self.dec, reversed(skips)):
            h = F.interpolate(h, scale_factor=2.0, mode="nearest")
            h = torch.relu(layer(torch.cat([h, skip], dim=1)))
        y = self.out(h)
        return torch.relu(torch.exp(torch.clamp(y.float(), max=LOG_CLAMP)) - 1.0)


def macs_per_pixel(model: DenoiseUNet) -> float:
    """Multiply-adds per output pixel (each level's convs weighted by its share of the pixels)."""
    total = 0.0
    levels = [1] + [4 ** i for i in range(1, len(model.enc))]
    for layer, scale in zip(model.enc, levels):
        total += layer.weight.numel() / scale
    total += sum(m.weight.numel() for m in model.bottleneck if isinstance(m, nn.Conv2d)) / 4 ** len(model.enc)
    for layer, scale in zip(model.dec, reversed(levels)):
        total += layer.weight.numel() / scale
    return total + model.out.weight.numel()
