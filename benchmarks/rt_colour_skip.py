"""Does the rt model's colour skip (lift_gl/denoise/train/model.py `colour_skip`) keep the colour?
Trainings from one seed on one data set, one for each value in --skips (0: no skip), then the
validation loss and each validation scene's channel means over the reference's at 4 spp
(without history, as a first frame).

    python benchmarks/rt_colour_skip.py --data runs/rt --steps 2000 --out benchmarks/results/rt_colour_skip_cpu.json

--data is a temporal plan's working folder (train/ and val/ of frame pairs:
python -m lift_gl.denoise.train.plan --model rt ...); --crop and --batch keep a CPU run small.
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


def main(argv=None) -> int:
    import torch
    from lift_gl.denoise.train.model import build_model
    from lift_gl.denoise.train.temporal import PairExamples
    from lift_gl.denoise.train.train import Examples, Stage, fit, mean_ratios, validation_loss

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, required=True)
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--skips", default="0,4")
    p.add_argument("--crop", type=int, default=64)
    p.add_argument("--batch", type=int, default=8)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    train = PairExamples(sorted((a.data / "train").glob("*.npz")), "cpu")
    val = Examples(sorted((a.data / "val").glob("*.npz")), "cpu")
    runs = []
    for k in [int(v) for v in a.skips.split(",")]:
        torch.manual_seed(a.seed)
        model = build_model("rt", temporal=True, colour_skip=k)
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            result = fit(model, train, val, [Stage(a.steps, 2e-3, 0.2, 4.0)], Path(tmp) / "c.pt", a.batch, a.crop,
                         a.seed, log=lambda m: None, checkpoint_every=10 ** 9)
            seconds = time.perf_counter() - t0
        means = np.array(mean_ratios(result["model"], val, per_channel=True))
        run = {"colour_skip": k, "steps": a.steps, "seconds": round(seconds, 1),
               "val_loss": round(validation_loss(result["model"], val, torch.autocast("cpu", enabled=False)), 4),
               "channel_mean_ratio_4spp": np.round(means, 3).tolist(),
               "worst_channel_deviation": round(float(np.abs(means - 1).max()), 3)}
        print(json.dumps(run), flush=True)
        runs.append(run)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps({"data": a.data.name, "train_scenes": len(train), "val_scenes": len(val),
                                     "arguments": {k: str(v) for k, v in vars(a).items() if k not in ("data", "out")},
                                     "runs": runs}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
