"""The training loss, in the manner of OIDN's: L1 plus an image-gradient L1 and an SSIM term,
all on tone-mapped values of the exposed radiance (v around 0.18 for a mid grey).

Tone maps: "log" (the default), log(1 + v/0.01) / log(1 + 1/0.01), is steep in the dark (slope
22 at 0, 1.1 at 0.18) so that errors in dark regions count, as they do in the sRGB SSIM the
denoiser is judged by; it maps 0 to 0 and 1 to 1, so the SSIM term's [0, 1] clamp still applies.
"log1p", log(1 + v), almost linear below 0.2, trained the first 2604 steps of the first model.

An L1 loss estimates the conditional median of the target, and at low spp, where a pixel's
radiance is heavy-tailed (rare bright paths), the median is below the mean: a network trained on
L1 alone darkens (mean 0.69-0.82 of the reference's at 4 spp). `mean_loss` holds the means: a
squared error between box means (MEAN_BLOCKS pixels wide) of the *linear* output and target,
each block's relative to a scale that depends on the input only (the larger of the noisy
input's and the detached output's block mean, plus MEAN_EPS). A squared error with weights that
do not depend on the target is least at the conditional mean, so this term pulls each block's
mean to the reference's mean, not to a median; the relative scale keeps dark blocks counting.
"""
from __future__ import annotations

import math

import torch
from torch.nn import functional as F

W_GRADIENT = 0.5
W_SSIM = 0.2
W_MEAN = 4.0  # mean_loss's weight in the plan's schedule (plan.py); 0 is the shipped model's loss
MEAN_BLOCKS = (8, 16)
MEAN_EPS = 0.01  # exposed radiance: mid grey is 0.18
DARK_EPS = 0.01  # the "log" tone map's toe: below this it turns linear
TONEMAPS = ("log", "log1p")


def tonemap(radiance: torch.Tensor, kind: str = "log") -> torch.Tensor:
    v = torch.clamp(radiance, min=0.0)
    if kind == "log1p":
        return torch.log1p(v)
    if kind == "log":
        return torch.log1p(v / DARK_EPS) / math.log1p(1.0 / DARK_EPS)
    raise ValueError(f"unknown loss tone map {kind!r} (one of {', '.join(TONEMAPS)})")


def ssim(a: torch.Tensor, b: torch.Tensor, window: int = 7) -> torch.Tensor:
    """Mean SSIM with a uniform window (as scikit-image's default), data range 1."""
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    pool = lambda t: F.avg_pool2d(t, window, stride=1)
    mu_a, mu_b = pool(a), pool(b)
    var_a = pool(a * a) - mu_a ** 2
    var_b = pool(b * b) - mu_b ** 2
    cov = pool(a * b) - mu_a * mu_b
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    return s.mean()


def gradient_l1(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    dx = lambda t: t[..., :, 1:] - t[..., :, :-1]
    dy = lambda t: t[..., 1:, :] - t[..., :-1, :]
    return F.l1_loss(dx(a), dx(b)) + F.l1_loss(dy(a), dy(b))


def denoise_loss(pred_radiance: torch.Tensor, target_radiance: torch.Tensor, kind: str = "log",
                 ssim_weight: float = W_SSIM) -> torch.Tensor:
    """L1 + W_GRADIENT x gradient L1 + ssim_weight x (1 - SSIM), on tone-mapped values."""
    p, t = tonemap(pred_radiance, kind), tonemap(target_radiance, kind)
    return (F.l1_loss(p, t) + W_GRADIENT * gradient_l1(p, t)
            + ssim_weight * (1.0 - ssim(torch.clamp(p, 0, 1), torch.clamp(t, 0, 1))))


def mean_loss(pred_radiance: torch.Tensor, target_radiance: torch.Tensor, noisy_radiance: torch.Tensor,
              blocks=MEAN_BLOCKS, eps: float = MEAN_EPS) -> torch.Tensor:
    """Mean over block sizes of ((box mean(pred) - box mean(target)) / scale)^2 with scale =
    max(box mean(noisy), box mean(pred), detached) + eps, on linear exposed radiance
    (N, 3, H, W); block sizes that do not fit are left out."""
    terms = []
    for b in blocks:
        if min(pred_radiance.shape[-2:]) < b:
            continue
        p, t = F.avg_pool2d(pred_radiance, b), F.avg_pool2d(torch.clamp(target_radiance, min=0.0), b)
        scale = torch.maximum(F.avg_pool2d(torch.clamp(noisy_radiance, min=0.0), b), p.detach()) + eps
        terms.append((((p - t) / scale) ** 2).mean())
    if not terms:
        raise ValueError(f"mean_loss: an image of {tuple(pred_radiance.shape[-2:])} holds no block of {blocks}")
    return torch.stack(terms).mean()
