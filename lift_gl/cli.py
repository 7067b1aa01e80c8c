"""The `lift-gl` command (also `python -m lift_gl`)."""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from . import arg_types, options, scaffold, warptest
from .app.command import add_parser as add_view_parser
from .denoise import DENOISER_CHOICES
from .errors import LiftError
from .lab import add_parser as add_lab_parser
from .report import bench, compare
from .grade import command as grade_command

GBUFFER_AOVS = ("albedo", "normal", "depth")  # as lift_gl.renderer (not imported here: it loads GL)


_size = arg_types.size  # the other commands' parsers import it from here


def _settings(pairs: list[str], integrator: str) -> dict:
    """--set NAME=VALUE (or PLUGIN.NAME=VALUE): plugin parameters as strings."""
    values = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise LiftError(f"--set expects NAME=VALUE, got {pair!r}")
        name, value = pair.split("=", 1)
        if "." in name:
            plugin, name = name.split(".", 1)
            if plugin not in (integrator, Path(integrator).name):  # a name, or a plugin folder's
                continue  # a setting for another integrator (as in compare runs)
        values[name.strip()] = value.strip()
    return values


def _add_render(sub):
    p = sub.add_parser("render", help="render a scene headless to an image file")
    p.add_argument("scene")
    p.add_argument("--integrator", default="pt")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--spp", type=arg_types.positive_int, help="samples per pixel (default 64)")
    budget.add_argument("--time", type=arg_types.positive, dest="seconds", help="render for this many seconds instead")
    p.add_argument("--size", type=_size, help="WxH (default: the scene's film size)")
    p.add_argument("--seed", type=arg_types.seed, default=0)
    p.add_argument("--denoise", choices=("off", "final", "every"), default="off",
                   help="denoise the final image, or every frame (the output is then biased; default off)")
    p.add_argument("--denoiser", choices=DENOISER_CHOICES, default="auto",
                   help="auto (default): the trained network for the final image (onnxruntime), for every frame "
                        "in GLSL on a GPU or the à-trous filter on a CPU rasterizer; atrous: GLSL edge-avoiding "
                        "à-trous; onnx: the trained network; glsl: the network in GLSL; oidn: Intel Open Image "
                        "Denoise (pip install 'lift-gl[oidn]')")
    p.add_argument("--noisy-out", metavar="FILE", help="with --denoise: also write the noisy mean here")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="plugin parameter")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    p.add_argument("--aov", choices=("albedo", "normal", "depth", "history", "rejection", "variance", "irradiance"),
                   help="write this G-buffer channel, or view of the accumulation (after rendering), instead")
    p.add_argument("--exposure", type=arg_types.finite, default=0.0, help="stops, for PNG output")
    p.add_argument("--tonemap", default="aces", choices=("aces", "reinhard", "clamp"), help="for PNG output")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR", help="more plugin folders")
    p.add_argument("--all-features", action="store_true",
                   help="compile every shader feature, not only those the scene uses (for comparisons)")
    p.add_argument("--explain", action="store_true",
                   help="print the passes, compiled features and options' choices, and why")
    options.add_option_argument(p)
    p.add_argument("--out", help="output file: .png (sRGB), .exr .pfm .npy (linear float32); with "
                   "--camera-path a folder (frame_0000.png, ...) or a pattern such as pan_{frame:04d}.png")
    seq = p.add_argument_group("image sequences (docs/temporal.md)")
    seq.add_argument("--camera-path", help="a camera path file (TOML keyframes): render a sequence along it")
    seq.add_argument("--frames", type=arg_types.positive_int, help="frames of the sequence (default 24); --spp is per frame (default 4)")
    seq.add_argument("--temporal", choices=("reproject", "reset"), default=None,
                     help="when the camera or an object moves: reproject the accumulation (default with "
                          "--camera-path) or restart it")
    seq.add_argument("--min-blend", type=arg_types.positive, default=None,
                     help="least weight of a moving frame in the reprojected average (default 0.1)")
    seq.add_argument("--clamp-sigma", type=arg_types.non_negative, default=0.0,
                     help="clamp the reprojected history to the frame's neighbourhood, +- this many "
                          "standard deviations (BIASED; default 0: off)")
    p.set_defaults(func=cmd_render)


def cmd_render(args) -> int:
    from .frame_settings import DenoiseSettings, TemporalSettings
    from .image_checks import check_render
    from .image_io import write_image, write_srgb8
    from .render_record import write_render_record
    from .renderer import Renderer
    from .scene.features import SceneFeatures
    from .scene.loader import load_scene

    if args.out is None and not args.explain:
        raise LiftError("render needs --out FILE (or --explain)")
    if args.noisy_out and args.denoise == "off":
        raise LiftError("--noisy-out needs --denoise final or every")
    if args.frames is not None and args.camera_path is None:
        raise LiftError("--frames needs --camera-path FILE")
    _check_render_outputs(args)
    scene = load_scene(args.scene)
    path = None
    if args.camera_path is not None:
        from .camera_path import load_camera_path

        path = load_camera_path(args.camera_path)
        path.check_objects(scene)
        scene = path.scene_at(path.keyframes[0].time, scene)
    temporal = args.temporal or ("reproject" if path is not None else "reset")
    if temporal != "reproject" and (args.min_blend is not None or args.clamp_sigma):
        raise LiftError("--min-blend and --clamp-sigma need --temporal reproject (or --camera-path)")
    if args.min_blend is not None and not 0 < args.min_blend <= 1:
        raise LiftError(f"--min-blend must be in (0, 1], not {args.min_blend}")
    if not args.clamp_sigma >= 0:
        raise LiftError(f"--clamp-sigma must be >= 0, not {args.clamp_sigma}")
    extra = {} if args.min_blend is None else {"min_blend": args.min_blend}
    renderer = Renderer(scene, size=args.size, integrator=args.integrator, backend=args.backend, seed=args.seed,
                        params=_settings(args.set, args.integrator), plugin_dirs=args.plugins,
                        features=SceneFeatures.everything() if args.all_features else None,
                        temporal=TemporalSettings(temporal, clamp_sigma=args.clamp_sigma, **extra),
                        denoise=DenoiseSettings(args.denoise, args.denoiser), options=options.from_args(args))
    if args.explain:
        print(renderer.explain())
        if args.out is None:
            return 0
    if path is not None:
        return _render_sequence(renderer, scene, path, args)
    if args.aov and args.aov not in GBUFFER_AOVS:
        renderer.render(spp=args.spp or 64, seconds=args.seconds)
        _write_aov(args.out, renderer, args.aov, args.exposure)
        print(f"wrote {args.out} ({args.aov})")
        return 0
    if args.aov:
        image = renderer.aov(args.aov)
        write_image(args.out, image, exposure=args.exposure, tonemap="clamp")
        print(f"wrote {args.out} ({args.aov})")
        return 0
    spp = None if args.seconds is not None else (args.spp or 64)
    progress = _progress_bar(spp, args.seconds)
    image = renderer.render(spp=spp, seconds=args.seconds, progress=progress)
    if progress is not None:
        progress.close()
    renderer.estimate_error()  # from the half-buffers: no reference needed
    if args.out.lower().endswith(".png"):
        write_srgb8(args.out, renderer.display(args.exposure, args.tonemap))
    else:
        write_image(args.out, image)
    if args.noisy_out:
        if args.noisy_out.lower().endswith(".png"):
            write_srgb8(args.noisy_out, renderer.display(args.exposure, args.tonemap, source="noisy"))
        else:
            write_image(args.noisy_out, renderer.noisy_image())
    warnings = check_render(renderer, image)
    write_render_record(renderer, args.scene, args.out, warnings)
    print(f"{args.out}: {renderer.size[0]}x{renderer.size[1]}, {args.integrator}, {renderer.stats.summary()}")
    for warning in warnings:
        print(f"lift-gl: warning: {args.out}: {warning}", file=sys.stderr)
    return 0


def _check_render_outputs(args) -> None:
    """--out and --noisy-out can be written (checked before the scene is loaded)."""
    from .image_io import FORMATS

    if args.out is not None:
        out = _frame_file(args.out, 0) if args.camera_path is not None else args.out
        arg_types.check_output_file(out, "--out", FORMATS)
    if args.noisy_out:
        arg_types.check_output_file(args.noisy_out, "--noisy-out", FORMATS)


def _write_aov(out, renderer, name: str, exposure: float) -> None:
    from .image_io import write_image, write_srgb8

    data = renderer.aov(name)
    if str(out).lower().endswith(".png") and name not in GBUFFER_AOVS:
        from .app.aov_view import aov_to_display  # the viewer's colours: counts and masks made visible

        write_srgb8(out, aov_to_display(name, data))
    else:
        write_image(out, data, exposure=exposure, tonemap="clamp")


def _frame_file(out: str, index: int) -> Path:
    """--out of a sequence: a pattern with {frame}, or a folder that gets frame_0000.png, ..."""
    if "{frame" in out:
        try:
            return Path(out.format(frame=index))
        except (KeyError, IndexError, ValueError) as exc:
            raise LiftError(f"--out pattern {out!r} is not valid: {exc}") from None
    folder = Path(out)
    if folder.suffix:
        raise LiftError(f"--out {out!r}: a sequence needs a folder or a pattern with {{frame}}, "
                        "e.g. frames/ or pan_{frame:04d}.png")
    return folder / f"frame_{index:04d}.png"


def _render_sequence(renderer, scene, path, args) -> int:
    """Follow the camera path: one image per frame, the accumulation reprojected (or reset)
    between frames; --spp samples per pixel are added at each frame."""
    from .image_checks import check_image
    from .image_io import write_image, write_srgb8

    frames = 24 if args.frames is None else args.frames
    if frames < 1:
        raise LiftError(f"--frames must be at least 1, not {frames}")
    spp = None if args.seconds is not None else (args.spp or 4)
    for index, time in enumerate(path.times(frames)):
        if index:
            moved = path.scene_at(time, scene)
            if path.moves:
                renderer.update_scene(moved)
            renderer.set_camera(moved.camera)
        image = renderer.render(spp=spp, seconds=args.seconds)
        out = _frame_file(args.out, index)
        out.parent.mkdir(parents=True, exist_ok=True)
        if args.aov:
            _write_aov(out, renderer, args.aov, args.exposure)
        elif out.suffix.lower() == ".png":
            write_srgb8(out, renderer.display(args.exposure, args.tonemap))
        else:
            write_image(out, image)
        print(f"{out}: t={time:g}, {renderer.stats.summary()}"
              + (f", {renderer.stats.reprojected} reprojected frames" if renderer.reproject is not None else ""))
        for warning in check_image(image, renderer.stats):
            print(f"lift-gl: warning: {out}: {warning}", file=sys.stderr)
    return 0


def _progress_bar(spp, seconds):
    """A progress bar on a terminal only; None elsewhere (no per-frame sync in batch runs)."""
    if not sys.stderr.isatty():
        return None
    from .progress import RenderProgress

    return RenderProgress(spp=spp, seconds=seconds)


def _add_plugins(sub):
    p = sub.add_parser("plugins", help="list the integrator plugins and their parameters")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR")
    p.set_defaults(func=cmd_plugins)


def cmd_plugins(args) -> int:
    from .plugins import discover

    broken = {}
    for name, plugin in sorted(discover(args.plugins, broken).items()):
        print(f"{name}  [{plugin.language}, primary={plugin.primary}]  {plugin.folder}")
        if plugin.description:
            print(f"    {plugin.description}")
        if plugin.biased:
            print(f"    BIASED: {plugin.biased}")
        for p in plugin.params.values():
            bounds = "" if p.min is None and p.max is None else f" in [{p.min}, {p.max}]"
            compiled = f", compile-time {p.define}" if p.define else ""  # a new value recompiles
            print(f"    --set {name}.{p.name}=...  ({p.type}, default {p.default}{bounds}{compiled}) {p.help}")
    for folder, error in sorted(broken.items()):
        print(f"{folder}  [broken] {error}")
    return 0


def main(argv=None) -> int:
    parser = arg_types.OneLineErrorParser(prog="lift-gl", description="lift-gl: a hybrid raster + ray-tracing "
                                     "renderer for teaching and studying light transport")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_render(sub)
    _add_plugins(sub)
    add_view_parser(sub)
    scaffold.add_parser(sub)
    compare.add_parser(sub)
    bench.add_parser(sub)
    warptest.add_parser(sub)
    grade_command.add_parser(sub)
    add_lab_parser(sub)
    args = parser.parse_args(argv)
    formatwarning = warnings.formatwarning
    warnings.formatwarning = _one_line_warning
    try:
        return args.func(args)
    except LiftError as exc:
        print(f"lift-gl: error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"lift-gl: error: {exc.filename}: file not found", file=sys.stderr)
        return 2
    except OSError as exc:  # a disk that is full, a folder that went read-only while rendering
        print(f"lift-gl: error: {exc.filename or ''}{': ' if exc.filename else ''}{exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C: the files being written were removed (lift_gl/atomic.py)
        print("lift-gl: interrupted", file=sys.stderr)
        return 130
    finally:
        warnings.formatwarning = formatwarning


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A warning as `lift-gl: warning: FILE:LINE: message` (the message names the user's file),
    without the Python file and source line that warnings.warn prints by default."""
    return "lift-gl: warning: " + " ".join(str(message).split()) + "\n"


if __name__ == "__main__":
    sys.exit(main())
