"""`lift-gl view [SCENE]`: the interactive viewer (moderngl-window + imgui-bundle).

    lift-gl view scenes/cornell.toml
    lift-gl view scenes/furnace.toml --frames 16 --screenshot out/furnace.png   # scripted, then exits

The GUI libraries are imported only when the command runs (`pip install 'lift-gl[viewer]'`).
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..denoise import DENOISER_CHOICES
from ..errors import LiftError
from ..options import add_option_argument
from .aov_view import AOV_VIEWS

DEFAULT_SCENE = Path(__file__).resolve().parent.parent.parent / "scenes" / "cornell.toml"
PANELS = ("settings", "statistics", "denoiser", "help", "edit")


def _panels(text: str) -> tuple:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in PANELS]
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown panel {unknown[0]!r}; choose from {', '.join(PANELS)}")
    return names


def _gamma(text: str):
    if text.lower() == "srgb":
        return None
    value = float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"gamma must be positive or 'srgb', not {text!r}")
    return value


def _prefixed(pairs: list[str], plugin: str | None) -> dict:
    """The --set PLUGIN.NAME=VALUE pairs of one plugin (for the split view's right side)."""
    from ..cli import _settings

    if plugin is None:
        return {}
    return _settings([p for p in pairs if p.split("=", 1)[0].startswith(plugin + ".")], plugin)


def add_parser(subparsers) -> None:
    from ..arg_types import finite, natural_int, non_negative, positive, positive_int, seed
    from ..cli import _size  # here, not at import time: cli imports this module

    p = subparsers.add_parser("view", help="the interactive viewer (needs the 'viewer' extra)",
                              description="Open SCENE in a window: camera navigation, integrator and parameter "
                              "widgets, statistics, AOVs, a split view and a convergence plot. With --frames and "
                              "--screenshot it renders N frames, saves the window and exits (for lab reports and tests).")
    p.add_argument("scene", nargs="?", default=str(DEFAULT_SCENE), help="scene file (default: scenes/cornell.toml)")
    p.add_argument("--integrator", default="pt")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="plugin parameter; PLUGIN.NAME=VALUE for one plugin (the split view's right side takes "
                   "only these)")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR", help="more plugin folders")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--size", type=_size, default=(1280, 720), help="window size WxH (default 1280x720)")
    p.add_argument("--scale", type=positive, help="render resolution / window resolution "
                   "(default 1; 0.25 on a CPU rasterizer such as llvmpipe)")
    p.add_argument("--moving-scale", type=positive, help="extra resolution factor while the camera moves "
                   "(default 1; 0.5 on llvmpipe)")
    p.add_argument("--render-size", type=_size, help="a fixed render resolution WxH, letterboxed in the window")
    p.add_argument("--spp-per-frame", type=positive_int, default=1, help="samples per pixel each frame (default 1)")
    target = p.add_mutually_exclusive_group()
    target.add_argument("--target-spp", type=natural_int, default=0, help="freeze the image at this many spp")
    target.add_argument("--target-time", type=non_negative, default=0.0, help="freeze after this many seconds of rendering")
    p.add_argument("--exposure", type=finite, default=0.0, help="stops")
    p.add_argument("--tonemap", default="aces", choices=("aces", "reinhard", "clamp"))
    p.add_argument("--gamma", type=_gamma, default=None, help="display gamma, or 'srgb' (default)")
    p.add_argument("--aov", choices=AOV_VIEWS, help="show this G-buffer channel or view of the accumulation")
    p.add_argument("--temporal", choices=("reset", "reproject"), default="reset",
                   help="camera moves: restart accumulation (default) or reproject it (docs/temporal.md)")
    p.add_argument("--split", metavar="INTEGRATOR", help="split view: this integrator on the right")
    p.add_argument("--denoise", choices=("off", "final", "every"), default="off",
                   help="denoise every frame, or the final frame (when the image freezes); default off")
    p.add_argument("--denoiser", choices=DENOISER_CHOICES, default="auto",
                   help="auto (default): the network in GLSL on a GPU, the à-trous filter on a CPU rasterizer")
    p.add_argument("--noisy-split", action="store_true",
                   help="with --denoise: show the noisy image left and the denoised one right")
    p.add_argument("--ref", help="reference image: plots the error against render time")
    p.add_argument("--panels", type=_panels, default=("settings", "statistics"),
                   help=f"panels open at start, comma-separated from {', '.join(PANELS)} (default settings,statistics)")
    p.add_argument("--inspector", action="store_true", help="start with the pixel inspector on")
    p.add_argument("--window", choices=("pyglet", "glfw", "headless"), default="pyglet",
                   help="window backend; 'headless' draws offscreen through EGL (no display, no input)")
    p.add_argument("--frames", type=positive_int, help="render this many frames, then exit (scripted run)")
    p.add_argument("--screenshot", help="with --frames: save the window, GUI included, to this PNG "
                   "(and its statistics to the same name with .json)")
    add_option_argument(p)
    p.set_defaults(func=cmd_view)


def cmd_view(args) -> int:
    from ..cli import _settings
    from ..options import from_args

    if args.screenshot is not None and args.frames is None:
        raise LiftError("--screenshot needs --frames N (F12 takes screenshots in an interactive session)")
    if args.frames is not None and args.frames < 1:
        raise LiftError("--frames must be at least 1")
    if args.screenshot is not None and not args.screenshot.lower().endswith(".png"):
        raise LiftError(f"--screenshot writes a PNG: {args.screenshot!r} does not end in .png")
    for name, value in (("--scale", args.scale), ("--moving-scale", args.moving_scale)):
        if value is not None and not 0 < value <= 1:
            raise LiftError(f"{name} must be in (0, 1], not {value}")
    if args.noisy_split and args.denoise == "off":
        raise LiftError("--noisy-split needs --denoise final or every")
    if args.screenshot is not None:
        from ..arg_types import check_output_file

        check_output_file(args.screenshot, "--screenshot", (".png",))
    if not Path(args.scene).is_file():
        raise LiftError("scene file not found", args.scene)
    try:
        from .window import ViewOptions, ViewerWindow
    except ImportError as exc:
        raise LiftError(f"the viewer needs its extra dependencies ({exc.name} is missing): "
                        "pip install 'lift-gl[viewer]'") from None
    options = ViewOptions(
        scene=args.scene, integrator=args.integrator, params=_settings(args.set, args.integrator),
        plugin_dirs=tuple(args.plugins), seed=args.seed, window_size=args.size, window_class=args.window,
        render_scale=args.scale, moving_scale=args.moving_scale, render_size=args.render_size,
        samples_per_frame=max(1, args.spp_per_frame), target_spp=args.target_spp, target_seconds=args.target_time,
        exposure=args.exposure, operator=args.tonemap, gamma=args.gamma,
        view=args.aov or ("noisy | denoised" if args.noisy_split else "render"),
        denoise=args.denoise, denoiser=args.denoiser,
        split=args.split, split_params=_prefixed(args.set, args.split), reference=args.ref, panels=args.panels, inspector=args.inspector,
        frames=args.frames, screenshot=args.screenshot, temporal=args.temporal, render_options=from_args(args))
    return ViewerWindow(options).run()
