"""Denoisers under motion: does denoising the temporally accumulated image
flicker less than denoising a fresh image every frame? Results in docs/denoiser.md, "Under
motion".

    python benchmarks/denoise_motion.py [--size 96] [--frames 16] [--spp 1] [--step 0.025]
        [--ref-spp 256] [--seed 7] [--denoisers none,atrous,onnx,oidn] [--cache DIR] [--out FILE.json]
        [--figure FILE.png] [--reference-noise]

The camera pans over scenes/cornell.toml as in benchmarks/temporal_pan.py (whose pan,
references and runs this reuses): --step scene units to the right a frame, --spp samples a
frame. Each configuration is a temporal mode
  reproject  temporal="reproject" (min_blend 0.1): the history is reprojected and kept;
  reset      accumulation restarts each frame, with a new seed each frame (independent noise:
             with the same seed every frame would show the same noise pattern, a static
             screen-space pattern that hides flicker);
times a denoiser run on every frame's mean (denoise="every"), or none. Per configuration:
  relMSE, SSIM   mean over frames 1.. against a converged still render from each frame's
                 camera (--ref-spp samples; frame 0 is the same in both modes);
  flicker        mean |frame-to-frame change| of the output (linear radiance, mean over
                 pixels and channels) minus that of the references: the change the motion
                 itself does not explain (the references' own noise at --ref-spp adds a little
                 to theirs, so a perfect output would score slightly below 0);
  error change   mean |(out_f+1 - ref_f+1) - (out_f - ref_f)|: how much the error itself
                 moves from frame to frame, whatever the content does; the references' own
                 noise puts a floor under it (--reference-noise measures that floor with a
                 second set of references).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from temporal_pan import mean_change, references, run_pan  # noqa: E402  (the pan and its references)

from lift_gl import load_scene  # noqa: E402
from lift_gl.frame_settings import DenoiseSettings, TemporalSettings  # noqa: E402
from lift_gl.gl.context import create_context, describe  # noqa: E402
from lift_gl.metrics import rel_mse, ssim  # noqa: E402

TEMPORAL = {"reproject": dict(temporal=TemporalSettings("reproject", min_blend=0.1)),
            "reset": dict(temporal="reset", reseed=True)}


def error_change(images, refs) -> float:
    errors = [image - ref for image, ref in zip(images, refs)]
    return float(np.mean([np.abs(b - a).mean() for a, b in zip(errors, errors[1:])]))


def evaluate(images, refs) -> dict:
    frames = range(1, len(images))
    return {"relmse": float(np.mean([rel_mse(images[f], refs[f]) for f in frames])),
            "ssim": float(np.mean([ssim(images[f], refs[f]) for f in frames])),
            "change": mean_change(images),
            "flicker": mean_change(images) - mean_change(refs),
            "error_change": error_change(images, refs)}


def settings_for(temporal: str, denoiser: str) -> dict:
    settings = dict(TEMPORAL[temporal])
    if denoiser != "none":
        options = {"providers": ["CPUExecutionProvider"]} if denoiser == "onnx" else {}
        settings["denoise"] = DenoiseSettings("every", denoiser, options)
    return settings


def markdown(results: dict, denoisers, reference_change: float) -> str:
    lines = ["| denoiser | temporal | relMSE | SSIM | mean frame change | flicker (minus references') | error change |",
             "|---|---|---|---|---|---|---|"]
    for d in denoisers:
        for t in TEMPORAL:
            r = results[f"{t}/{d}"]
            lines.append(f"| {d} | {t} | {r['relmse']:.4f} | {r['ssim']:.3f} | {r['change']:.4f} | "
                         f"{r['flicker']:+.4f} | {r['error_change']:.4f} |")
    lines.append(f"\nreferences' own mean frame change: {reference_change:.4f}")
    return "\n".join(lines)


def figure(runs: dict, refs, denoisers, out: Path) -> None:
    """Rows: reproject and reset; columns: the last frame per denoiser, then the reference."""
    from lift_gl.image_io import write_srgb8
    from lift_gl.tonemap import to_srgb8

    size = refs[-1].shape[0]
    gap = np.full((size, 2, 3), 255, np.uint8)
    rows = []
    for t in TEMPORAL:
        tiles = [to_srgb8(runs[f"{t}/{d}"][-1]) for d in denoisers] + [to_srgb8(refs[-1])]
        rows.append(np.concatenate([x for tile in tiles for x in (tile, gap)][:-1], axis=1))
    write_srgb8(out, np.concatenate([rows[0], np.full((2, rows[0].shape[1], 3), 255, np.uint8), rows[1]], axis=0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=96)
    parser.add_argument("--frames", type=int, default=16)
    parser.add_argument("--spp", type=int, default=1, help="samples a frame")
    parser.add_argument("--step", type=float, default=0.025)
    parser.add_argument("--ref-spp", type=int, default=256)
    parser.add_argument("--seed", type=int, default=7, help="of the pan (the references' seeds are fixed)")
    parser.add_argument("--denoisers", default="none,atrous,onnx,oidn",
                        help="comma-separated: none and names from lift_gl.denoise (oidn skipped if pyoidn is absent)")
    parser.add_argument("--cache", type=Path, help="folder for the references")
    parser.add_argument("--reference-noise", action="store_true",
                        help="also render a second set of references (other seeds) to measure their own noise")
    parser.add_argument("--out", type=Path, help="results JSON")
    parser.add_argument("--figure", type=Path, help="PNG of the last frame of every configuration")
    args = parser.parse_args()

    denoisers = [d.strip() for d in args.denoisers.split(",")]
    if "oidn" in denoisers:
        try:
            import pyoidn  # noqa: F401
        except ImportError:
            print("oidn skipped: pyoidn is not installed (pip install 'lift-gl[oidn]')", file=sys.stderr)
            denoisers.remove("oidn")
    ctx = create_context()
    scene = load_scene(ROOT / "scenes" / "cornell.toml")
    refs = references(scene, args.size, args.frames, args.step, args.ref_spp, args.cache, ctx)
    runs, results = {}, {}
    for d in denoisers:
        for t in TEMPORAL:
            runs[f"{t}/{d}"] = run_pan(scene, args.size, args.frames, args.step, settings_for(t, d), ctx, spp=args.spp,
                                       seed=args.seed)
            results[f"{t}/{d}"] = evaluate(runs[f"{t}/{d}"], refs)
            print(f"{t}/{d}: " + ", ".join(f"{k} {v:.4f}" for k, v in results[f"{t}/{d}"].items()), file=sys.stderr)
    reference_change = mean_change(refs)
    reference_noise = None
    if args.reference_noise:
        # Two independent sets: their difference's error change is sqrt(2) times each one's floor.
        second = references(scene, args.size, args.frames, args.step, args.ref_spp, args.cache, ctx, seed=5000)
        between = error_change(refs, second)
        reference_noise = {"error_change_between_sets": between, "floor_per_set": between / np.sqrt(2),
                           "change_of_the_average": mean_change([(a + b) / 2 for a, b in zip(refs, second)])}
    print(f"pan over scenes/cornell.toml: {args.frames} frames, {args.step} scene units a frame, "
          f"{args.size}x{args.size}, {args.spp} spp a frame, denoise every frame; references {args.ref_spp} spp")
    print(markdown(results, denoisers, reference_change))
    if reference_noise:
        print("references' own noise: " + ", ".join(f"{k} {v:.4f}" for k, v in reference_noise.items()))
    if args.figure:
        figure(runs, refs, denoisers, args.figure)
    if args.out:
        args.out.write_text(json.dumps({
            "machine": f"{platform.node()} {platform.processor() or platform.machine()}, {describe(ctx)}",
            "settings": {k: getattr(args, k) for k in ("size", "frames", "spp", "step", "ref_spp", "seed")},
            "denoisers": denoisers, "results": results, "reference_change": reference_change,
            "reference_noise": reference_noise}, indent=1))


if __name__ == "__main__":
    main()
