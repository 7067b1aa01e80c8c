"""PT against BDPT at equal time on a scene where light is hard to reach.

    python benchmarks/equal_time.py reference SCENE --minutes 30 [--seed 1001] [--size 128] [--out out/NAME]
    python benchmarks/equal_time.py compare SCENE --seconds 30 [--size 128] [--out out/NAME] [--ref EXR]

SCENE is a name from SCENES below (covered_dragon: the Lift paper's Covered Dragon,
scenes/covered_dragon.toml; veach_bidir: Veach's bidirectional room from ../shared) or the
path of any scene file; NAME is the scene's name (or the file's stem). --size is the width;
the height follows the scene's aspect ratio.

`reference` renders a long BDPT image as two independent halves (seeds S and S + 1, one
after the other in slices, each saved as it goes), so that the reference's own noise can be
measured: for the mean of the halves, relMSE noise = mean((a - b)^2 / (ref^2 + eps)) / 4.
Run it in the background; `compare` uses whatever it has saved so far. Runs with other seeds
add to the same reference: the halves of every run are pooled, weighted by their samples.

`compare` renders with pt and with bdpt for the same wall time (slices of about one second
taken in turn, so that both see the same load on a shared machine), then reports each
image's relMSE against the reference (raw, and less the reference's own noise), the samples
per pixel each reached, and writes the two images side by side as a PNG. The reference is
BDPT's, so `compare` also reports how PT's image mean sits against it (PT is unbiased too).
With --ref, it also reports both against an independent renderer's image (resized to ours).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.image_io import write_image, write_srgb8
from lift_gl.metrics import REL_MSE_EPS, rel_mse, resize_to
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
SCENES = {"covered_dragon": REPO / "scenes" / "covered_dragon.toml",
          "veach_bidir": REPO.parent / "shared" / "scenes_bitterli" / "veach-bidir" / "scene.xml"}


def scene_path(name: str) -> Path:
    path = SCENES.get(name, Path(name))
    if not path.is_file():
        raise SystemExit(f"{path}: no such scene file" + ("" if name in SCENES else f" (known names: {', '.join(SCENES)})"))
    return path


def scene_name(name: str) -> str:
    return name if name in SCENES else Path(name).parent.name if Path(name).stem == "scene" else Path(name).stem


def image_size(scene, width: int) -> tuple[int, int]:
    """width x the height of the film's aspect ratio in the scene file."""
    w, h = scene.film_size
    return width, max(1, round(width * h / w))


def machine(renderer) -> str:
    return f"{platform.node()} ({os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}), {describe(renderer.ctx)}"


def save_npy(path: Path, image) -> None:
    tmp = path.with_suffix(".tmp.npy")
    np.save(tmp, image)
    tmp.replace(path)  # readers never see half a file


def reference(args) -> None:
    scene = load_scene(scene_path(args.scene))
    size = image_size(scene, args.size)
    halves = [Renderer(scene, size=size, integrator="bdpt", seed=args.seed + k) for k in range(2)]
    tag = f"reference_s{args.seed}"
    end = time.perf_counter() + 60 * args.minutes
    while time.perf_counter() < end:
        images = [r.render(spp=args.chunk) for r in halves]
        for k, image in enumerate(images):
            save_npy(args.out / f"{tag}_half{k}.npy", image)
        info = {"integrator": "bdpt", "size": args.size, "seeds": [args.seed, args.seed + 1],
                "spp_per_half": halves[0].stats.spp, "seconds": [r.stats.render_seconds for r in halves],
                "machine": machine(halves[0]),
                "dropped": [(r.stats.dropped_samples, r.stats.dropped_splats) for r in halves]}
        (args.out / f"{tag}.json").write_text(json.dumps(info, indent=1))
        print(f"{tag}: {info['spp_per_half']} spp per half", flush=True)


def load_halves(out: Path):
    """The reference's two independent halves (every run's, pooled by samples) and what they
    are made of."""
    runs = [json.loads(path.read_text()) for path in sorted(out.glob("reference_s*.json"))]
    if not runs:
        raise SystemExit(f"no reference in {out}: run the reference command first")
    weights = np.array([run["spp_per_half"] for run in runs], np.float64)
    halves = []
    for k in range(2):
        parts = [np.load(out / f"reference_s{run['seeds'][0]}_half{k}.npy").astype(np.float64) for run in runs]
        halves.append(sum(w * part for w, part in zip(weights, parts)) / weights.sum())
    return halves[0], halves[1], {"spp": int(2 * weights.sum()), "runs": runs}


def load_reference(out: Path):
    """The pooled reference, its own relMSE noise, and what it is made of."""
    a, b, info = load_halves(out)
    ref = (a + b) / 2
    noise = float(np.mean((a - b) ** 2 / (ref ** 2 + REL_MSE_EPS)) / 4)
    return ref, noise, info


def compare(args) -> None:
    path = scene_path(args.scene)
    ref, ref_noise, ref_info = load_reference(args.out)
    scene = load_scene(path)
    size = image_size(scene, args.size)
    if ref.shape[:2] != size[::-1]:
        raise SystemExit(f"the reference is {ref.shape[1]}x{ref.shape[0]}; run compare with --size {ref.shape[1]}")
    external = None
    if args.ref is not None:
        from lift_gl.image_io import read_image
        external = resize_to(read_image(args.ref), size).astype(np.float64)
    renderers = {name: Renderer(scene, size=size, integrator=name, seed=args.seed) for name in ("pt", "bdpt")}
    for r in renderers.values():
        r.render(spp=1)  # compile and warm up, then start from zero
        r.reset()
    while min(r.stats.render_seconds for r in renderers.values()) < args.seconds:
        for r in renderers.values():
            if r.stats.render_seconds < args.seconds:
                r.render(seconds=min(args.slice, args.seconds - r.stats.render_seconds))
    rows = {}
    for name, r in renderers.items():
        image = r.image().astype(np.float64)
        raw = rel_mse(image, ref)
        rows[name] = {"spp": r.stats.spp, "seconds": round(r.stats.render_seconds, 2), "rel_mse": raw,
                      "rel_mse_less_reference_noise": raw - ref_noise,
                      "mean_over_reference_mean": float(image.mean() / ref.mean()),
                      **({"rel_mse_vs_external": rel_mse(image, external)} if external is not None else {}),
                      "dropped_samples": r.stats.dropped_samples, "dropped_splats": r.stats.dropped_splats}
        write_image(args.out / f"{name}_{args.seconds:g}s.exr", image.astype(np.float32))
        print(f"{name:5s} {r.stats.spp:5d} spp in {r.stats.render_seconds:6.1f} s  relMSE {raw:.4f} "
              f"(less the reference's noise {raw - ref_noise:.4f})  mean / reference mean "
              f"{rows[name]['mean_over_reference_mean']:.3f}", flush=True)
    ratio = rows["pt"]["rel_mse_less_reference_noise"] / rows["bdpt"]["rel_mse_less_reference_noise"]
    print(f"relMSE pt / bdpt at equal time: {ratio:.1f}  (reference: bdpt, {ref_info['spp']} spp, "
          f"its own relMSE noise {ref_noise:.5f})")
    side_by_side = np.concatenate([renderers["pt"].display(), np.full((size[1], 4, 3), 255, np.uint8),
                                   renderers["bdpt"].display()], axis=1)
    write_srgb8(args.out / f"pt_vs_bdpt_{args.seconds:g}s.png", side_by_side)
    if external is not None:
        print(f"against {args.ref}: relMSE pt {rows['pt']['rel_mse_vs_external']:.4f}, "
              f"bdpt {rows['bdpt']['rel_mse_vs_external']:.4f}, our reference {rel_mse(ref, external):.4f}")
    shown = str(path.relative_to(REPO)) if path.is_relative_to(REPO) else f"../{path.relative_to(REPO.parent)}"
    result = {"machine": machine(renderers["pt"]), "scene": shown, "size": list(size),
              "seconds_each": args.seconds, "reference": ref_info, "reference_rel_mse_noise": ref_noise,
              "rows": rows, "rel_mse_ratio_pt_over_bdpt": ratio,
              **({"external_reference": str(args.ref), "reference_rel_mse_vs_external": rel_mse(ref, external)}
                 if external is not None else {})}
    (args.out / f"compare_{args.seconds:g}s.json").write_text(json.dumps(result, indent=1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    for name in ("reference", "compare"):
        p = sub.add_parser(name)
        p.add_argument("scene", help=f"one of {', '.join(SCENES)}, or a scene file")
        p.add_argument("--size", type=int, default=128, help="image width")
        p.add_argument("--out", type=Path, help="default: out/NAME")
    sub.choices["reference"].add_argument("--minutes", type=float, default=30.0)
    sub.choices["reference"].add_argument("--chunk", type=int, default=8, help="spp per half between saves")
    sub.choices["reference"].add_argument("--seed", type=int, default=1001, help="the halves use seed and seed + 1")
    sub.choices["compare"].add_argument("--seconds", type=float, default=30.0)
    sub.choices["compare"].add_argument("--slice", type=float, default=1.0, help="seconds each takes in turn")
    sub.choices["compare"].add_argument("--seed", type=int, default=7)
    sub.choices["compare"].add_argument("--ref", type=Path, help="an independent reference image (EXR)")
    args = parser.parse_args()
    args.out = args.out or REPO / "out" / scene_name(args.scene)
    args.out.mkdir(parents=True, exist_ok=True)
    (reference if args.command == "reference" else compare)(args)


if __name__ == "__main__":
    main()
