"""Train the denoiser and export it (torch: the `train` extra).

The shipped weights, in two stages on one working folder (the second resumes the first's
checkpoint with a warm restart of the learning-rate schedule):

    python -m lift_gl.denoise.train --out runs/denoiser --workers 10 --backend egl --no-export
    python -m lift_gl.denoise.train --out runs/denoiser --scenes 400 --steps 21000 --schedule-start 11000 \
        --lr 1e-3 --onnx assets/denoiser/lift_unet.onnx --workers 10 --backend egl

It renders the training and validation scenes (resumable: existing files are kept), trains
(resuming from --out/checkpoint.pt, whose architecture then wins over the options), and
exports the ONNX model and its sidecar JSON. The defaults are the settings of the first stage
(docs/denoiser.md; assets/denoiser/train_checkpoint.pt is the second stage's step-21000 state).
All the stages in one command that a time budget stops and a rerun continues, with the loss's
mean term and temporal training: python -m lift_gl.denoise.train.plan (plan.py).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .scenes import TRAIN_SEEDS, VALIDATION_SEEDS


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m lift_gl.denoise.train", description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True, help="working folder: data, checkpoint, log")
    p.add_argument("--onnx", type=Path, default=None, help="where to write the model (default: OUT/lift_unet.onnx)")
    p.add_argument("--scenes", type=int, default=181, help="training scenes")
    p.add_argument("--first-scene", type=int, default=0, help="the first training scene's seed (a later stage "
                   "can train on scenes an earlier one never saw)")
    p.add_argument("--val-scenes", type=int, default=8, help="validation scenes (never trained on)")
    p.add_argument("--size", type=int, default=256, help="image size of each scene (square)")
    p.add_argument("--ref-spp", type=int, default=1024, help="samples per pixel of the targets")
    p.add_argument("--steps", type=int, default=11000)
    p.add_argument("--schedule-start", type=int, default=0,
                   help="warm restart: the LR warm-up and cosine run from this step to --steps "
                        "(resume a finished checkpoint at its step to train it longer)")
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--crop", type=int, default=128)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--backend", default="auto", help="OpenGL backend for rendering (auto|egl|osmesa)")
    p.add_argument("--workers", type=int, default=1,
                   help="rendering processes (one GL context each); with --executor ray, the cluster's workers to start")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="ray: render the data on a Ray cluster's workers (pip install 'lift-gl[cluster]'; docs/cluster.md)")
    p.add_argument("--address", metavar="HOST:PORT", help="the Ray head to join (with --executor ray)")
    p.add_argument("--data-minutes", type=float, default=None,
                   help="stop rendering training scenes after this long (the record says how many were made)")
    p.add_argument("--minutes", type=float, default=None, help="stop training after this long (resumable)")
    p.add_argument("--stop-at", type=int, default=None,
                   help="stop at this step (the schedule still spans --steps; resumable)")
    p.add_argument("--loss-tonemap", default="log", choices=("log", "log1p"),  # loss.TONEMAPS (torch loads later)
                   help="the loss's tone map (lift_gl/denoise/train/loss.py); "
                        "log1p trained the first model's first 2604 steps")
    p.add_argument("--ssim-weight", type=float, default=0.2,  # loss.W_SSIM (torch loads later)
                   help="weight of the loss's 1 - SSIM term (L1 and gradient terms keep theirs)")
    p.add_argument("--encoder", default="32,48,64,80",  # model.ENCODER (torch loads later)
                   help="encoder channels at 1, 1/2, 1/4, 1/8 resolution")
    p.add_argument("--bottleneck", type=int, default=80, help="bottleneck channels at 1/16")
    p.add_argument("--full-res-convs", type=int, default=1, help="3x3 convs at full resolution on each side")
    p.add_argument("--transform", default="log", choices=("log", "log1p"),  # model.TRANSFORMS
                   help="the network's colour transform (lift_gl/denoise/train/model.py)")
    p.add_argument("--samplings", default="independent",
                   help="how the noisy inputs are sampled, the scenes taking these in turn: independent, "
                        "coherent, interleave2 (pt's coherent sampling; render_data.SAMPLINGS)")
    p.add_argument("--no-export", action="store_true")
    a = p.parse_args(argv)
    log = lambda msg: print(msg, flush=True)

    from ...cluster.options import ExecutorSettings
    from .render_data import generate
    executor = ExecutorSettings(a.executor, a.address, workers=a.workers if a.executor == "ray" and a.workers > 1 else None)
    size = (a.size, a.size)
    samplings = tuple(a.samplings.split(","))
    t0 = time.perf_counter()
    val_paths = generate(a.out / "val", VALIDATION_SEEDS[: a.val_scenes], size, a.ref_spp, a.backend, log,
                         a.workers, samplings=samplings, executor=executor)
    train_seeds = list(TRAIN_SEEDS[a.first_scene: a.first_scene + a.scenes])
    train_paths = generate(a.out / "train", train_seeds, size, a.ref_spp, a.backend, log, a.workers,
                           a.data_minutes, samplings=samplings, executor=executor)
    log(f"data: {len(train_paths)} training scenes (seeds {train_seeds[0]}..{train_seeds[len(train_paths) - 1]})")
    data_seconds = time.perf_counter() - t0

    from .train import train
    arch = {"encoder": [int(c) for c in a.encoder.split(",")], "bottleneck": a.bottleneck,
            "transform": a.transform, "full_res_convs": a.full_res_convs}
    result = train(train_paths, val_paths, a.out, a.steps, a.batch, a.crop, a.lr, a.seed, a.minutes, log, a.stop_at,
                   a.loss_tonemap, arch, a.schedule_start, a.ssim_weight)
    model = result.pop("model")
    data_bytes = sum(f.stat().st_size for f in train_paths + val_paths)
    record = {"command": "python -m lift_gl.denoise.train " + " ".join(argv if argv is not None else sys.argv[1:]),
              "train_scenes": result["train_scenes"], "train_seeds": [train_seeds[0], train_seeds[len(train_paths) - 1]],
              "reproduce": f"--first-scene {a.first_scene} --scenes {len(train_paths)} --ref-spp {a.ref_spp} "
                           f"--steps {a.steps}"
                           + (f" --schedule-start {a.schedule_start} --lr {a.lr}" if a.schedule_start else "")
                           + (f" --ssim-weight {a.ssim_weight}" if a.ssim_weight != 0.2 else "")
                           + (f" --samplings {a.samplings}" if a.samplings != "independent" else "")
                           + (f" --stop-at {result['steps']}" if result["steps"] < a.steps else ""),
              "val_scenes": result["val_scenes"],
              "val_seeds": [VALIDATION_SEEDS[0], VALIDATION_SEEDS[a.val_scenes - 1]] if a.val_scenes else [],
              "samplings": list(samplings), "size": a.size, "ref_spp": a.ref_spp, "spp_levels": [1, 2, 4, 8, 16, 32, 64],
              "steps": result["steps"], "loss_tonemap": a.loss_tonemap, "ssim_weight": a.ssim_weight, "batch": a.batch, "crop": a.crop, "lr": a.lr,
              "schedule_start": a.schedule_start, "resumed_at_step": result["resumed_at"],
              "train_seconds": round(result["seconds"], 1), "data_seconds_this_run": round(data_seconds, 1),
              "data_bytes": data_bytes, "device": result["device"], "arch": model.arch}
    (a.out / "record.json").write_text(json.dumps(record, indent=2) + "\n")
    log("record: " + json.dumps(record))
    if not a.no_export:
        from .export import export
        onnx = a.onnx or a.out / "lift_unet.onnx"
        export(model, onnx, record)
        log(f"exported {onnx} ({onnx.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
