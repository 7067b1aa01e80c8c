"""Train a denoiser from nothing in one resumable command (torch: the `train` extra).

    python -m lift_gl.denoise.train.plan --model rt --out runs/rt --onnx assets/denoiser/lift_rt.onnx \\
        --workers 12 --backend egl --time-budget-s 540

does, in order, what is not done yet in --out: render the validation and training scenes (one
file a scene, kept once written), train through the stages of --schedule (each a warm restart
of the learning rate, the loss's SSIM weight its own; the mean term of loss.py in every stage),
checkpointing as it goes, and export the ONNX model and its sidecar. With --time-budget-s it
stops before the budget is spent, saving the checkpoint, and exits with status 3; the same
command run again continues where it stopped (the checkpoint, OUT/checkpoint.pt, a few MB, is all
that a later session needs besides the command: the scenes render again from their seeds).
OUT/status.json says what is done and what remains; exit status 0 means all is done.

A temporal model (--model rt: the default --temporal) trains on frame pairs with the previous
frame's output reprojected (temporal.py, temporal_data.py); the others on single frames.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .scenes import TRAIN_SEEDS, VALIDATION_SEEDS

# today's four stages of the shipped U-Net (docs/denoiser.md): end step : peak LR : SSIM weight
SCHEDULE = "11000:2e-3:0.2,21000:1e-3:0.2,24000:5e-4:2.0,30000:3e-4:2.0"
EXPORT_RESERVE_S = 30.0  # kept from the budget for the last checkpoint, the export and the record
NOT_DONE = 3  # exit status: stopped by the budget, run the same command again
# a checkpoint's recorded options where it predates them (the models' own defaults)
PLAN_DEFAULTS = {"passthrough": False, "full_res_convs": 1, "chroma_block": 0}


def parse_schedule(text: str, mean_weight: float):
    """Stages from "END:LR:SSIM,..." (ends increasing)."""
    from .train import Stage
    stages = []
    for part in text.split(","):
        try:
            end, lr, ssim = part.split(":")
            stages.append(Stage(int(end), float(lr), float(ssim), mean_weight))
        except ValueError:
            raise SystemExit(f"--schedule: {part!r} is not END:LR:SSIM")
    if any(b.end <= a.end for a, b in zip(stages, stages[1:])) or stages[0].end <= 0:
        raise SystemExit(f"--schedule: the stages' ends must increase from above 0 ({text})")
    return stages


def arguments(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m lift_gl.denoise.train.plan", description=__doc__.splitlines()[0])
    p.add_argument("--model", default="rt", choices=("unet", "rt"),  # model.MODELS (torch loads later)
                   help="the network to train (model.py: unet, the shipped U-Net; rt, the real-time one)")
    p.add_argument("--temporal", action=argparse.BooleanOptionalAction, default=None,
                   help="train with the previous frame's output as an input (default: on for rt)")
    p.add_argument("--out", type=Path, required=True, help="working folder: data, checkpoint, status, record")
    p.add_argument("--onnx", type=Path, default=None, help="the model to write at the end (default OUT/MODEL.onnx)")
    p.add_argument("--init-from", type=Path, default=None,
                   help="start from this model's weights (an ONNX file of the same architecture, e.g. the shipped "
                        "one, to fine-tune it) instead of random ones; ignored once OUT has a checkpoint")
    p.add_argument("--grow", action="store_true",
                   help="--init-from a smaller unet: the new layers start as the identity or zero, so that "
                        "training starts from the file's function")
    p.add_argument("--passthrough", action="store_true",
                   help="a learned share of the input colour in the output (model.py)")
    p.add_argument("--full-res-convs", type=int, default=1, help="unet: convs at full resolution each side")
    p.add_argument("--encoder", type=lambda t: [int(c) for c in t.split(",")], default=None,
                   help="the encoder's channels a level, e.g. 24,32,48 (default: the model's, model.py)")
    p.add_argument("--bottleneck", type=int, default=None, help="the bottleneck's channels (default: the model's)")
    p.add_argument("--time-budget-s", type=float, default=None,
                   help="stop before this many seconds (checkpoint saved, exit status 3); run again to continue")
    p.add_argument("--scenes", type=int, default=400, help="training scenes")
    p.add_argument("--val-scenes", type=int, default=8, help="validation scenes (never trained on)")
    p.add_argument("--size", type=int, default=256, help="image size of each scene (square)")
    p.add_argument("--ref-spp", type=int, default=1024, help="samples per pixel of the targets")
    p.add_argument("--schedule", default=SCHEDULE, help="stages END:LR:SSIM,... (default: the shipped model's)")
    p.add_argument("--mean-weight", type=float, default=None, help="weight of the loss's mean term (default loss.W_MEAN)")
    p.add_argument("--chroma-block", type=int, default=None,
                   help="rt: the block of the chroma correction (model.py; default the model's, 0: none)")
    p.add_argument("--history-drop", type=float, default=0.25,
                   help="temporal: the share of samples trained without history")
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--crop", type=int, default=128)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--stop-at", type=int, default=None, help="stop at this step (resumable, as the budget)")
    p.add_argument("--checkpoint-every", type=int, default=500, help="steps between checkpoints")
    p.add_argument("--backend", default="auto", help="OpenGL backend for rendering (auto|egl|osmesa)")
    p.add_argument("--workers", type=int, default=1, help="rendering processes (one GL context each)")
    a = p.parse_args(argv)
    if a.temporal is None:
        a.temporal = a.model == "rt"
    if a.chroma_block is not None and a.model != "rt":
        p.error("--chroma-block is an option of --model rt")
    if a.model != "unet" and a.full_res_convs != 1:
        p.error("--full-res-convs is an option of --model unet")
    if a.grow and a.init_from is None:
        p.error("--grow grows the model of --init-from: give it")
    if a.crop > a.size:
        p.error(f"--crop {a.crop} is larger than the scenes' --size {a.size}")
    return a


def main(argv=None, clock=time.monotonic) -> int:
    a = arguments(argv)
    start = clock()
    deadline = None if a.time_budget_s is None else start + a.time_budget_s - EXPORT_RESERVE_S
    log = lambda msg: print(msg, flush=True)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    from .loss import W_MEAN
    mean_weight = W_MEAN if a.mean_weight is None else a.mean_weight
    stages = parse_schedule(a.schedule, mean_weight)
    status = {"command": "python -m lift_gl.denoise.train.plan " + " ".join(argv if argv is not None else sys.argv[1:]),
              "done": False, "steps": stages[-1].end}

    def finish(phase: str, remaining: str, code: int) -> int:
        status.update(phase=phase, remaining=remaining, done=code == 0, seconds_this_run=round(clock() - start, 1))
        (out / "status.json").write_text(json.dumps(status, indent=2) + "\n")
        log(f"plan: {phase}; {remaining}")
        return code

    # ---- data ----
    val_seeds, train_seeds = list(VALIDATION_SEEDS[: a.val_scenes]), list(TRAIN_SEEDS[: a.scenes])
    minutes_left = lambda: None if deadline is None else max(0.0, (deadline - clock()) / 60)
    size = (a.size, a.size)
    if a.temporal:
        from .temporal_data import generate_pairs as generate
    else:
        from .render_data import generate
    val_paths = generate(out / "val", val_seeds, size, a.ref_spp, a.backend, log, a.workers, minutes_left())
    train_paths = generate(out / "train", train_seeds, size, a.ref_spp, a.backend, log, a.workers, minutes_left())
    status["data"] = {"val": f"{len(val_paths)}/{len(val_seeds)}", "train": f"{len(train_paths)}/{len(train_seeds)}"}
    if len(val_paths) < len(val_seeds) or len(train_paths) < len(train_seeds):
        if deadline is not None and clock() >= deadline:
            return finish("data", f"{len(train_paths)}/{len(train_seeds)} training scenes rendered: run again", NOT_DONE)
        missing = len(train_seeds) - len(train_paths)  # scenes left out (incomplete renders) or a stop
        log(f"plan: {missing} training scenes missing (see the .failed files); training on the {len(train_paths)} there")

    # ---- training ----
    import torch
    from .model import BOTTLENECK, CHROMA_BLOCK, ENCODER, RT_BOTTLENECK, RT_ENCODER, build_model
    from .train import Examples, fit
    device = "cuda" if torch.cuda.is_available() else "cpu"
    ckpt_path = out / "checkpoint.pt"
    rt = a.model == "rt"
    sizes = {"encoder": list(RT_ENCODER if rt else ENCODER), "bottleneck": RT_BOTTLENECK if rt else BOTTLENECK}
    options = ({"chroma_block": CHROMA_BLOCK if a.chroma_block is None else a.chroma_block}
               if rt else {"full_res_convs": a.full_res_convs})
    options.update(passthrough=a.passthrough, encoder=a.encoder or sizes["encoder"],
                   bottleneck=a.bottleneck or sizes["bottleneck"])
    chosen = {"model": a.model, "temporal": a.temporal, **options}  # what the checkpoint records
    if ckpt_path.exists():
        saved = torch.load(ckpt_path, map_location="cpu").get("plan", {})
        # the chroma correction has no weights: a checkpoint of another would load without an error
        was = {k: saved.get(k, {**PLAN_DEFAULTS, **sizes}.get(k)) for k in chosen}
        if saved and was != chosen:
            show = lambda d: ", ".join(f"{k} {v}" for k, v in d.items())
            raise SystemExit(f"{ckpt_path} trains {show(was)}, not {show(chosen)}: use another --out")
    torch.manual_seed(a.seed)
    torch.backends.cudnn.benchmark = True  # fixed crop size: let cuDNN pick its fastest kernels
    model = build_model(a.model, temporal=a.temporal, **options)
    if a.init_from is not None and not ckpt_path.exists():
        from .export import load_onnx_weights
        load_onnx_weights(model, a.init_from, grow=a.grow)
        log(f"plan: starting from the weights of {a.init_from}")
    model = model.to(device).to(memory_format=torch.channels_last)
    if a.temporal:
        from .temporal import PairExamples as Data
    else:
        Data = Examples
    result = fit(model, Data(train_paths, device), Data(val_paths, device) if val_paths else None, stages, ckpt_path,
                 a.batch, a.crop, a.seed, deadline, a.stop_at, log,
                 checkpoint_extra={"plan": chosen},
                 checkpoint_every=a.checkpoint_every, history_drop=a.history_drop, clock=clock)
    status.update(step=result["steps"], device=result["device"], train_seconds=round(result["seconds"], 1),
                  checkpoint_bytes=ckpt_path.stat().st_size)
    if result["steps"] < stages[-1].end:
        why = result["stopped_by"] or f"--stop-at {a.stop_at}"
        return finish("train", f"stopped by {why} at step {result['steps']} of {stages[-1].end}: run again", NOT_DONE)

    # ---- export ----
    from .export import export
    from .train import mean_ratios
    model = result["model"]
    record = {"command": status["command"], "model": a.model, "temporal": a.temporal,
              "init_from": None if a.init_from is None else a.init_from.name, "train_scenes": len(train_paths),
              "train_seeds": [train_seeds[0], train_seeds[len(train_paths) - 1]],
              "val_seeds": [val_seeds[0], val_seeds[-1]] if val_seeds else [], "size": a.size, "ref_spp": a.ref_spp,
              "spp_levels": [1, 2, 4, 8, 16, 32, 64], "schedule": a.schedule, "mean_weight": mean_weight,
              "batch": a.batch, "crop": a.crop, "seed": a.seed, "steps": result["steps"],
              "train_seconds": round(result["seconds"], 1), "device": result["device"], "arch": model.arch}
    if val_paths:  # mean(output) / mean(reference) at 4 spp; a temporal model's without history
        record["val_mean_ratio_4spp"] = [round(r, 4) for r in mean_ratios(model, Examples(val_paths, device))]
    (out / "record.json").write_text(json.dumps(record, indent=2) + "\n")
    onnx = a.onnx or out / f"lift_{a.model}.onnx"
    export(model, onnx, record)
    status["onnx"] = str(onnx)
    return finish("done", f"exported {onnx} ({onnx.stat().st_size} bytes)", 0)


if __name__ == "__main__":
    sys.exit(main())
