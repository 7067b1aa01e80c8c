"""The training loop: random crops of the rendered examples, augmented, Adam under a schedule of
stages (each a warm restart: warm-up, then a cosine to the stage's last step), checkpoints that
a later run resumes from bit for bit (model, optimizer, step and the batch generator's state).

`fit` runs a schedule of Stages on a model, stopping at a deadline or a step and resuming from
its checkpoint; `train` is one stage of it (the four-command recipe of python -m
lift_gl.denoise.train). A temporal model (model.arch["temporal"]) trains on frame
pairs (temporal.py); the others on single frames."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from .loss import W_SSIM, denoise_loss, mean_loss
from .model import model_from_arch

TRAIN_LEVELS_WEIGHTS = (3, 2, 3, 2, 2, 1, 1)  # 1..64 spp; the low counts matter most
WARMUP = 200


@dataclass(frozen=True)
class Stage:
    """Steps up to `end` (from the previous stage's end) at a peak learning rate `lr`, with
    these loss weights (loss.py: 1 - SSIM, and mean_loss's)."""
    end: int
    lr: float
    ssim_weight: float = W_SSIM
    mean_weight: float = 0.0


def stage_at(stages, step: int) -> tuple[int, int]:
    """(index, first step) of the stage that the step `step` belongs to; len(stages) when done."""
    start = 0
    for i, stage in enumerate(stages):
        if step < stage.end:
            return i, start
        start = stage.end
    return len(stages), start


class Examples:
    """All examples on the device, float16: noisy (N, L, 3, H, W), guides (N, 6, H, W), ..."""

    def __init__(self, paths, device):
        data = [np.load(p) for p in paths]
        stack = lambda key: torch.from_numpy(np.stack([d[key] for d in data])).to(device)
        self.noisy, self.guides = stack("noisy"), stack("guides")
        self.target, self.divisor, self.exposure = stack("target"), stack("divisor"), stack("exposure")
        self.device = device

    def __len__(self):
        return self.noisy.shape[0]

    def batch(self, gen: torch.Generator, size: int, crop: int, levels_weights=TRAIN_LEVELS_WEIGHTS):
        """(x, divisor, target radiance) of one augmented batch, all times the example's exposure."""
        n, _, _, h, w = self.noisy.shape
        weights = torch.tensor(levels_weights[: self.noisy.shape[1]], dtype=torch.float)  # fewer levels: the first
        xs, divs, tgts = [], [], []
        for _ in range(size):
            i = int(torch.randint(n, (1,), generator=gen))
            lvl = int(torch.multinomial(weights, 1, generator=gen))
            y0 = int(torch.randint(h - crop + 1, (1,), generator=gen))
            x0 = int(torch.randint(w - crop + 1, (1,), generator=gen))
            sl = (slice(y0, y0 + crop), slice(x0, x0 + crop))
            # exposure jitter: the network must not depend on the autoexposure being exact
            exposure = self.exposure[i, lvl] * float(2.0 ** (2 * torch.rand(1, generator=gen) - 1))
            perm = torch.randperm(3, generator=gen).to(self.device)  # colour channel permutation
            color = self.noisy[i, lvl][:, sl[0], sl[1]].float()[perm] * exposure
            albedo = self.guides[i, :3][:, sl[0], sl[1]].float()[perm]
            normal = self.guides[i, 3:][:, sl[0], sl[1]].float()
            div = self.divisor[i][:, sl[0], sl[1]].float()[perm]
            tgt = self.target[i][:, sl[0], sl[1]].float()[perm] * exposure * div
            t = augment([color, albedo, normal, div, tgt], gen)
            xs.append(torch.cat(t[:3]))
            divs.append(t[3])
            tgts.append(t[4])
        return torch.stack(xs), torch.stack(divs), torch.stack(tgts)


def augment(images, gen: torch.Generator, inverse: bool = False, k: int | None = None, flip: bool | None = None):
    """The same rotation of the image plane (k quarter turns) and flip on each (C, H, W) image,
    drawn from `gen` when k and flip are not given; `inverse` undoes a given one."""
    if k is None:
        k = int(torch.randint(4, (1,), generator=gen))
        flip = bool(torch.randint(2, (1,), generator=gen))
    if inverse:
        images = [torch.flip(a, dims=(2,)) for a in images] if flip else images
        return [torch.rot90(a, -k, dims=(1, 2)) for a in images]
    images = [torch.rot90(a, k, dims=(1, 2)) for a in images]
    return [torch.flip(a, dims=(2,)) for a in images] if flip else images


def lr_at(step: int, steps: int, peak: float, warmup: int = WARMUP) -> float:
    if step < warmup:
        return peak * (step + 1) / warmup
    return 0.5 * peak * (1 + math.cos(math.pi * min(1.0, (step - warmup) / max(1, steps - warmup))))


def frame_loss(pred, x, div, tgt, stage: Stage, loss_tonemap: str = "log"):
    """The loss of one frame: pred is the network's demodulated output for the input x, div
    remodulates both."""
    radiance = pred.float() * div
    loss = denoise_loss(radiance, tgt, loss_tonemap, stage.ssim_weight)
    if stage.mean_weight:
        loss = loss + stage.mean_weight * mean_loss(radiance, tgt, x[:, :3] * div)
    return loss


def save_checkpoint(path: Path, model, opt, step: int, seconds: float, gen: torch.Generator, extra: dict) -> None:
    """Written under a temporary name and renamed: a run killed while saving keeps the last one."""
    path = Path(path)
    tmp = path.with_suffix(".tmp")
    torch.save({"model": model.state_dict(), "arch": model.arch, "optimizer": opt.state_dict(), "step": step,
                "seconds": seconds, "generator": gen.get_state(), **extra}, tmp)
    tmp.replace(path)


def fit(model, train_examples, val_examples, stages, ckpt_path: Path, batch: int = 16, crop: int = 128,
        seed: int = 0, deadline: float | None = None, stop_at: int | None = None, log=print,
        loss_tonemap: str = "log", checkpoint_extra: dict | None = None, checkpoint_every: int = 500,
        history_drop: float = 0.25, clock=time.monotonic) -> dict:
    """Train `model` through `stages`, resuming from ckpt_path when it exists, until the last
    stage's end, the step `stop_at`, or `deadline` (a clock() value) — whichever comes first —
    and save the checkpoint. The same seed and stages give the same weights whether the run
    went through at once or stopped and resumed (on one device: kernels may differ between
    devices). Returns a summary dict with the model."""
    device = next(model.parameters()).device
    temporal = bool(model.arch.get("temporal"))
    opt = torch.optim.Adam(model.parameters(), lr=stages[0].lr)
    gen = torch.Generator().manual_seed(seed)
    step, seconds_before, resumed_at = 0, 0.0, None
    ckpt_path = Path(ckpt_path)
    if ckpt_path.exists():
        ckpt = torch.load(ckpt_path, map_location=device)
        model.load_state_dict(ckpt["model"])
        opt.load_state_dict(ckpt["optimizer"])
        step, seconds_before = ckpt["step"], ckpt.get("seconds", 0.0)
        gen.set_state(ckpt["generator"].cpu())  # map_location moved it; the generator lives on the CPU
        resumed_at = step
        log(f"train: resumed at step {step}")
    amp = (torch.autocast(device_type="cuda", dtype=torch.bfloat16) if device.type == "cuda"
           else torch.autocast("cpu", enabled=False))
    start = clock()
    seconds = lambda: seconds_before + clock() - start
    save = lambda: save_checkpoint(ckpt_path, model, opt, step, seconds(), gen, checkpoint_extra or {})
    if temporal:
        from .temporal import temporal_step

    def one_step(stage: Stage) -> torch.Tensor:
        if temporal:
            return temporal_step(model, train_examples, gen, batch, crop, stage, amp, loss_tonemap, history_drop)
        x, div, tgt = train_examples.batch(gen, batch, crop)
        with amp:
            pred = model(x.contiguous(memory_format=torch.channels_last))
        return frame_loss(pred, x, div, tgt, stage, loss_tonemap)

    last = stages[-1].end if stop_at is None else min(stop_at, stages[-1].end)
    losses, stopped_by = [], None
    while step < last:
        if deadline is not None and clock() >= deadline:
            stopped_by = "time budget"
            log(f"train: time budget reached at step {step}")
            break
        index, first = stage_at(stages, step)
        stage = stages[index]
        for group in opt.param_groups:
            group["lr"] = lr_at(step - first, stage.end - first, stage.lr)
        loss = one_step(stage)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()) if step % 50 == 0 else None)
        step += 1
        if step % checkpoint_every == 0 or step == stage.end:
            vl = (validation_loss(model, val_examples, amp, loss_tonemap)
                  if val_examples is not None else float("nan"))
            recent = [v for v in losses[-500:] if v is not None] or [float("nan")]
            log(f"train: step {step}/{stages[-1].end} (stage {index + 1}/{len(stages)}), loss {np.mean(recent):.4f}, "
                f"val loss {vl:.4f}, {clock() - start:.0f} s")
            save()
    save()
    return {"steps": step, "resumed_at": resumed_at, "seconds": seconds(), "device": device.type,
            "stopped_by": stopped_by, "train_scenes": len(train_examples),
            "val_scenes": len(val_examples) if val_examples is not None else 0, "model": model}


def train(train_paths, val_paths, out_dir: Path, steps: int, batch: int = 16, crop: int = 128, lr: float = 2e-3,
          seed: int = 0, minutes: float | None = None, log=print, stop_at: int | None = None,
          loss_tonemap: str = "log", arch: dict | None = None, schedule_start: int = 0,
          ssim_weight: float = W_SSIM, mean_weight: float = 0.0) -> dict:
    """Train the U-Net (resuming from out_dir/checkpoint.pt when present); returns a summary dict.

    One stage: the learning rate follows a warm-up and a cosine from `schedule_start` to
    `steps` (schedule_start > 0: a warm restart of a resumed checkpoint); `stop_at` ends the
    run earlier at that step (resumable). `arch` is a model.model_from_arch description (a resumed
    checkpoint's own architecture wins). The validation loss keeps the default weights
    (loss.W_SSIM, no mean term) so that runs with other weights stay comparable."""
    device = "cuda" if torch.cuda.is_available() else "cpu"
    torch.manual_seed(seed)
    torch.backends.cudnn.benchmark = True  # fixed crop size: let cuDNN pick its fastest kernels
    ckpt_path = Path(out_dir) / "checkpoint.pt"
    if ckpt_path.exists():  # checkpoints before "arch" was stored are the first shipped network's
        arch = torch.load(ckpt_path, map_location="cpu").get(
            "arch", {"encoder": (16, 32, 48, 64), "bottleneck": 80, "transform": "log1p"})
    model = model_from_arch(arch or {}).to(device).to(memory_format=torch.channels_last)
    # steps before schedule_start belong to an earlier stage whose lr is not this run's concern
    stages = ([Stage(schedule_start, lr)] if schedule_start else []) + [Stage(steps, lr, ssim_weight, mean_weight)]
    clock = time.monotonic
    deadline = None if minutes is None else clock() + 60 * minutes
    examples = Examples(train_paths, device)
    val = Examples(val_paths, device) if val_paths else None
    return fit(model, examples, val, stages, ckpt_path, batch, crop, seed, deadline, stop_at, log, loss_tonemap)


def single_frame_input(model, x: torch.Tensor) -> torch.Tensor:
    """x as the model takes a frame without history: a temporal model's previous output and
    its validity (the channels after the nine) are zero."""
    extra = getattr(model, "in_channels", x.shape[1]) - x.shape[1]
    return torch.cat([x, x.new_zeros(x.shape[0], extra, *x.shape[2:])], dim=1) if extra > 0 else x


@torch.no_grad()
def validation_loss(model, val: Examples, amp, loss_tonemap: str = "log", levels=(0, 2, 4)) -> float:
    """Mean loss on whole validation images at 1, 4 and 16 spp (scenes never trained on)."""
    model.eval()
    total = []
    for i in range(len(val)):
        for lvl in (lvl for lvl in levels if lvl < val.noisy.shape[1]):  # data with fewer levels: theirs
            e = val.exposure[i, lvl]
            x = single_frame_input(model, torch.cat([val.noisy[i, lvl].float() * e, val.guides[i].float()])[None])
            div = val.divisor[i].float()[None]
            with amp:
                pred = model(x.contiguous(memory_format=torch.channels_last))
            total.append(float(denoise_loss(pred.float() * div, val.target[i].float()[None] * e * div,
                                             loss_tonemap)))
    model.train()
    return float(np.mean(total))


@torch.no_grad()
def mean_ratios(model, val: Examples, level: int = 2, per_channel: bool = False) -> list:
    """Per validation image, mean(denoised radiance) / mean(reference radiance) at one spp level
    (index into SPP_LEVELS; 2 is 4 spp), on whole images: 1 keeps the mean. per_channel: a list
    of the R, G and B ratios for each image instead."""
    model.eval()
    ratios = []
    axes = (0, 2, 3) if per_channel else (0, 1, 2, 3)
    for i in range(len(val)):
        e = val.exposure[i, level]
        x = single_frame_input(model, torch.cat([val.noisy[i, level].float() * e, val.guides[i].float()])[None])
        div = val.divisor[i].float()[None]
        pred = model(x.contiguous(memory_format=torch.channels_last)).float() * div
        ratio = pred.mean(axes) / (val.target[i].float()[None] * e * div).mean(axes)
        ratios.append(ratio.tolist() if per_channel else float(ratio))
    model.train()
    return ratios
