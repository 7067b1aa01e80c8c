"""Does the denoiser keep the image's mean? Trainings from one seed on one data set, one for each
weight of the mean term (lift_gl/denoise/train/loss.py mean_loss) in --mean-weights (0: the
shipped model's loss, L1 + gradient L1 + SSIM in the log domain), then mean(denoised) /
mean(reference) on the validation scenes (never trained on) at 1, 4 and 16 spp.

    python benchmarks/denoise_mean_kept.py --data runs/rt --steps 3000 --out benchmarks/results/denoise_mean_kept.json

--data is a folder with train/ and val/ of lift_gl.denoise.train's npz examples (the plan's
working folder, or python -m lift_gl.denoise.train's). The arguments after the data (--encoder,
--crop, --batch) let a CPU run stay small.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

LEVELS = {1: 0, 4: 2, 16: 4}  # spp -> index into render_data.SPP_LEVELS


def run(data: Path, steps: int, mean_weight: float, args, log) -> dict:
    import torch
    from lift_gl.denoise.train.model import DenoiseUNet
    from lift_gl.denoise.train.train import Examples, Stage, fit, mean_ratios

    device = "cuda" if torch.cuda.is_available() else "cpu"
    torch.manual_seed(args.seed)
    model = DenoiseUNet(encoder=[int(c) for c in args.encoder.split(",")], bottleneck=args.bottleneck).to(device)
    train = Examples(sorted((data / "train").glob("scene_*.npz")), device)
    val = Examples(sorted((data / "val").glob("scene_*.npz")), device)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = fit(model, train, None, [Stage(steps, args.lr, mean_weight=mean_weight)], Path(tmp) / "ckpt.pt",
                     args.batch, args.crop, args.seed, log=log)
        seconds = time.perf_counter() - t0
    ratios = {spp: mean_ratios(result["model"], val, level) for spp, level in LEVELS.items()}
    return {"mean_weight": mean_weight, "steps": steps, "seconds": round(seconds, 1), "steps_per_s": round(steps / seconds, 2),
            "mean_ratio": {str(spp): [round(r, 4) for r in rs] for spp, rs in ratios.items()},
            "mean_abs_deviation": {str(spp): round(float(np.mean(np.abs(np.array(rs) - 1))), 4)
                                   for spp, rs in ratios.items()}}


def main(argv=None) -> int:
    from lift_gl.denoise.train.loss import W_MEAN
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, required=True)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--mean-weights", default=f"0,{W_MEAN}", help="the mean term's weight of each run (0: the shipped loss)")
    p.add_argument("--encoder", default="32,48,64,80")
    p.add_argument("--bottleneck", type=int, default=80)
    p.add_argument("--crop", type=int, default=128)
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="JSON of both runs")
    a = p.parse_args(argv)
    log = lambda m: print(m, flush=True)
    runs = [run(a.data, a.steps, float(w), a, log) for w in a.mean_weights.split(",")]
    for r in runs:
        log(f"mean weight {r['mean_weight']}: |mean/ref - 1| " + ", ".join(
            f"{spp} spp {d}" for spp, d in r["mean_abs_deviation"].items()) + f"; ratios at 4 spp {r['mean_ratio']['4']}")
    record = {"data": str(a.data), "arguments": {k: str(v) for k, v in vars(a).items() if k not in ("data", "out")},
              "runs": runs}
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(record, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
