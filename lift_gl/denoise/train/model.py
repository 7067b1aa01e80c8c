"""The denoiser's networks, built by name (`build_model`):

- "unet" (DenoiseUNet): the quality model for final images, a U-Net in the manner of OIDN's
  (encoder and decoder with skip connections, 3x3 convolutions and ReLU, 2x2 max pooling,
  nearest upsampling, HDR colour through a log curve), encoder 32, 48, 64, 80 and a bottleneck
  of 80 at 1/16: about 52k multiply-adds a pixel.
- "rt" (RealTimeUNet): the lean model for every frame of the viewer. A stride-2 2x2 conv takes
  full resolution to 1/2 (a learned space-to-depth: all four pixels of a block reach the
  features), an encoder at 1/2, 1/4, 1/8, a bottleneck at 1/16, a decoder with skips back to
  1/2, and a stride-2 2x2 transposed conv back to full resolution (a learned depth-to-space).
  Nothing runs at full resolution but those two: about 8k multiply-adds a pixel. With
  `chroma_block` k (the shipped rt: CHROMA_BLOCK) the output's colour balance over kxk
  blocks is set to the input's (_keep_chroma): no weights, so it applies to a trained model.

Input channels (`input_channels`): colour (3), albedo (3), normal (3), and with
`temporal=True` the previous frame's denoised output (3: linear, demodulated and exposed as
the colour is, reprojected to this frame) and its validity (1: 0 where the history does not
hold, which also zeroes the previous colour). Both colour inputs go through the colour
transform.

Colour transform (`transform`, inside the graph, inverted on the output):
- "log": t(x) = log(1 + x/eps) / log(1 + 1/eps) with eps = LOG_EPS, the loss's steep curve
  (0 at 0, 1 at 1, slope 22 at 0): dark regions (exposed radiance 0.005-0.05) get as much of
  the input's and the output's range as bright ones. The output y is mapped back by
  eps * exp(y), so that an error in y is a relative error of the radiance, and no output has
  a zero gradient (an earlier relu(eps * (exp(y) - 1)) let a wider network die at the start
  of training: every y below 0, so every output 0 with no gradient).
- "log1p": log(1 + x) in, exp(y) - 1 out, the first shipped model's: almost linear below
  0.2, so that a small offset in y is an additive haze in the dark.

`model.arch` holds what rebuilds the model (`model_from_arch(model.arch)`): its name and
constructor arguments; checkpoints and the ONNX sidecar store it.

Multiples: H and W must be multiples of MULTIPLE (four halvings); the onnx denoiser pads.
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
RT_ENCODER = (24, 32, 48)  # the rt model's channels at 1/2, 1/4, 1/8
RT_BOTTLENECK = 48  # at 1/16
CHROMA_BLOCK = 8  # the block of the rt model's chroma correction (_keep_chroma; 0: none)
CHROMA_EPS = 1e-4  # of the exposed radiance: a black block keeps the output's chroma
CHROMA_RANGE = 3.0  # a block's channel scaled by at most 3x or 1/3: a coloured firefly tints, not paints
TRANSFORM = "log"
TRANSFORMS = ("log", "log1p")
MODELS = ("unet", "rt")
LOG_EPS = 0.01  # the "log" transform's toe, as the loss's (loss.DARK_EPS)
MULTIPLE = 16
# An impulse moves outputs up to 64 px away (measured), up to 79 px for a pixel at the far end
# of a 16-px pooling block; rounded up to a multiple of MULTIPLE. An extra full-resolution conv
# each side adds 2 px: still within. The rt model's 3x3 convs sit one level coarser each but
# there is one level fewer: its reach is within the same bound (tests/test_rt_model.py).
RECEPTIVE_RADIUS = 96
GUIDE_CHANNELS = ("color.r", "color.g", "color.b", "albedo.r", "albedo.g", "albedo.b",
                  "normal.x", "normal.y", "normal.z")
TEMPORAL_CHANNELS = ("previous.r", "previous.g", "previous.b", "previous.valid")
IN_CHANNELS = len(GUIDE_CHANNELS)
LOG_CLAMP = 25.0  # output log value cap: eps * exp(25) ~ 7e8, far above any exposed radiance
PASSTHROUGH_BIAS = -8.0  # the passthrough's share starts at sigmoid(-8) = 3e-4 (_start_passthrough)


def input_channels(temporal: bool) -> tuple[str, ...]:
    return GUIDE_CHANNELS + (TEMPORAL_CHANNELS if temporal else ())


def conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, padding=1)


class _ColourTransform(nn.Module):
    """The colour curve in and out (module docstring), shared by both models."""

    def __init__(self, transform: str, temporal: bool):
        super().__init__()
        if transform not in TRANSFORMS:
            raise ValueError(f"unknown colour transform {transform!r} (one of {', '.join(TRANSFORMS)})")
        self.transform, self.temporal = transform, bool(temporal)
        self.in_channels = len(input_channels(temporal))

    def _color_in(self, x: torch.Tensor) -> torch.Tensor:
        v = torch.relu(x)
        if self.transform == "log":
            return torch.log(1.0 + v * (1.0 / LOG_EPS)) * (1.0 / math.log1p(1.0 / LOG_EPS))
        return torch.log(1.0 + v)  # log1p: not in ONNX opset 17

    def transformed_input(self, x: torch.Tensor) -> torch.Tensor:
        parts = [self._color_in(x[:, :3]), x[:, 3:IN_CHANNELS]]
        if self.temporal:
            parts += [self._color_in(x[:, IN_CHANNELS:IN_CHANNELS + 3]), x[:, IN_CHANNELS + 3:]]
        return torch.cat(parts, dim=1)

    def _color_out(self, y: torch.Tensor) -> torch.Tensor:
        e = torch.exp(torch.clamp(y, max=LOG_CLAMP))
        return e * LOG_EPS if self.transform == "log" else torch.relu(e - 1.0)

    def _make_bottom(self, channels, bottleneck: int) -> None:
        """Both models' lower half: two convs at the bottleneck below the deepest encoder level,
        then a conv a level back up on the upsampled features and that level's skip."""
        self.bottleneck = nn.Sequential(conv(channels[-1], bottleneck), nn.ReLU(inplace=True),
                                        conv(bottleneck, bottleneck), nn.ReLU(inplace=True))
        ups, prev = [], bottleneck
        for ch in reversed(channels):
            ups.append(conv(prev + ch, ch))
            prev = ch
        self.dec = nn.ModuleList(ups)

    def _decode(self, h: torch.Tensor, skips: list) -> torch.Tensor:
        h = self.bottleneck(F.max_pool2d(h, 2))
        for layer, skip in zip(self.dec, reversed(skips)):
            h = F.interpolate(h, scale_factor=2.0, mode="nearest")
            h = torch.relu(layer(torch.cat([h, skip], dim=1)))
        return h

    def _output(self, layer: nn.Module, h: torch.Tensor, passthrough: torch.Tensor | None = None) -> torch.Tensor:
        """The output layer's colour; `passthrough` (the input colour): blended in by the share
        sigmoid(the layer's fourth channel) (DenoiseUNet's passthrough)."""
        # the output layer in float32 even under autocast: a bfloat16 y would quantise the
        # radiance in steps of ~2% (y is a log)
        with torch.autocast(device_type=h.device.type, enabled=False):
            y = layer(h.float())
            if passthrough is not None:
                share, y = torch.sigmoid(y[:, 3:4]), y[:, :3]
        if passthrough is None:
            return self._color_out(y)
        return self._color_out(y) * (1.0 - share) + torch.relu(passthrough.float()) * share

    def _start_passthrough(self, layer: nn.Module) -> None:
        """The share's channel (the output layer's fourth) starts at zero weights and the bias
        PASSTHROUGH_BIAS: a share of 3e-4 everywhere, the network alone. At a share of 1/2 a
        model trained from random weights handed the whole input back within 500 steps (the
        input beats a network not yet trained) and stayed there: sigmoid's slope is 0 at 1."""
        with torch.no_grad():
            weight = layer.weight if isinstance(layer, nn.Conv2d) else layer.weight.transpose(0, 1)
            weight[3:].zero_()  # output channels on axis 0 (Conv2d), 1 (ConvTranspose2d)
            layer.bias[3:] = PASSTHROUGH_BIAS


class DenoiseUNet(_ColourTransform):
    """passthrough: the output conv gives a fourth channel z, and the output is
    (1 - s) * network + s * input colour with s = sigmoid(z), linear, so that where the input
    is already exact (an emitter seen directly) the network can return it unchanged."""

    def __init__(self, encoder=ENCODER, bottleneck=BOTTLENECK, transform=TRANSFORM, full_res_convs: int = 1,
                 temporal: bool = False, passthrough: bool = False):
        super().__init__(transform, temporal)
        c = list(encoder)
        self.arch = {"name": "unet", "encoder": c, "bottleneck": int(bottleneck), "transform": transform,
                     "full_res_convs": int(full_res_convs), "temporal": self.temporal,
                     "passthrough": bool(passthrough)}
        self.enc = nn.ModuleList([conv(self.in_channels, c[0])] + [conv(c[i - 1], c[i]) for i in range(1, len(c))])
        # further convs at full resolution after the first encoder and the last decoder conv
        self.enc_extra = nn.ModuleList([conv(c[0], c[0]) for _ in range(full_res_convs - 1)])
        self._make_bottom(c, bottleneck)
        self.dec_extra = nn.ModuleList([conv(c[0], c[0]) for _ in range(full_res_convs - 1)])
        self.out = conv(c[0], 4 if passthrough else 3)
        if passthrough:
            self._start_passthrough(self.out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.transformed_input(x)
        skips = []
        for i, layer in enumerate(self.enc):
            if i:
                h = F.max_pool2d(h, 2)
            h = torch.relu(layer(h))
            if i == 0:
                for extra in self.enc_extra:
                    h = torch.relu(extra(h))
            skips.append(h)
        h = self._decode(h, skips)
        for extra in self.dec_extra:
            h = torch.relu(extra(h))
        return self._output(self.out, h, passthrough=x[:, :3] if self.arch["passthrough"] else None)


class RealTimeUNet(_ColourTransform):
    """The "rt" model (module docstring): full resolution only in the 2x2 stride-2 conv in and
    the 2x2 stride-2 transposed conv out."""

    def __init__(self, encoder=RT_ENCODER, bottleneck=RT_BOTTLENECK, transform=TRANSFORM, temporal: bool = False,
                 passthrough: bool = False, chroma_block: int = CHROMA_BLOCK):
        super().__init__(transform, temporal)
        c = list(encoder)
        self.arch = {"name": "rt", "encoder": c, "bottleneck": int(bottleneck), "transform": transform,
                     "temporal": self.temporal, "passthrough": bool(passthrough), "chroma_block": int(chroma_block)}
        # the channels' mean as a 1x1 conv: an op the GLSL executor runs (it has no ReduceMean)
        self.register_buffer("channel_mean", torch.full((1, 3, 1, 1), 1.0 / 3.0), persistent=False)
        self.down = nn.Conv2d(self.in_channels, c[0], 2, stride=2)  # full -> 1/2
        self.enc = nn.ModuleList([conv(c[0], c[0])] + [conv(c[i - 1], c[i]) for i in range(1, len(c))])
        self._make_bottom(c, bottleneck)
        # 1/2 -> full: the output's log colour (and the passthrough's share, as DenoiseUNet's)
        self.up = nn.ConvTranspose2d(c[0], 4 if passthrough else 3, 2, stride=2)
        if passthrough:
            self._start_passthrough(self.up)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = torch.relu(self.down(self.transformed_input(x)))
        skips = []
        for i, layer in enumerate(self.enc):
            if i:
                h = F.max_pool2d(h, 2)
            h = torch.relu(layer(h))
            skips.append(h)
        out = self._output(self.up, self._decode(h, skips), passthrough=x[:, :3] if self.arch["passthrough"] else None)
        return self._keep_chroma(out, x[:, :3], self.arch["chroma_block"]) if self.arch["chroma_block"] else out

    def _keep_chroma(self, out: torch.Tensor, colour: torch.Tensor, k: int) -> torch.Tensor:
        """`out` with each kxk block's colour balance (channel means over their mean) the
        input's, the ratio upsampled bilinearly; the blocks' brightness stays the network's.
        Why: the rt drifts in colour (Lift's cornell-box lavender) where its luminance is right;
        the mean of 64 samples holds the colour better at 1 spp (docs/denoiser.md)."""
        with torch.autocast(device_type=out.device.type, enabled=False):
            mean_in, mean_out = F.avg_pool2d(torch.relu(colour.float()), k), F.avg_pool2d(out.float(), k)
            grey_in, grey_out = F.conv2d(mean_in, self.channel_mean), F.conv2d(mean_out, self.channel_mean)
            ratio = ((mean_in + CHROMA_EPS) * (grey_out + CHROMA_EPS)) / ((grey_in + CHROMA_EPS) * (mean_out + CHROMA_EPS))
            ratio = torch.clamp(ratio, 1.0 / CHROMA_RANGE, CHROMA_RANGE)
            return out * F.interpolate(ratio, scale_factor=float(k), mode="bilinear", align_corners=False)


def build_model(name: str = "unet", temporal: bool = False, **options) -> nn.Module:
    """The network `name` (one of MODELS) with `temporal` inputs; `options` are its
    constructor's (encoder, bottleneck, transform; the unet's full_res_convs)."""
    if name == "unet":
        return DenoiseUNet(temporal=temporal, **options)
    if name == "rt":
        return RealTimeUNet(temporal=temporal, **options)
    raise ValueError(f"unknown denoiser model {name!r} (one of {', '.join(MODELS)})")


DERIVED_ARCH_KEYS = ("inputs", "parameters", "macs_per_pixel")  # the sidecar's additions to .arch


def model_from_arch(arch: dict) -> nn.Module:
    """The model `arch` describes (a model's .arch, or a sidecar's `architecture`; an arch
    without a name is a unet's)."""
    arch = {k: v for k, v in arch.items() if k not in DERIVED_ARCH_KEYS}
    if arch.get("name") == "rt":
        if arch.pop("colour_skip", 0):  # an option that lost (docs/denoiser.md), no longer built
            raise ValueError("an rt model with a colour skip: this version builds none (colour_skip 0)")
        arch.setdefault("passthrough", False)
        arch.setdefault("chroma_block", 0)  # an rt model saved before the chroma correction
    return build_model(arch.pop("name", "unet"), **arch)


def macs_per_pixel(model: nn.Module) -> float:
    """Multiply-adds per full-resolution pixel, each conv weighted by its output's share of the
    pixels (a 2x2 stride-2 conv: its weights once per 4 pixels; a 2x2 stride-2 transposed conv:
    a quarter of its weights per pixel)."""
    if isinstance(model, RealTimeUNet):
        levels = [4 ** (i + 1) for i in range(len(model.enc))]  # the encoder starts at 1/2
        total = (model.down.weight.numel() + model.up.weight.numel()) / 4
        deepest = 4 ** (len(model.enc) + 1)
    else:
        levels = [1] + [4 ** i for i in range(1, len(model.enc))]
        total = model.out.weight.numel()
        total += sum(m.weight.numel() for m in list(model.enc_extra) + list(model.dec_extra))
        deepest = 4 ** len(model.enc)
    for layer, scale in zip(model.enc, levels):
        total += layer.weight.numel() / scale
    total += sum(m.weight.numel() for m in model.bottleneck if isinstance(m, nn.Conv2d)) / deepest
    for layer, scale in zip(model.dec, reversed(levels)):
        total += layer.weight.numel() / scale
    return total


if __name__ == "__main__":  # python -m lift_gl.denoise.train.model: each model's cost
    for name in MODELS:
        for temporal in (False, True):
            m = build_model(name, temporal)
            print(f"{name:4s} temporal={temporal!s:5s} in={m.in_channels:2d} "
                  f"params={sum(p.numel() for p in m.parameters()):7d} MACs/px={macs_per_pixel(m):8.0f}")
