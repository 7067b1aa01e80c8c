"""Renders of the imported scenes against their references (issue 4's "must show").

    python benchmarks/scene_figures.py render [JOB ...] [--out out/figures]
    python benchmarks/scene_figures.py compare [JOB ...] [--out out/figures]
    python benchmarks/scene_figures.py docs [JOB ...] [--out out/figures] [--docs docs/scenes]

`render` renders each job's scene with `pt` as two independent halves (seeds 1 and 2, half
the samples each) and writes JOB.exr (their mean: the full sample count), JOB_a.exr,
JOB_b.exr and JOB.json (size, spp, seconds, dropped samples, the machine). The two halves
give the noise of the estimate without a reference. One job at a time.

`compare` reads those files and, where the job has a reference, prints and writes to
JOB_metrics.json: SSIM of the tone-mapped images (ACES, sRGB 8-bit, as `render --out
x.png` writes them) and SSIM on sRGB-clipped linear values (lift_gl.metrics.ssim, the
Mitsuba refs' convention), both also after box-downsampling by 4; relMSE against the
reference and the noise part of it (from the two halves); the mean brightness ratio.
It writes JOB_side_by_side.png (ours | reference) for every job with a reference and
JOB.png for the others.

`docs` copies those PNGs, made small for the repository (a 256-colour palette; wider than
`--max-width` pixels: box-downsampled), to the docs folder.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

# name: (scene file, size, spp, reference or None)
JOBS = {
    "dining-room": ("scenes_lift/dining-room/scene.pbrt", (320, 180), 1024, "refs/lift/dining-room.exr"),
    "bitterli-cornell-box": ("scenes_bitterli/cornell-box/scene.xml", (256, 256), 1024, "refs/bitterli/cornell-box.exr"),
    "veach-mis": ("scenes_bitterli/veach-mis/scene.xml", (256, 144), 1024, "refs/bitterli/veach-mis.exr"),
    "staircase2": ("scenes_bitterli/staircase2/scene.xml", (320, 180), 256, None),
    "living-room": ("scenes_bitterli/living-room/scene.xml", (320, 180), 256, None),
    "classroom": ("scenes_lift/classroom/scene.pbrt", (320, 180), 1024, None),
    # Mitsuba 3's own renders (128x128, thousands of spp) of Mitsuba 3 scenes.
    "mitsuba-cbox": ("refs/mitsuba/cbox/scene.xml", (128, 128), 256, "refs/mitsuba/cbox/reference.npy"),
    "mitsuba-furnace": ("refs/mitsuba/furnace/scene.xml", (128, 128), 256, "refs/mitsuba/furnace/reference.npy"),
    "mitsuba-glossy_mis": ("refs/mitsuba/glossy_mis/scene.xml", (128, 128), 256,
                           "refs/mitsuba/glossy_mis/reference.npy"),
}


def machine(ctx=None) -> str:
    text = f"{platform.node()}, {platform.processor() or platform.machine()}"
    try:
        import os
        text += f", {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}"
    except (OSError, AttributeError):
        pass
    if ctx is not None:
        from lift_gl.gl.context import describe
        text += f", {describe(ctx)}"
    return text


def render(name: str, out: Path, shared: Path, spp: int | None = None) -> None:
    from lift_gl import load_scene
    from lift_gl.image_io import write_image
    from lift_gl.renderer import Renderer

    scene_file, size, job_spp, _ = JOBS[name]
    spp = spp or job_spp
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(shared / scene_file)
    halves, seconds, dropped, desc = [], 0.0, 0, ""
    for seed in (1, 2):
        r = Renderer(scene, size=size, seed=seed)
        desc = machine(r.ctx)
        start = time.perf_counter()

        def progress(renderer, done, seed=seed, start=start):
            if done % 64 == 0:
                print(f"{name}: seed {seed}, {done} spp, {time.perf_counter() - start:.0f} s", flush=True)

        halves.append(r.render(spp=spp // 2, progress=progress))
        seconds += time.perf_counter() - start
        dropped += r.stats.dropped_samples
        r.release()
        print(f"{name}: seed {seed}, {spp // 2} spp done ({seconds:.0f} s so far)", flush=True)
    write_image(out / f"{name}_a.exr", halves[0])
    write_image(out / f"{name}_b.exr", halves[1])
    write_image(out / f"{name}.exr", 0.5 * (halves[0] + halves[1]))
    info = {"scene": scene_file, "size": size, "spp": spp, "seconds": seconds, "dropped_samples": dropped,
            "machine": desc}
    (out / f"{name}.json").write_text(json.dumps(info, indent=2))
    print(json.dumps(info), flush=True)


def _tonemapped(image: np.ndarray) -> np.ndarray:
    from lift_gl.tonemap import to_srgb8
    return to_srgb8(image).astype(np.float64) / 255.0


def _ssim_display(a: np.ndarray, b: np.ndarray) -> float:
    from skimage.metrics import structural_similarity
    return float(structural_similarity(_tonemapped(a), _tonemapped(b), channel_axis=-1, data_range=1.0))


def compare(name: str, out: Path, shared: Path) -> dict | None:
    from PIL import Image

    from lift_gl import metrics
    from lift_gl.image_io import read_image
    from lift_gl.tonemap import to_srgb8

    _, size, _, ref_file = JOBS[name]
    image = read_image(out / f"{name}.exr").astype(np.float64)
    info = json.loads((out / f"{name}.json").read_text()) if (out / f"{name}.json").exists() else {}
    if ref_file is None:
        Image.fromarray(to_srgb8(image)).save(out / f"{name}.png")
        return None
    ref = read_image(shared / ref_file).astype(np.float64)
    factor = ref.shape[1] // size[0]
    ref = metrics.box_downsample(ref[: size[1] * factor, : size[0] * factor], factor)
    result = {"job": name, "size": size, "spp": info.get("spp"), "seconds": info.get("seconds"),
              "machine": info.get("machine"),
              "ssim_tonemapped": _ssim_display(image, ref), "ssim_srgb_clipped": metrics.ssim(image, ref),
              "ssim_tonemapped_downsampled_4": _ssim_display(metrics.box_downsample(image, 4),
                                                             metrics.box_downsample(ref, 4)),
              "rel_mse": metrics.rel_mse(image, ref),
              "mean_ratio": float((image @ LUMINANCE).mean() / (ref @ LUMINANCE).mean())}
    if (out / f"{name}_a.exr").exists():
        a, b = (read_image(out / f"{name}_{k}.exr").astype(np.float64) for k in "ab")
        # The mean of two independent halves: its variance is E[(a - b)^2] / 4.
        result["rel_mse_noise"] = float(np.mean((a - b) ** 2 / (ref ** 2 + metrics.REL_MSE_EPS)) / 4)
        result["rel_mse_bias_estimate"] = result["rel_mse"] - result["rel_mse_noise"]
    side = np.concatenate([to_srgb8(image), np.full((size[1], 4, 3), 255, np.uint8), to_srgb8(ref)], axis=1)
    Image.fromarray(side).save(out / f"{name}_side_by_side.png")
    (out / f"{name}_metrics.json").write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))
    return result


def docs_image(name: str, out: Path, docs: Path, max_width: int) -> Path | None:
    """out/JOB_side_by_side.png (or JOB.png), smaller, as docs/JOB.png."""
    from PIL import Image

    source = next((p for p in (out / f"{name}_side_by_side.png", out / f"{name}.png") if p.exists()), None)
    if source is None:
        return None
    image = Image.open(source).convert("RGB")
    if image.width > max_width:
        factor = -(-image.width // max_width)
        image = image.reduce(factor)
    docs.mkdir(parents=True, exist_ok=True)
    target = docs / f"{name}.png"
    image.quantize(256, method=Image.Quantize.MEDIANCUT).save(target, optimize=True)
    print(f"{target}: {image.width}x{image.height}, {target.stat().st_size // 1024} KiB")
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=("render", "compare", "docs"))
    parser.add_argument("jobs", nargs="*", help=f"default: all ({', '.join(JOBS)})")
    parser.add_argument("--out", type=Path, default=Path("out/figures"))
    parser.add_argument("--shared", type=Path, default=SHARED)
    parser.add_argument("--spp", type=int, help="render: samples per pixel instead of the job's own")
    parser.add_argument("--docs", type=Path, default=Path("docs/scenes"), help="docs: where the small PNGs go")
    parser.add_argument("--max-width", type=int, default=660, help="docs: widest PNG, in pixels")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.jobs or list(JOBS):
        if name not in JOBS:
            parser.error(f"unknown job {name!r}; choose from {', '.join(JOBS)}")
        if args.command == "render":
            render(name, args.out, args.shared, args.spp)
        elif args.command == "compare":
            compare(name, args.out, args.shared)
        else:
            docs_image(name, args.out, args.docs, args.max_width)


if __name__ == "__main__":
    main()
