"""Renders of the imported scenes against their references, for docs/scenes.

    python benchmarks/scene_figures.py render [JOB ...] [--out out/figures]
    python benchmarks/scene_figures.py compare [JOB ...] [--out out/figures]
    python benchmarks/scene_figures.py docs [JOB ...] [--out out/figures] [--docs docs/scenes]

`render` renders each job's scene with `pt` as two independent halves (seeds 1 and 2, half
the samples each) and writes JOB.exr (their mean: the full sample count), JOB_a.exr,
JOB_b.exr and JOB.json (size, spp, seconds, dropped samples, the machine). The two halves
give the noise of the estimate without a reference. One job at a time. With `--chunk N`
the halves advance N spp at a time and the files are rewritten after each round; `--until
HH:MM` (UTC) stops there, and JOB.json records the spp reached.

`compare` reads those files and, where the job has a reference, prints and writes to
JOB_metrics.json: SSIM of the tone-mapped images (ACES, sRGB 8-bit, as `render --out
x.png` writes them) and SSIM on sRGB-clipped linear values (lift_gl.metrics.ssim, the
Mitsuba refs' convention), both also after box-downsampling by 4; relMSE against the
reference and the noise part of it (from the two halves), with a z score of the difference
(is the relMSE inside the noise band?); the mean brightness ratio.
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

# name: (scene file, size, spp, reference or None[, pt parameters])
JOBS = {
    "dining-room": ("scenes_lift/dining-room/scene.pbrt", (320, 180), 1024, "refs/lift/dining-room.exr"),
    "bitterli-cornell-box": ("scenes_bitterli/cornell-box/scene.xml", (256, 256), 1024, "refs/bitterli/cornell-box.exr"),
    "veach-mis": ("scenes_bitterli/veach-mis/scene.xml", (256, 144), 1024, "refs/bitterli/veach-mis.exr"),
    # The XML asks for maxDepth 5 (4 bounces); Tungsten's reference matches direct light only.
    "veach-mis-direct": ("scenes_bitterli/veach-mis/scene.xml", (256, 144), 256, "refs/bitterli/veach-mis.exr",
                         {"max_depth": 1}),
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


def render(name: str, out: Path, shared: Path, spp: int | None = None, chunk: int | None = None,
           deadline: float | None = None) -> None:
    """Both halves side by side, `chunk` spp at a time each, the files rewritten after every
    round: on a shared machine a long render then leaves a usable result whenever it ends.
    `deadline` (a time.time() value) ends it early, with the spp reached recorded."""
    from lift_gl import load_scene
    from lift_gl.image_io import write_image
    from lift_gl.renderer import Renderer

    scene_file, size, job_spp = JOBS[name][:3]
    params = JOBS[name][4] if len(JOBS[name]) > 4 else None
    spp = spp or job_spp
    chunk = chunk or spp // 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(shared / scene_file)
    renderers = [Renderer(scene, size=size, seed=seed, params=params) for seed in (1, 2)]
    desc = machine(renderers[0].ctx)
    seconds, done = 0.0, 0
    while done < spp // 2 and (deadline is None or time.time() < deadline):
        n = min(chunk, spp // 2 - done)
        halves = []
        for r in renderers:
            start = time.perf_counter()
            halves.append(r.render(spp=n))
            seconds += time.perf_counter() - start
        done += n
        write_image(out / f"{name}_a.exr", halves[0])
        write_image(out / f"{name}_b.exr", halves[1])
        write_image(out / f"{name}.exr", 0.5 * (halves[0] + halves[1]))
        info = {"scene": scene_file, "params": params, "size": size, "spp": 2 * done, "spp_asked": spp,
                "seconds": seconds,
                "dropped_samples": sum(r.stats.dropped_samples for r in renderers), "machine": desc}
        (out / f"{name}.json").write_text(json.dumps(info, indent=2))
        print(f"{name}: {2 * done} of {spp} spp, {seconds:.0f} s", flush=True)
    for r in renderers:
        r.release()
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

    _, size, _, ref_file = JOBS[name][:4]
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
        weight = 1.0 / (ref ** 2 + metrics.REL_MSE_EPS)
        noise = (a - b) ** 2 / 4 * weight
        result["rel_mse_noise"] = float(noise.mean())
        result["rel_mse_bias_estimate"] = result["rel_mse"] - result["rel_mse_noise"]
        # Per pixel, (x - ref)^2 - (a - b)^2 / 4 has expectation bias^2 (plus the reference's
        # own noise): zero for an unbiased render of the same scene. Pixels are independent,
        # so their spread gives the standard error of its mean: z within about +-3 means the
        # relMSE is inside the noise band the render's own halves predict.
        excess = ((image - ref) ** 2 * weight - noise).mean(axis=-1).ravel()
        result["rel_mse_excess_z"] = float(excess.mean() / (excess.std(ddof=1) / np.sqrt(excess.size)))
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


def _deadline(until: str | None) -> float | None:
    """HH:MM (UTC, today) as a time.time() value."""
    if until is None:
        return None
    import datetime
    hours, minutes = (int(v) for v in until.split(":"))
    now = datetime.datetime.now(datetime.timezone.utc)
    return now.replace(hour=hours, minute=minutes, second=0, microsecond=0).timestamp()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=("render", "compare", "docs"))
    parser.add_argument("jobs", nargs="*", help=f"default: all ({', '.join(JOBS)})")
    parser.add_argument("--out", type=Path, default=Path("out/figures"))
    parser.add_argument("--shared", type=Path, default=SHARED)
    parser.add_argument("--spp", type=int, help="render: samples per pixel instead of the job's own")
    parser.add_argument("--chunk", type=int, help="render: spp per half between two writes of the files")
    parser.add_argument("--until", help="render: stop at this UTC time (HH:MM), keeping the spp reached")
    parser.add_argument("--docs", type=Path, default=Path("docs/scenes"), help="docs: where the small PNGs go")
    parser.add_argument("--max-width", type=int, default=660, help="docs: widest PNG, in pixels")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.jobs or list(JOBS):
        if name not in JOBS:
            parser.error(f"unknown job {name!r}; choose from {', '.join(JOBS)}")
        if args.command == "render":
            render(name, args.out, args.shared, args.spp, args.chunk, _deadline(args.until))
        elif args.command == "compare":
            compare(name, args.out, args.shared)
        else:
            docs_image(name, args.out, args.docs, args.max_width)


if __name__ == "__main__":
    main()
