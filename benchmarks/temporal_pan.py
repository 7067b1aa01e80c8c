"""Temporal reprojection against accumulation reset, on a scripted camera pan over
scenes/cornell.toml (results in docs/temporal.md).

    python benchmarks/temporal_pan.py [--size 64] [--frames 16] [--step 0.025] [--ref-spp 384]
                                      [--cache DIR] [--out FILE.json] [--figure FILE.png]

The camera (and its target) moves --step scene units to the right each frame, and each
frame adds one sample per pixel (the viewer's case). For every frame it reports the relMSE
and SSIM of the image shown against a converged still render from that frame's camera
(--ref-spp samples, cached in --cache), for:
  reset      accumulation restarts when the camera moves (lift-gl's behaviour before); a
             restart also restarts the frame sequence, so every frame has the same noise
             pattern on screen (reset_reseeded: a new seed each frame, independent noise);
  reproject  temporal="reproject", min_blend 0.1 (the default) and 0.2;
  clamp      reproject with the neighbourhood clamp at 1 sigma (BIASED);
and the mean absolute frame-to-frame change of each output (temporal stability), beside
that of the references (the change the motion itself makes).

A second part measures ghosting: a red emissive ball moves across an emissive wall (the
scene of tests/test_temporal.py) and the largest share of the ball's colour left in the
pixels it has left is printed per frame, for each min_blend, with and without the clamp.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import sys
from pathlib import Path

import numpy as np

from lift_gl import load_scene
from lift_gl.gl.context import create_context, describe
from lift_gl.metrics import rel_mse, ssim
from lift_gl.frame_settings import TemporalSettings
from lift_gl.renderer import Renderer

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = {"reset": dict(temporal="reset"),
            "reset_reseeded": dict(temporal="reset", reseed=True),
            "reproject": dict(temporal=TemporalSettings("reproject", min_blend=0.1)),
            "reproject_b0.2": dict(temporal=TemporalSettings("reproject", min_blend=0.2)),
            "clamp": dict(temporal=TemporalSettings("reproject", min_blend=0.1, clamp_sigma=1.0))}


def pan_camera(camera, frame: int, step: float):
    shift = np.array([frame * step, 0.0, 0.0])
    return dataclasses.replace(camera, position=camera.position + shift, target=camera.target + shift)


def references(scene, size, frames, step, spp, cache: Path | None, ctx, seed: int = 1000) -> list[np.ndarray]:
    """Still renders from each frame's camera, frame f with seed `seed` + f."""
    refs = []
    tag = "" if seed == 1000 else f"_s{seed}"  # the default's cache files keep their names
    for f in range(frames):
        file = None if cache is None else cache / f"cornell_{size}_{step}_{f}_{spp}{tag}.npy"
        if file is not None and file.is_file():
            refs.append(np.load(file))
            continue
        r = Renderer(dataclasses.replace(scene, camera=pan_camera(scene.camera, f, step)), size=(size, size),
                     seed=seed + f, ctx=ctx)
        refs.append(r.render(spp=spp))
        r.release()
        if file is not None:
            file.parent.mkdir(parents=True, exist_ok=True)
            np.save(file, refs[-1])
        print(f"reference {f}: {spp} spp", file=sys.stderr)
    return refs


def run_pan(scene, size, frames, step, settings, ctx, spp: int = 1, seed: int = 7) -> list[np.ndarray]:
    """The images shown along the pan, `spp` samples a frame; settings: Renderer keywords,
    plus reseed (a new seed at every reset)."""
    settings = dict(settings)
    reseed = settings.pop("reseed", False)
    r = Renderer(scene, size=(size, size), seed=seed, ctx=ctx, **settings)
    images = []
    for f in range(frames):
        if f:
            r.set_camera(pan_camera(scene.camera, f, step))
            if reseed:  # a reset restarts the frame sequence: the same noise each frame unless reseeded
                r.reset(seed=seed + f)
        images.append(r.render(spp=spp))
    r.release()
    return images


def figure(scene, size, frames, step, runs, reference, ctx, out: Path) -> None:
    """One row: the last pan frame with reset, with reprojection, the reference, then the
    reprojecting renderer's history, rejection, variance and irradiance views."""
    from lift_gl.app.aov_view import aov_to_display
    from lift_gl.image_io import write_srgb8
    from lift_gl.tonemap import to_srgb8

    r = Renderer(scene, size=(size, size), seed=7, ctx=ctx, temporal="reproject")
    for f in range(frames):
        if f:
            r.set_camera(pan_camera(scene.camera, f, step))
        r.render(spp=1)
    tiles = [to_srgb8(runs["reset"][-1]), to_srgb8(runs["reproject"][-1]), to_srgb8(reference)]
    tiles += [aov_to_display(name, r.aov(name)) for name in ("history", "rejection", "variance", "irradiance")]
    r.release()
    gap = np.full((size, 2, 3), 255, np.uint8)
    write_srgb8(out, np.concatenate([x for t in tiles for x in (t, gap)][:-1], axis=1))


def mean_change(images) -> float:
    return float(np.mean([np.abs(b - a).mean() for a, b in zip(images, images[1:])]))


def ghosting(steps: int = 12) -> dict:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_temporal import _dilate, occluder_scene  # the ghosting test's scene and masks

    scene = occluder_scene()
    out = {}
    for name, settings in {"min_blend 0.1": dict(min_blend=0.1), "min_blend 0.2": dict(min_blend=0.2),
                           "min_blend 0.1 + clamp": dict(min_blend=0.1, clamp_sigma=1.0)}.items():
        r = Renderer(scene, size=scene.film_size, seed=3, temporal=TemporalSettings("reproject", **settings))
        r.render(spp=16)
        was_ball = r.image()[..., 0] > 0.6
        interior, ring = [], []
        for step in range(1, steps + 1):
            ball = dataclasses.replace(scene.spheres[0], center=scene.spheres[0].center + [0.25 * step, 0, 0])
            r.update_scene(dataclasses.replace(scene, spheres=[ball]))
            image = r.render(spp=1)
            left = was_ball & ~_dilate(r.aov("depth")[..., 0] < 6.5, 2)
            red = np.clip((image[..., 0] - 0.2) / 0.8, 0, None)
            inner = left & ~_dilate(~was_ball, 1)
            interior.append(float(red[inner].max(initial=0.0)))
            ring.append(float(red[left & ~inner].max(initial=0.0)))
        out[name] = {"interior": interior, "edge": ring}
        r.release()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--frames", type=int, default=16)
    parser.add_argument("--step", type=float, default=0.025)
    parser.add_argument("--ref-spp", type=int, default=384)
    parser.add_argument("--cache", type=Path)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--figure", type=Path, help="PNG: last frame reset | reproject | reference | "
                        "history | rejection | variance | irradiance")
    args = parser.parse_args()

    ctx = create_context()
    scene = load_scene(ROOT / "scenes" / "cornell.toml")
    refs = references(scene, args.size, args.frames, args.step, args.ref_spp, args.cache, ctx)
    runs = {name: run_pan(scene, args.size, args.frames, args.step, settings, ctx) for name, settings in VARIANTS.items()}
    table = []
    for f in range(args.frames):
        row = {"frame": f}
        for name, images in runs.items():
            row[f"relmse_{name}"] = rel_mse(images[f], refs[f])
            row[f"ssim_{name}"] = ssim(images[f], refs[f])
        table.append(row)
    means = {k: float(np.mean([row[k] for row in table[1:]])) for k in table[0] if k != "frame"}
    stability = {name: mean_change(images) for name, images in runs.items()}
    stability["references"] = mean_change(refs)
    ghosts = ghosting()
    if args.figure:
        figure(scene, args.size, args.frames, args.step, runs, refs[-1], ctx, args.figure)

    names = list(VARIANTS)
    print(f"pan: {args.frames} frames, {args.step} scene units a frame, {args.size}x{args.size}, 1 spp a frame; "
          f"references {args.ref_spp} spp")
    print("| frame | " + " | ".join(f"relMSE {n}" for n in names) + " | " + " | ".join(f"SSIM {n}" for n in names) + " |")
    print("|---" * (1 + 2 * len(names)) + "|")
    for row in table:
        print(f"| {row['frame']} | " + " | ".join(f"{row['relmse_' + n]:.4f}" for n in names) + " | "
              + " | ".join(f"{row['ssim_' + n]:.3f}" for n in names) + " |")
    print("| mean (frames 1..) | " + " | ".join(f"{means['relmse_' + n]:.4f}" for n in names) + " | "
          + " | ".join(f"{means['ssim_' + n]:.3f}" for n in names) + " |")
    print("mean |frame-to-frame change| (linear radiance): "
          + ", ".join(f"{k} {v:.4f}" for k, v in stability.items()))
    for name, g in ghosts.items():
        print(f"ghost, {name}: interior " + " ".join(f"{v:.3f}" for v in g["interior"])
              + " | edge " + " ".join(f"{v:.3f}" for v in g["edge"]))
    result = {"machine": f"{platform.node()} {platform.processor() or platform.machine()}, {describe(ctx)}",
              "settings": {k: getattr(args, k) for k in ("size", "frames", "step", "ref_spp")},
              "table": table, "means": means, "stability": stability,
              "ghosting": ghosts}
    if args.out:
        args.out.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
