"""The training loop: random crops of the rendered examples, augmented, a fixed number of
Adam steps under a cosine schedule, checkpoints that a later run resumes from."""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import torch

from .loss import W_SSIM, denoise_loss
from .model import model_from_arch

TRAIN_LEVELS_WEIGHTS = (3, 2, 3, 2, 2, 1, 1)  # 1..64 spp; the low counts matter most


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
        weights = torch.tensor(levels_weights, dtype=torch.float)
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
            t = [color, albedo, normal, div, tgt]
            k = int(torch.randint(4, (1,), generator=gen))  # rotations and flips of the image plane
            flip = bool(torch.randint(2, (1,), generator=gen))
            t = [torch.rot90(a, k, dims=(1, 2)) for a in t]
            if flip:
                t = [torch.flip(a, dims=(2,)) for a in t]
            xs.append(torch.cat(t[:3]))
            divs.append(t[3])
            tgts.append(t[4])
        return torch.stack(xs), torch.stack(divs), torch.stack(tgts)


def lr_at(step: int, steps: int, peak: float, warmup: int = 200) -> float:
    if step < warmup:
        return peak * (step + 1) / warmup
    return 0.5 * peak * (1 + math.cos(math.pi * min(1.0, (step - warmup) / max(1, steps - warmup))))


def train(train_paths, val_paths, out_dir: Path, steps: int, batch: int = 16, crop: int = 128, lr: float = 2e-3,
          seed: int = 0, minutes: float | None = None, log=print, stop_at: int | None = None,
          loss_tonemap: str = "log", arch: dict | None = None, schedule_start: int = 0,
          ssim_weight: float = W_SSIM) -> dict:
    """Train (resuming from out_dir/checkpoint.pt when present); returns a summary dict.

    The learning rate follows a cosine over `steps`; `stop_at` ends the run earlier at that
    step (a resumable checkpoint; also how the shipped weights, cut short by a time cap, are
    reproduced exactly). `loss_tonemap` picks the loss's tone map (loss.TONEMAPS); `arch` the
    network's model.model_from_arch description (a resumed checkpoint's own architecture wins).
    `schedule_start` > 0 is a warm restart: the warm-up and cosine begin again at that step
    (a resumed checkpoint's step) and end at `steps`, so a finished run can train longer.
    `ssim_weight` is the training loss's SSIM weight; the validation loss keeps the default
    (loss.W_SSIM) so that runs with other weights stay comparable."""
    device = "cuda" if torch.cuda.is_available() else "cpu"
    torch.manual_seed(seed)
    torch.backends.cudnn.benchmark = True  # fixed crop size: let cuDNN pick its fastest kernels
    ckpt_path = Path(out_dir) / "checkpoint.pt"
    ckpt = torch.load(ckpt_path, map_location=device) if ckpt_path.exists() else None
    if ckpt is not None:  # checkpoints before "arch" was stored are the first shipped network's
        arch = ckpt.get("arch", {"encoder": (16, 32, 48, 64), "bottleneck": 80, "transform": "log1p"})
    model = model_from_arch(arch or {}).to(device).to(memory_format=torch.channels_last)
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    step, seconds_before = 0, 0.0
    resumed_at = None
    gen = torch.Generator().manual_seed(seed)
    if ckpt is not None:
        model.load_state_dict(ckpt["model"])
        opt.load_state_dict(ckpt["optimizer"])
        step, seconds_before = ckpt["step"], ckpt.get("seconds", 0.0)
        gen.set_state(ckpt["generator"].cpu())  # map_location moved it; the generator lives on the CPU
        resumed_at = step
        log(f"train: resumed at step {step}")
    examples = Examples(train_paths, device)
    val = Examples(val_paths, device) if val_paths else None
    amp = torch.autocast(device_type="cuda", dtype=torch.bfloat16) if device == "cuda" else torch.autocast("cpu", enabled=False)
    start = time.perf_counter()

    def save():
        torch.save({"model": model.state_dict(), "arch": model.arch, "optimizer": opt.state_dict(), "step": step,
                    "seconds": seconds_before + time.perf_counter() - start, "generator": gen.get_state()}, ckpt_path)

    losses = []
    while step < min(steps, stop_at or steps):
        if minutes is not None and time.perf_counter() - start > 60 * minutes:
            log(f"train: time cap of {minutes} min reached at step {step}")
            break
        for group in opt.param_groups:
            group["lr"] = lr_at(step - schedule_start, steps - schedule_start, lr)
        x, div, tgt = examples.batch(gen, batch, crop)
        with amp:
            pred = model(x.contiguous(memory_format=torch.channels_last))
        loss = denoise_loss(pred.float() * div, tgt, loss_tonemap, ssim_weight)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()) if step % 50 == 0 else None)
        step += 1
        if step % 500 == 0 or step == steps:
            vl = validation_loss(model, val, amp, loss_tonemap) if val is not None else float("nan")
            recent = [v for v in losses[-500:] if v is not None] or [float("nan")]
            log(f"train: step {step}/{steps}, loss {np.mean(recent):.4f}, "
                f"val loss {vl:.4f}, {time.perf_counter() - start:.0f} s")
            save()
    save()
    return {"steps": step, "resumed_at": resumed_at, "seconds": seconds_before + time.perf_counter() - start,
            "device": device,
            "train_scenes": len(examples), "val_scenes": len(val) if val is not None else 0, "model": model}


@torch.no_grad()
def validation_loss(model, val: Examples, amp, loss_tonemap: str = "log", levels=(0, 2, 4)) -> float:
    """Mean loss on whole validation images at 1, 4 and 16 spp (scenes never trained on)."""
    model.eval()
    total = []
    for i in range(len(val)):
        for lvl in levels:
            e = val.exposure[i, lvl]
            x = torch.cat([val.noisy[i, lvl].float() * e, val.guides[i].float()])[None]
            div = val.divisor[i].float()[None]
            with amp:
                pred = model(x.contiguous(memory_format=torch.channels_last))
            total.append(float(denoise_loss(pred.float() * div, val.target[i].float()[None] * e * div,
                                             loss_tonemap)))
    model.train()
    return float(np.mean(total))
