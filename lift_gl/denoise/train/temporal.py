"""Temporal training: the network sees, beside frame t's noisy colour and guides, its own output
for frame t-1 reprojected into frame t and where that is valid (channels 9-11 and 12 of the
temporal model's input: previous output colour, linear, demodulated and at frame t's exposure;
previous-valid).

One step unrolls two frames (temporal_data.py's pairs): frame t-1 is denoised without history
(valid 0), its output warped into frame t by the motion vectors (grid_sample, bilinear) and fed,
detached, as frame t's history; pixels that were off screen or disoccluded (the pair's `history`
mask), or whose source lies outside the crop, get valid 0. The loss is both frames' (train.py
frame_loss) plus W_TEMPORAL times an L1 between the output's change from the warped frame t-1
to frame t and the reference's, on tone-mapped values where valid (the flicker a viewer sees,
against what the scene itself changes). A share `history_drop` of samples trains with no history
at all, so that the network also works on a first frame or after a cut.
"""
from __future__ import annotations

import torch
from torch.nn import functional as F

from .loss import tonemap
from .train import TRAIN_LEVELS_WEIGHTS, Examples, augment, frame_loss

W_TEMPORAL = 1.0


class PairExamples(Examples):
    """Frame t's arrays as Examples has them (so validation runs on frame t), frame t-1's as
    prev_*, the source positions and history mask."""

    def __init__(self, paths, device):
        super().__init__(paths, device)
        import numpy as np
        data = [np.load(p) for p in paths]
        missing = [str(p) for p, d in zip(paths, data) if "source" not in d.files]
        if missing:
            raise ValueError(f"not frame pairs (render them with temporal_data.generate_pairs): {', '.join(missing)}")
        stack = lambda key: torch.from_numpy(np.stack([d[key] for d in data])).to(device)
        self.prev = {k: stack(f"prev_{k}") for k in ("noisy", "guides", "target", "divisor", "exposure")}
        self.source, self.history = stack("source").float(), stack("history")

    def pair_batch(self, gen: torch.Generator, size: int, crop: int, history_drop: float,
                   levels_weights=TRAIN_LEVELS_WEIGHTS) -> dict:
        """One augmented batch of crops of both frames (the same window and level), each frame at
        its own exposure times one jitter; `grid` samples frame t-1's crop (grid_sample's
        coordinates, before augmentation) and `valid` (N, 1, crop, crop) says where it may."""
        n, _, _, h, w = self.noisy.shape
        weights = torch.tensor(levels_weights[: self.noisy.shape[1]], dtype=torch.float)  # fewer levels: the first
        rows = {k: [] for k in ("x_prev", "div_prev", "tgt_prev", "x", "div", "tgt", "grid", "valid", "ratio", "aug")}
        for _ in range(size):
            i = int(torch.randint(n, (1,), generator=gen))
            lvl = int(torch.multinomial(weights, 1, generator=gen))
            y0 = int(torch.randint(h - crop + 1, (1,), generator=gen))
            x0 = int(torch.randint(w - crop + 1, (1,), generator=gen))
            jitter = float(2.0 ** (2 * torch.rand(1, generator=gen) - 1))
            perm = torch.randperm(3, generator=gen).to(self.device)
            keep = float(torch.rand(1, generator=gen)) >= history_drop
            k = int(torch.randint(4, (1,), generator=gen))
            flip = bool(torch.randint(2, (1,), generator=gen))
            sl = (slice(y0, y0 + crop), slice(x0, x0 + crop))
            frames = []
            current = {"noisy": self.noisy, "guides": self.guides, "divisor": self.divisor, "target": self.target}
            for arrays, exposure in ((self.prev, self.prev["exposure"][i, lvl]), (current, self.exposure[i, lvl])):
                e = exposure * jitter
                color = arrays["noisy"][i, lvl][:, sl[0], sl[1]].float()[perm] * e
                albedo = arrays["guides"][i, :3][:, sl[0], sl[1]].float()[perm]
                normal = arrays["guides"][i, 3:][:, sl[0], sl[1]].float()
                div = arrays["divisor"][i][:, sl[0], sl[1]].float()[perm]
                tgt = arrays["target"][i][:, sl[0], sl[1]].float()[perm] * e * div
                frames.append(augment([color, albedo, normal, div, tgt], gen, k=k, flip=flip))
            (cp, ap, np_, dp, tp), (c, a, nrm, d, t) = frames
            src = self.source[i][:, sl[0], sl[1]] - torch.tensor([x0, y0], device=self.device)[:, None, None]
            # all four bilinear taps inside the crop (pixel centres at +0.5)
            inside = (src[0] >= 0.5) & (src[0] <= crop - 0.5) & (src[1] >= 0.5) & (src[1] <= crop - 0.5)
            valid = (self.history[i][sl[0], sl[1]].float() * inside) * float(keep)
            rows["x_prev"].append(torch.cat([cp, ap, np_]))
            rows["div_prev"].append(dp)
            rows["tgt_prev"].append(tp)
            rows["x"].append(torch.cat([c, a, nrm]))
            rows["div"].append(d)
            rows["tgt"].append(t)
            # grid_sample with align_corners=False: -1 and 1 are the crop's outer edges
            rows["grid"].append(torch.stack([2 * src[0] / crop - 1, 2 * src[1] / crop - 1], dim=-1))
            rows["valid"].append(augment([valid[None]], gen, k=k, flip=flip)[0])
            rows["ratio"].append(self.exposure[i, lvl] / self.prev["exposure"][i, lvl])
            rows["aug"].append((k, flip))
        out = {key: torch.stack(v) for key, v in rows.items() if key != "aug"}
        out["aug"] = rows["aug"]
        return out


def warp(images: torch.Tensor, grid: torch.Tensor, aug) -> torch.Tensor:
    """Frame t-1's augmented images (N, C, H, W) into frame t: each un-augmented, sampled at
    its grid (bilinear, zero outside) and augmented again."""
    plain = torch.stack([augment([im], None, inverse=True, k=k, flip=flip)[0] for im, (k, flip) in zip(images, aug)])
    warped = F.grid_sample(plain, grid, mode="bilinear", padding_mode="zeros", align_corners=False)
    return torch.stack([augment([im], None, k=k, flip=flip)[0] for im, (k, flip) in zip(warped, aug)])


def temporal_loss(pred, warped_prev, tgt, warped_prev_tgt, valid, kind: str = "log") -> torch.Tensor:
    """Mean over valid pixels of |(T(pred) - T(warped prev)) - (T(tgt) - T(warped prev tgt))|."""
    change = tonemap(pred, kind) - tonemap(warped_prev, kind)
    ref_change = tonemap(tgt, kind) - tonemap(warped_prev_tgt, kind)
    return (valid * torch.abs(change - ref_change)).sum() / (3 * valid.sum()).clamp(min=1.0)


def temporal_step(model, examples: PairExamples, gen, batch: int, crop: int, stage, amp, loss_tonemap: str,
                  history_drop: float) -> torch.Tensor:
    """The loss of one two-frame batch (the module docstring)."""
    b = examples.pair_batch(gen, batch, crop, history_drop)
    n = b["x"].shape[0]
    zeros = b["x"].new_zeros(n, 4, crop, crop)
    with amp:
        pred_prev = model(torch.cat([b["x_prev"], zeros], 1).contiguous(memory_format=torch.channels_last)).float()
    # the history at frame t's exposure; where it is not valid it is zero, as at inference
    history = warp(pred_prev, b["grid"], b["aug"]) * b["ratio"][:, None, None, None] * b["valid"]
    x = torch.cat([b["x"], history.detach(), b["valid"]], 1)
    with amp:
        pred = model(x.contiguous(memory_format=torch.channels_last)).float()
    loss = frame_loss(pred_prev, b["x_prev"], b["div_prev"], b["tgt_prev"], stage, loss_tonemap)
    loss = loss + frame_loss(pred, b["x"], b["div"], b["tgt"], stage, loss_tonemap)
    # the change between frames as radiance of frame t: both sides remodulated by frame t's albedo
    prev_radiance = history * b["div"]
    prev_target = warp(b["tgt_prev"] / b["div_prev"], b["grid"], b["aug"]) * b["ratio"][:, None, None, None] * b["div"]
    return loss + W_TEMPORAL * temporal_loss(pred * b["div"], prev_radiance, b["tgt"], prev_target, b["valid"],
                                             loss_tonemap)
