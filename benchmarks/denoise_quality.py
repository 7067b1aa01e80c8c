"""Denoiser quality: SSIM, relMSE and mean/ref (the image's mean over the reference's: the
energy a denoiser keeps) against converged references, for the noisy input and
each denoiser, at 1, 4 and 16 spp, on the denoiser's validation scenes (never trained on) and
on Lift's cornell-box and dining-room.

Two steps, so that the rendering can run on a GPU machine and the denoising on any CPU:

    # render inputs (noisy at 1/4/16 spp, albedo, normal) and references into npz files
    python benchmarks/denoise_quality.py render --out eval/ [--ref-spp 8192] [--backend egl]
    # denoise and tabulate; a denoiser name is looked up in lift_gl.denoise.get_denoiser
    # (the registry), else the built-ins here: onnx (lift_gl.denoise.onnx_denoiser), oidn (pyoidn);
    # onnx:PATH and glsl:PATH run another model file, a column of its own (benchmarks/denoiser_spec.py)
    python benchmarks/denoise_quality.py evaluate eval/*.npz --denoisers onnx,oidn,atrous,onnx:model_rt.onnx \
        [--out benchmarks/results/denoise_quality.md] [--images DIR]
    # --out FILE.md writes the tables there and every row (scene, sampling, spp, method, ssim,
    # relmse, mean_ratio, mean_split: the bright pixels' and the rest's) to FILE.json

Each npz holds, per scene NAME: NAME/noisy1, noisy4, noisy16, albedo, normal, depth (G-buffer),
reference (float16); albedoN / normalN, where present, are level N's own guides
(mitsuba_denoise_inputs.py: Mitsuba 3's renders as the input). Denoisers get color, albedo, normal and depth (no variance: the inputs
are single snapshots). `add-depth FILES` adds the depth guide to files made before it was stored.

The goal line checks that at 4 spp the ONNX model's SSIM is within 0.01 of OIDN's on every
validation scene.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import denoiser_spec  # noqa: E402
from temporal_error import BRIGHT_OVER_MEAN, mean_ratio, mean_split  # noqa: E402

SPP = (1, 4, 16)
SHARED = Path(__file__).resolve().parents[2] / "shared" / "scenes_lift"
SHARED_SCENES = ("cornell-box", "dining-room")


# ---- denoisers -------------------------------------------------------------------------------

class PyOidnDenoiser:
    """Intel Open Image Denoise through pyoidn (the `oidn` extra): RT filter, HDR, high quality,
    with the noise-free G-buffer albedo and normal (clean_aux)."""

    name = "oidn"

    def denoise(self, color, albedo, normal, depth=None, variance=None):
        import pyoidn
        f32 = lambda a: np.ascontiguousarray(np.asarray(a, dtype=np.float32))
        return pyoidn.denoise(f32(np.maximum(np.nan_to_num(color), 0)), f32(np.clip(albedo, 0, 1)),
                              f32(np.clip(normal, -1, 1)), hdr=True, clean_aux=True, quality="high")


def get_denoiser(spec: str):
    """The denoiser a name stands for (benchmarks/denoiser_spec.py: onnx:PATH and glsl:PATH for
    another model file, *N for a self-ensemble of N mirror images): lift_gl.denoise.get_denoiser's
    where it has one, else the built-ins of this benchmark (oidn through pyoidn directly)."""
    name, options = denoiser_spec.parse(spec)
    try:
        from lift_gl.denoise import get_denoiser as registry
    except ImportError:
        registry = None
    if registry is not None:
        try:
            found = registry(name, **options)
            return found() if isinstance(found, type) else found
        except Exception:  # not registered there (whatever error the registry raises): the built-ins
            pass
    if name == "onnx":
        from lift_gl.denoise.onnx_denoiser import OnnxDenoiser
        return OnnxDenoiser(**options)
    if name == "oidn":
        return PyOidnDenoiser()
    raise SystemExit(f"unknown denoiser {spec!r} (no lift_gl.denoise.get_denoiser entry and no built-in)")


# ---- rendering the inputs ---------------------------------------------------------------------

def guide_key(kind: str, spp: int) -> str:
    """The npz kind of level `spp`'s own guide ("albedo" or "normal"), where a file has one:
    kindSPP (mitsuba_denoise_inputs.py); otherwise every level uses the scene's `kind`."""
    return f"{kind}{spp}"


def noisy_key(spp: int, sampling: str = "independent") -> str:
    """The npz kind of a noisy input: noisySPP[_SAMPLING] (render_data.sampling_suffix)."""
    from lift_gl.denoise.train.render_data import sampling_suffix
    return f"noisy{spp}{sampling_suffix(sampling)}"


def render_set(scenes: dict, out: Path, size_of, ref_spp: int, backend: str, seed: int = 7,
               samplings=("independent",)):
    """Render every scene's inputs (for each of `samplings`) and reference into one npz
    (float16), keys NAME/KIND."""
    from lift_gl.denoise.train.render_data import render_views
    from lift_gl.gl.context import create_context
    ctx = create_context(backend)
    arrays = {}
    for name, scene in scenes.items():
        t = time.perf_counter()
        for k, sampling in enumerate(samplings):  # the reference once, with the first
            noisy, albedo, normal, reference, dropped = render_views(scene, size_of(scene), SPP,
                                                                     ref_spp if k == 0 else 0, seed, ctx,
                                                                     sampling=sampling)
            ref = reference if k == 0 else ref
            for spp, img in zip(SPP, noisy):
                arrays[f"{name}/{noisy_key(spp, sampling)}"] = img
        arrays.update({f"{name}/albedo": albedo, f"{name}/normal": normal, f"{name}/reference": ref,
                       f"{name}/depth": depth_guide(scene, size_of(scene), ctx)})
        print(f"rendered {name} {size_of(scene)} ({ref_spp} spp reference, {dropped} samples dropped) "
              f"in {time.perf_counter() - t:.1f} s", flush=True)
    f16 = {k: np.clip(np.nan_to_num(v), -60000, 60000).astype(np.float16) for k, v in arrays.items()}
    np.savez_compressed(out, **f16)


def depth_guide(scene, size, ctx) -> np.ndarray:
    """The G-buffer's depth (H, W) for denoisers that use it (the à-trous filter's edge stop)."""
    from lift_gl.renderer import Renderer
    r = Renderer(scene, size=size, integrator="pt", ctx=ctx)
    try:
        return r.aov("depth")[..., 0]
    finally:
        r.release()


def scene_of(name: str, shared_dir: Path):
    """The scene an npz entry was rendered from: valK (validation seed K) or a shared scene's name."""
    from lift_gl.denoise.train.scenes import VALIDATION_SEEDS, random_scene
    from lift_gl.scene.loader import load_scene
    if name.startswith("val") and name[3:].isdigit():
        return random_scene(VALIDATION_SEEDS[0] + int(name[3:]))
    return load_scene(shared_dir / name / "scene.pbrt")


def add_depth(args) -> None:
    """Add the depth guide to npz files rendered before it was stored (a raster pass: cheap anywhere)."""
    from lift_gl.gl.context import create_context
    ctx = create_context(args.backend)
    for path in args.inputs:
        with np.load(path) as data:
            arrays = {k: data[k] for k in data.files}
        for name in sorted({k.split("/")[0] for k in arrays}):
            if f"{name}/depth" in arrays:
                continue
            h, w = arrays[f"{name}/reference"].shape[:2]
            arrays[f"{name}/depth"] = depth_guide(scene_of(name, args.shared_dir), (w, h), ctx).astype(np.float16)
            print(f"{path}: depth of {name} ({w}x{h})", flush=True)
        np.savez_compressed(path, **arrays)


def render(args) -> None:
    from lift_gl.denoise.train.scenes import VALIDATION_SEEDS
    args.out.mkdir(parents=True, exist_ok=True)
    val = {f"val{k}": scene_of(f"val{k}", args.shared_dir) for k in range(len(VALIDATION_SEEDS[: args.val_scenes]))}
    square = lambda s: (args.size, args.size)
    names = list(val)
    for part in range(0, len(names), args.per_file):  # files of a few scenes: each under 16 MiB
        subset = {n: val[n] for n in names[part: part + args.per_file]}
        render_set(subset, args.out / f"val_{part // args.per_file}.npz", square, args.ref_spp, args.backend,
                   samplings=args.samplings)
    for name in args.shared:
        path = args.shared_dir / name / "scene.pbrt"
        if not path.is_file():
            print(f"skipped {name}: {path} is absent")
            continue
        scene = scene_of(name, args.shared_dir)
        scaled = lambda s: tuple(max(16, int(round(v * args.shared_scale))) for v in s.film_size)
        render_set({name: scene}, args.out / f"{name}.npz", scaled, args.ref_spp, args.backend,
                   samplings=args.samplings)


# ---- evaluating -------------------------------------------------------------------------------

def load_sets(paths) -> dict:
    scenes = {}
    for p in paths:
        with np.load(p) as data:
            for key in data.files:
                name, kind = key.split("/")
                scenes.setdefault(name, {})[kind] = data[key].astype(np.float32)
    return scenes


def samplings_in(kinds) -> list[str]:
    """The samplings whose noisy inputs a scene's npz kinds hold, independent first."""
    first = noisy_key(SPP[0])
    found = {k.partition("_")[2] or "independent" for k in kinds if k == first or k.startswith(first + "_")}
    return sorted(found, key=lambda x: (x != "independent", x))


def evaluate(args) -> None:
    from lift_gl.denoise.train.render_data import sampling_suffix
    from lift_gl.metrics import rel_mse, ssim
    scenes = load_sets(args.inputs)
    denoisers = {denoiser_spec.label(n): get_denoiser(n) for n in args.denoisers.split(",") if n}
    rows, seconds = [], {n: [] for n in denoisers}
    for name, s in scenes.items():
        ref = s["reference"]
        for sampling in samplings_in(s):
            for spp in SPP:
                noisy = s[noisy_key(spp, sampling)]
                results = {"noisy": noisy}
                for dname, d in denoisers.items():
                    t = time.perf_counter()
                    albedo, normal = (s.get(guide_key(k, spp), s[k]) for k in ("albedo", "normal"))
                    results[dname] = d.denoise(noisy, albedo, normal, depth=s.get("depth"))
                    seconds[dname].append(time.perf_counter() - t)
                for method, img in results.items():
                    rows.append({"scene": name, "sampling": sampling, "spp": spp, "method": method,
                                 "ssim": ssim(img, ref), "relmse": rel_mse(img, ref),
                                 "mean_ratio": mean_ratio(img, ref), "mean_split": mean_split(img, ref)})
                if args.images:
                    save_strip(args.images / f"{name}_{spp}spp{sampling_suffix(sampling)}.png",
                               [results[m] for m in results] + [ref])
    text = table(rows, list(denoisers), scenes)
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
        args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1) + "\n")


def table(rows, denoisers, scenes) -> str:
    methods = ["noisy"] + denoisers
    get = {(r["scene"], r.get("sampling", "independent"), r["spp"], r["method"]): r for r in rows}
    head = "| scene | size | sampling | spp | " + " | ".join(f"{m} SSIM | {m} relMSE | {m} mean/ref"
                                                          for m in methods) + " |"
    lines = ["Denoiser quality against converged references (SSIM on sRGB clipped to [0, 1]; relMSE on linear RGB; "
             "mean/ref: the image's mean over the reference's, the energy kept)",
             "", head, "|" + " --- |" * (4 + 3 * len(methods))]
    for name, s in scenes.items():
        h, w = s["reference"].shape[:2]
        for sampling in samplings_in(s):
            for spp in SPP:
                cells = [f"{g['ssim']:.4f} | {g['relmse']:.4f} | {g.get('mean_ratio', float('nan')):.3f}"
                         for g in (get[(name, sampling, spp, m)] for m in methods)]
                lines.append(f"| {name} | {w}x{h} | {sampling} | {spp} | " + " | ".join(cells) + " |")
    samplings = sorted({r.get("sampling", "independent") for r in rows}, key=lambda x: (x != "independent", x))
    vals = [n for n in scenes if n.startswith("val")]
    if vals and (len(samplings) > 1 or len(denoisers) > 1):  # means over the validation scenes, per sampling and spp
        lines += ["", f"Means over the {len(vals)} validation scenes (SSIM / relMSE / mean/ref):", "",
                  "| sampling | spp | " + " | ".join(methods) + " |", "|" + " --- |" * (2 + len(methods))]
        for sampling in samplings:
            for spp in SPP:
                cells = []
                for m in methods:
                    got = [get[(n, sampling, spp, m)] for n in vals if (n, sampling, spp, m) in get]
                    cells.append(f"{np.mean([g['ssim'] for g in got]):.4f} / {np.mean([g['relmse'] for g in got]):.4f}"
                                 f" / {np.mean([g.get('mean_ratio', np.nan) for g in got]):.3f}" if got else "-")
                lines.append(f"| {sampling} | {spp} | " + " | ".join(cells) + " |")
    split = [n for n in scenes
             if (n, "independent", 4, "noisy") in get and get[(n, "independent", 4, "noisy")].get("mean_split", {}).get("bright")]
    if split:  # scenes with lights seen directly: the energy kept there and elsewhere
        lines += ["", f"Where the mean goes, 4 spp: mean/ref on the bright pixels (reference above {BRIGHT_OVER_MEAN:g}x "
                      "its mean luminance) / on the rest:", "",
                  "| scene | bright pixels | their share of the energy | " + " | ".join(methods) + " |",
                  "|" + " --- |" * (3 + len(methods))]
        for name in split:
            noisy = get[(name, "independent", 4, "noisy")]["mean_split"]
            cells = [f"{g['mean_split']['bright']:.3f} / {g['mean_split']['rest']:.3f}"
                     for g in (get[(name, "independent", 4, m)] for m in methods)]
            lines.append(f"| {name} | {noisy['bright_pixels']:.2%} | {noisy['bright_energy']:.0%} | " + " | ".join(cells) + " |")
    goal_scenes = vals or [n for n in scenes if (n, "independent", 4, "noisy") in get]  # or every scene given
    which = "validation scene" if vals else "scene"
    for onnx in [d for d in denoisers if d.startswith("onnx")] if "oidn" in denoisers else []:
        gaps = {n: get[(n, "independent", 4, onnx)]["ssim"] - get[(n, "independent", 4, "oidn")]["ssim"] for n in goal_scenes}
        worst = min(gaps.values()) if gaps else float("nan")
        met = bool(gaps) and all(g >= -0.01 for g in gaps.values())
        lines += ["", f"Goal (4 spp, every {which}: SSIM({onnx}) >= SSIM(oidn) - 0.01): "
                      f"{'met' if met else 'NOT met'}; worst SSIM({onnx}) - SSIM(oidn) = {worst:+.4f}",
                  "per scene: " + ", ".join(f"{n} {g:+.4f}" for n, g in gaps.items())]
    return "\n".join(lines) + "\n"


def save_strip(path: Path, images) -> None:
    from PIL import Image
    from lift_gl.tonemap import srgb_encode
    path.parent.mkdir(parents=True, exist_ok=True)
    strip = np.concatenate([np.clip(srgb_encode(np.clip(i, 0, None)), 0, 1) for i in images], axis=1)
    Image.fromarray((strip * 255 + 0.5).astype(np.uint8)).save(path)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("render")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--val-scenes", type=int, default=8)
    r.add_argument("--per-file", type=int, default=4)
    r.add_argument("--size", type=int, default=256)
    r.add_argument("--shared", nargs="*", default=list(SHARED_SCENES))
    r.add_argument("--shared-dir", type=Path, default=SHARED)
    r.add_argument("--shared-scale", type=float, default=0.5, help="of the scene file's film size")
    r.add_argument("--ref-spp", type=int, default=8192)
    r.add_argument("--backend", default="auto")
    r.add_argument("--samplings", type=lambda v: tuple(v.split(",")), default=("independent",),
                   help="the noisy inputs' samplings (lift_gl.denoise.train.render_data.SAMPLINGS), each rendered")
    e = sub.add_parser("evaluate")
    e.add_argument("inputs", nargs="+", type=Path)
    e.add_argument("--denoisers", default="onnx,oidn",
                   help="comma-separated names (atrous, onnx, glsl, oidn; onnx:PATH / glsl:PATH for another model)")
    e.add_argument("--out", type=Path)
    e.add_argument("--images", type=Path, help="write noisy | denoisers | reference strips here")
    g = sub.add_parser("add-depth", help="add the depth guide to npz files that lack it")
    g.add_argument("inputs", nargs="+", type=Path)
    g.add_argument("--shared-dir", type=Path, default=SHARED)
    g.add_argument("--backend", default="auto")
    a = p.parse_args(argv)
    {"render": render, "evaluate": evaluate, "add-depth": add_depth}[a.cmd](a)


if __name__ == "__main__":
    main()
