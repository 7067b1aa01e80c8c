"""Temporal error of the denoisers along moving-camera sequences, run as the viewer runs them:
Renderer(..., temporal="reproject", denoise="every"), --spp samples a frame,
render(final=False) each frame, so a denoiser that keeps state between frames (a temporal
network) is measured as it runs. --final renders each frame as a script's render() does instead
(the denoiser run again on guides through the pixel centres), to tell the two apart.

    python benchmarks/denoise_temporal.py [--sequences cornell,val0,lift-cornell-box] [--size 96]
        [--frames 16] [--spp 1] [--ref-spp 256] [--denoisers atrous,onnx,glsl,oidn] [--backend auto]
        [--cache DIR] [--out FILE.json] [--markdown FILE.md] [--figures DIR] [--figure-frames 4]
        [--final]

Sequences (the camera moves every frame; converged references are still renders from each
frame's camera, --ref-spp samples, seed 1000 + frame, cached in --cache):
  cornell           scenes/cornell.toml, a pan to the right (--pan of the camera's distance
                    to its target a frame; 0.004 is 0.027 scene units, about 1 pixel at 96 px);
  val0              the denoiser's first validation scene (lift_gl/denoise/train/scenes.py,
                    never trained on), the same pan;
  lift-cornell-box  Lift's scene (cornell-box/scene.pbrt in --shared-dir, ../shared/scenes_lift
                    or shared/scenes_lift; skipped when absent), an orbit about the target,
                    --orbit degrees a frame.
Denoisers: names as benchmarks/denoiser_spec.py reads them (onnx:PATH, glsl:PATH for another
model); "noisy" (no denoiser, the reprojected mean) always comes first. glsl runs on any GL
device (on llvmpipe about 0.15 s a frame at 96x96, seconds at 720p). oidn is skipped when pyoidn
is absent.

Per sequence and denoiser (benchmarks/temporal_error.py), per frame and averaged:
  change            mean |out_f - out_f-1| (linear radiance, over pixels and channels);
  reference change  the same of the references;
  difference        change - reference change: the change the motion does not explain;
  relMSE, mean/ref  of each frame against its reference.
--figures writes DIR/denoise_temporal_SEQUENCE.png: rows noisy, each denoiser, reference;
columns --figure-frames frames spread over the sequence (first to last), in a palette of
--figure-colours.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

import denoiser_spec  # noqa: E402
from temporal_error import temporal_error  # noqa: E402

# the shared Lift scenes: beside the checkout (a worktree) or inside it (a copy that carries shared/)
SHARED = next((d for d in (ROOT.parent / "shared" / "scenes_lift", ROOT / "shared" / "scenes_lift") if d.is_dir()),
              ROOT.parent / "shared" / "scenes_lift")
SEQUENCES = ("cornell", "val0", "lift-cornell-box")


# ---- the sequences ----------------------------------------------------------------------------

def panned(camera, frame: int, fraction: float):
    """The camera moved right (its own right vector) by frame * fraction of its distance to the target."""
    forward = camera.target - camera.position
    right = np.cross(forward, camera.up)
    shift = right / np.linalg.norm(right) * (frame * fraction * np.linalg.norm(forward))
    return dataclasses.replace(camera, position=camera.position + shift, target=camera.target + shift)


def orbited(camera, frame: int, degrees: float):
    """The camera turned about the target by frame * degrees, about the camera's up axis."""
    axis = camera.up / np.linalg.norm(camera.up)
    offset = camera.position - camera.target
    a = math.radians(frame * degrees)
    # Rodrigues' rotation of the offset about the axis
    rotated = (offset * math.cos(a) + np.cross(axis, offset) * math.sin(a)
               + axis * np.dot(axis, offset) * (1 - math.cos(a)))
    return dataclasses.replace(camera, position=camera.target + rotated)


def sequence(name: str, args):
    """(scene, camera_at(frame)) of a sequence, or a reason to skip it (str)."""
    from lift_gl import load_scene
    from lift_gl.denoise.train.scenes import VALIDATION_SEEDS, random_scene

    if name == "cornell":
        scene = load_scene(ROOT / "scenes" / "cornell.toml")
        return scene, lambda f: panned(scene.camera, f, args.pan)
    if name.startswith("val") and name[3:].isdigit():
        scene = random_scene(VALIDATION_SEEDS[0] + int(name[3:]))
        return scene, lambda f: panned(scene.camera, f, args.pan)
    if name == "lift-cornell-box":
        path = args.shared_dir / "cornell-box" / "scene.pbrt"
        if not path.is_file():
            return f"skipped lift-cornell-box: {path} is absent (the shared Lift scenes are not beside this checkout)"
        scene = load_scene(path)
        return scene, lambda f: orbited(scene.camera, f, args.orbit)
    raise SystemExit(f"unknown sequence {name!r}; choose from {', '.join(SEQUENCES)} (valK for validation scene K)")


def motion_tag(name: str, args) -> str:
    return f"orbit{args.orbit}" if name == "lift-cornell-box" else f"pan{args.pan}"


def references(name, scene, camera_at, args, ctx) -> list[np.ndarray]:
    """Still renders from each frame's camera, frame f with seed 1000 + f (cached)."""
    from lift_gl.renderer import Renderer

    refs = []
    for f in range(args.frames):
        file = None if args.cache is None else \
            args.cache / f"{name}_{args.size}_{motion_tag(name, args)}_{f}_{args.ref_spp}.npy"
        if file is not None and file.is_file():
            refs.append(np.load(file))
            continue
        r = Renderer(dataclasses.replace(scene, camera=camera_at(f)), size=(args.size, args.size),
                     seed=1000 + f, ctx=ctx)
        refs.append(r.render(spp=args.ref_spp))
        r.release()
        if file is not None:
            file.parent.mkdir(parents=True, exist_ok=True)
            np.save(file, refs[-1])
    return refs


# ---- the runs ---------------------------------------------------------------------------------

def viewer_run(scene, camera_at, args, ctx, spec: str | None) -> tuple[list[np.ndarray], float]:
    """The frames the viewer shows along the sequence with denoiser `spec` (None: no denoiser),
    and the wall seconds a frame."""
    from lift_gl.frame_settings import DenoiseSettings
    from lift_gl.renderer import Renderer

    denoise = "off"
    if spec is not None:
        name, options = denoiser_spec.parse(spec)
        denoise = DenoiseSettings("every", name, options)
    r = Renderer(scene, size=(args.size, args.size), seed=args.seed, ctx=ctx, temporal="reproject", denoise=denoise)
    frames, start = [], time.perf_counter()
    try:
        for f in range(args.frames):
            if f:
                r.set_camera(camera_at(f))
            # the viewer's frame (final=False): denoised on this frame's jittered guides
            frames.append(r.render(spp=args.spp, final=args.final))
    finally:
        r.release()
    return frames, (time.perf_counter() - start) / args.frames


def usable(specs) -> tuple[list[str], list[str]]:
    """The denoisers that run here, and why the others are skipped."""
    kept, skipped = [], []
    for spec in specs:
        name, _ = denoiser_spec.parse(spec)
        if name == "glsl" and not _has("onnx"):
            skipped.append(f"{spec}: skipped, the glsl denoiser reads the model with the onnx package (pip install onnx)")
        elif name == "oidn" and not _has("pyoidn"):
            skipped.append(f"{spec}: skipped, pyoidn is not installed (pip install 'lift-gl[oidn]')")
        elif name == "onnx" and not _has("onnxruntime"):
            skipped.append(f"{spec}: skipped, onnxruntime is not installed")
        else:
            kept.append(spec)
    return kept, skipped


def _has(module: str) -> bool:
    from importlib.util import find_spec
    return find_spec(module) is not None


# ---- output -----------------------------------------------------------------------------------

def markdown(results: dict, settings: dict, skipped: list[str]) -> str:
    frames = ("render(final=True) each frame (guides through the pixel centres)" if settings.get("final")
              else "the viewer's frames")
    lines = [f"Temporal error, {frames} (temporal reprojection, denoise every frame, {settings['spp']} spp "
             f"a frame), {settings['size']}x{settings['size']}, {settings['frames']} frames; references "
             f"{settings['ref_spp']} spp; {settings['machine']}", ""]
    lines += [f"- {s}" for s in skipped] + ([""] if skipped else [])
    for seq, by_denoiser in results.items():
        if isinstance(by_denoiser, str):
            lines += [f"## {seq}", "", by_denoiser, ""]
            continue
        lines += [f"## {seq} ({by_denoiser['motion']})", "",
                  "| | change | reference change | difference | relMSE | mean/ref | s a frame |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        names = [d for d in by_denoiser if d != "motion"]
        for d in names:
            m, secs = by_denoiser[d]["mean"], by_denoiser[d]["seconds_per_frame"]
            lines.append(f"| {d} | {m['change']:.4f} | {m['reference_change']:.4f} | {m['difference']:+.4f} | "
                         f"{m['relmse']:.4f} | {m['mean_ratio']:.3f} | {secs:.3f} |")
        lines += ["", "Per frame: difference (change - reference change) / relMSE", "",
                  "| frame | " + " | ".join(names) + " |", "|" + " --- |" * (1 + len(names))]
        for f in range(settings["frames"]):
            cells = []
            for d in names:
                p = by_denoiser[d]["per_frame"]
                diff = f"{p['difference'][f - 1]:+.4f}" if f else "-"
                cells.append(f"{diff} / {p['relmse'][f]:.4f}")
            lines.append(f"| {f} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def strip_figure(rows: list[list[np.ndarray]], picks, out: Path, colours: int = 128) -> None:
    """Rows of tiles (a run's frames at `picks`), 2-pixel white gaps, in a palette of `colours`
    (noise compresses badly: the palette keeps the file small for docs/)."""
    from lift_gl.tonemap import to_srgb8

    size = rows[0][0].shape[0]
    gap_v = np.full((size, 2, 3), 255, np.uint8)
    lines = []
    for frames in rows:
        tiles = [to_srgb8(frames[f]) for f in picks]
        lines.append(np.concatenate([x for t in tiles for x in (t, gap_v)][:-1], axis=1))
    gap_h = np.full((2, lines[0].shape[1], 3), 255, np.uint8)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_palette_png(out, np.concatenate([x for line in lines for x in (line, gap_h)][:-1], axis=0), colours)


def save_palette_png(path: Path, srgb8: np.ndarray, colours: int) -> None:
    from PIL import Image

    image = Image.fromarray(srgb8)
    if colours < 256:
        image = image.quantize(colors=colours, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    image.save(path, optimize=True)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sequences", default=",".join(SEQUENCES))
    p.add_argument("--size", type=int, default=96)
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--spp", type=int, default=1, help="samples a frame")
    p.add_argument("--ref-spp", type=int, default=256)
    p.add_argument("--seed", type=int, default=7, help="of the viewer runs (the references' seeds are fixed)")
    p.add_argument("--pan", type=float, default=0.004, help="of the camera's distance to its target, a frame")
    p.add_argument("--orbit", type=float, default=0.5, help="degrees a frame (lift-cornell-box)")
    p.add_argument("--denoisers", default="atrous,onnx,glsl,oidn")
    p.add_argument("--final", action="store_true",
                   help="render(final=True) each frame, as a script's render() ends: denoised on guides through "
                        "the pixel centres, not the viewer's jittered ones")
    p.add_argument("--backend", default="auto")
    p.add_argument("--shared-dir", type=Path, default=SHARED)
    p.add_argument("--cache", type=Path, help="folder for the references")
    p.add_argument("--out", type=Path, help="results JSON")
    p.add_argument("--markdown", type=Path, help="results table")
    p.add_argument("--figures", type=Path, help="folder for the strip figures")
    p.add_argument("--figure-frames", type=int, default=4)
    p.add_argument("--figure-colours", type=int, default=128, help="of the figures' palette (256: full colour)")
    a = p.parse_args(argv)

    from lift_gl.gl.context import create_context, describe

    ctx = create_context(a.backend)
    specs, skipped = usable([s for s in a.denoisers.split(",") if s])
    for reason in skipped:
        print(reason, file=sys.stderr)
    settings = {k: getattr(a, k) for k in ("size", "frames", "spp", "ref_spp", "seed", "pan", "orbit", "final")}
    settings["machine"] = f"{platform.node()} {platform.processor() or platform.machine()}, {describe(ctx)}"
    settings["denoisers"] = specs
    results = {}
    for seq in [s for s in a.sequences.split(",") if s]:
        made = sequence(seq, a)
        if isinstance(made, str):
            print(made, file=sys.stderr)
            results[seq] = made
            continue
        scene, camera_at = made
        t = time.perf_counter()
        refs = references(seq, scene, camera_at, a, ctx)
        print(f"{seq}: references in {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)
        runs = {"noisy": viewer_run(scene, camera_at, a, ctx, None)}
        for spec in specs:
            runs[denoiser_spec.label(spec)] = viewer_run(scene, camera_at, a, ctx, spec)
        results[seq] = {"motion": motion_tag(seq, a)}
        for name, (frames, secs) in runs.items():
            results[seq][name] = dict(temporal_error(frames, refs), seconds_per_frame=secs)
            m = results[seq][name]["mean"]
            print(f"{seq}/{name}: difference {m['difference']:+.4f} (change {m['change']:.4f}, references "
                  f"{m['reference_change']:.4f}), relMSE {m['relmse']:.4f}, mean/ref {m['mean_ratio']:.3f}",
                  file=sys.stderr, flush=True)
        if a.figures:
            picks = np.linspace(0, a.frames - 1, min(a.figure_frames, a.frames)).round().astype(int)
            strip_figure([frames for frames, _ in runs.values()] + [refs], picks,
                         a.figures / f"denoise_temporal_{seq}.png", a.figure_colours)
    text = markdown(results, settings, skipped)
    print(text)
    if a.markdown:
        a.markdown.parent.mkdir(parents=True, exist_ok=True)
        a.markdown.write_text(text)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps({"settings": settings, "skipped": skipped, "results": results}, indent=1) + "\n")


if __name__ == "__main__":
    main()
