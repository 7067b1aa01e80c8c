"""`lift-gl compare`: error against render time of integrators on one scene.

    lift-gl compare SCENE --integrators pt,pt:max_depth=3,mine (--time T | --spp N)
                    [--ref FILE | --ref-spp N] [--size WxH] [--seeds K] --out DIR

Each configuration renders progressively, once per seed (configurations interleaved, so a
change in machine load hits them alike), and at log-spaced checkpoints records render time,
wall time, spp and its errors against the reference (relMSE, RMSE, SSIM, DSSIM, FLIP with
--flip). Writes into DIR: metrics.csv (every checkpoint of every run), convergence.png/.svg,
contact_sheet.png (images at equal time), images/ (each configuration's last image, seed 1,
and the reference, linear EXR), summary.json and report.md (table and verdict).
"""
from __future__ import annotations

import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ..arg_types import check_output_folder
from ..atomic import atomic_path, write_text
from ..consistency import BIAS_TOLERANCE
from ..denoise import DENOISER_CHOICES
from ..errors import LiftError
from .configurations import Configuration, parse_configurations

DEFAULT_REF_SPP = 4096
COMPARE_TASK_SECONDS = 3600.0   # a run on a cluster worker past this is taken as hung


def add_parser(subparsers) -> None:
    from ..arg_types import finite, non_negative, positive, positive_int, probability
    from ..cli import _size

    p = subparsers.add_parser("compare", help="error against render time of integrators: metrics.csv, plot, report.md",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("--integrators", default="pt", metavar="LIST",
                   help="comma-separated plugins, each with optional :NAME=VALUE settings (pt,pt:max_depth=3)")
    p.add_argument("--denoise", default="off", metavar="MODES",
                   help="off,final,every: each configuration once per mode (final: each checkpoint denoised as if "
                        "it were the last; every: every frame; the denoiser's time counts as render time)")
    p.add_argument("--denoiser", default="auto", choices=DENOISER_CHOICES,
                   help="the denoiser of the modes other than off (default auto: chosen per mode and device, "
                        "as render's --denoiser)")
    budget = p.add_mutually_exclusive_group(required=True)
    budget.add_argument("--time", type=positive, dest="seconds", help="equal time: render time of every run, in seconds")
    budget.add_argument("--spp", type=positive_int, help="equal spp: samples per pixel of every run")
    ref = p.add_mutually_exclusive_group()
    ref.add_argument("--ref", type=Path, help="reference image (.exr .pfm .npy; larger by a whole factor is fine)")
    ref.add_argument("--ref-spp", type=positive_int, help=f"without --ref: spp of the pt reference (default {DEFAULT_REF_SPP}; cached)")
    p.add_argument("--size", type=_size, help="WxH (default: the scene's film size)")
    p.add_argument("--seeds", type=positive_int, default=3, help="independent runs per configuration (confidence intervals; default 3)")
    p.add_argument("--set", action="append", default=[], metavar="PLUGIN.NAME=VALUE", help="setting for every run of a plugin")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR", help="more plugin folders")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    p.add_argument("--flip", action="store_true",
                   help="also FLIP (needs pip install 'lift-gl[flip]'; slow: about 1 s a checkpoint at 128x128 here)")
    p.add_argument("--alpha", type=probability, default=1e-3,
                   help="bias test: chance that a configuration consistent with the reference is called biased "
                        "(default 0.001)")
    p.add_argument("--tolerance", type=non_negative, default=BIAS_TOLERANCE,
                   help=f"bias test: relative difference from the reference not called a bias (default {BIAS_TOLERANCE:g})")
    p.add_argument("--target-rel-mse", type=positive, help="relMSE for the verdict (default: the highest error of any run's end)")
    p.add_argument("--target-dssim", type=positive, help="DSSIM for the verdict (default: the highest error of any run's end)")
    p.add_argument("--points-per-doubling", type=positive_int, default=1, help="checkpoints per factor of 2 (default 1)")
    p.add_argument("--measure-overhead", action="store_true",
                   help="after each run, time a plain render of the same spp and seed (the checkpoints' cost)")
    p.add_argument("--exposure", type=finite, default=0.0, help="stops, for the contact sheet")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    from ..cluster.options import add_executor_arguments
    from ..options import add_option_argument

    add_option_argument(p)
    add_executor_arguments(p)
    p.set_defaults(func=cmd_compare)


# ---- metrics of one image ----
def image_metrics(image: np.ndarray, reference: np.ndarray, with_flip: bool = False) -> dict:
    from .. import metrics

    s = metrics.ssim(image, reference)
    out = {"rel_mse": metrics.rel_mse(image, reference), "rmse": metrics.rmse(image, reference),
           "ssim": s, "dssim": metrics.dssim_from_ssim(s)}
    if with_flip:
        out["flip"] = metrics.flip(image, reference)
    return out


# ---- runs ----
def _check_arguments(args) -> None:
    if args.seeds < 1:
        raise LiftError(f"--seeds must be at least 1, not {args.seeds}")
    if args.spp is not None and args.spp < 1:
        raise LiftError(f"--spp must be at least 1, not {args.spp}")
    if args.seconds is not None and not args.seconds > 0:
        raise LiftError(f"--time must be positive, not {args.seconds}")
    if args.ref_spp is not None and args.ref_spp < 1:
        raise LiftError(f"--ref-spp must be at least 1, not {args.ref_spp}")
    if not 0 < args.alpha < 1:
        raise LiftError(f"--alpha must be between 0 and 1, not {args.alpha}")
    if not 0 <= args.tolerance < 1:
        raise LiftError(f"--tolerance must be in [0, 1), not {args.tolerance}")
    if args.points_per_doubling < 1:
        raise LiftError(f"--points-per-doubling must be at least 1, not {args.points_per_doubling}")
    if args.flip:
        try:
            import flip_evaluator  # noqa: F401
        except ImportError:
            raise LiftError("--flip needs NVIDIA's FLIP: pip install 'lift-gl[flip]' (package flip-evaluator)") from None


def _configurations(args) -> list[Configuration]:
    from ..cli import _settings
    from .configurations import parse_spec

    names = {parse_spec(spec.strip())[0] for spec in args.integrators.split(",") if spec.strip()}
    return parse_configurations(args.integrators, args.denoise, {name: _settings(args.set, name) for name in names},
                                args.denoiser)


class Session:
    """What every run of one comparison shares: scene, size, reference, budgets."""

    def __init__(self, scene, size, args):
        self.scene, self.size, self.args = scene, size, args
        from .progressive import spp_checkpoints, time_checkpoints

        if args.spp is not None:
            self.mode, self.spp_targets, self.time_targets = "spp", spp_checkpoints(args.spp, args.points_per_doubling), None
        else:
            self.mode, self.spp_targets, self.time_targets = "time", None, time_checkpoints(args.seconds, args.points_per_doubling)

    def renderer(self, config: Configuration, seed: int):
        from ..frame_settings import DenoiseSettings
        from ..options import from_args
        from ..renderer import Renderer

        return Renderer(self.scene, size=self.size, integrator=config.integrator, backend=self.args.backend,
                        seed=seed, params=config.params, plugin_dirs=self.args.plugins,
                        denoise=DenoiseSettings(config.denoise, config.denoiser), options=from_args(self.args))

    def run(self, config: Configuration, seed: int, reference: np.ndarray, keep_images: bool):
        """One progressive run: its rows (one per checkpoint), images if asked, total wall time,
        and its final image with the variance of each pixel's mean (the bias test's input)."""
        from .bias import pixel_variance

        from .progressive import run_checkpoints, warm_up

        renderer = self.renderer(config, seed)
        warm_up(renderer)
        rows, images = [], []
        start = time.perf_counter()
        # Denoising is the renderer's: "every" after each frame, "final" at the end of each
        # render() call, i.e. each checkpoint's image as if it were the last; either way inside
        # the timed render, and the image a checkpoint holds is the denoised one.
        for cp in run_checkpoints(renderer, self.spp_targets, self.time_targets):
            row = {"configuration": config.label, "integrator": config.integrator,
                   "params": ";".join(f"{k}={v}" for k, v in config.params.items()), "denoise": config.denoise,
                   "seed": seed, "checkpoint": cp.index, "spp": cp.spp,
                   "render_seconds": cp.render_seconds, "wall_seconds": cp.wall_seconds}
            row.update(image_metrics(cp.image, reference, self.args.flip))
            row["est_rel_mse"] = cp.estimate.rel_mse if cp.estimate is not None else math.nan  # of the noisy mean
            row["dropped_samples"] = cp.dropped_samples
            rows.append(row)
            if keep_images:
                images.append((cp.spp, cp.render_seconds, cp.image))
            last = cp
        total_wall = time.perf_counter() - start
        # The denoised image's own variance is not known: the noisy mean's, larger, stands for it.
        final = (last.image, pixel_variance(renderer), last.spp)
        renderer.release()
        return rows, images, total_wall, final

    def plain_render_seconds(self, config: Configuration, seed: int, spp: int) -> float:
        """Wall time of a plain render of `spp` (one call, one readback), as `lift-gl render` does."""
        from .progressive import warm_up

        renderer = self.renderer(config, seed)
        warm_up(renderer)
        start = time.perf_counter()
        renderer.render(spp=spp)
        seconds = time.perf_counter() - start
        renderer.release()
        return seconds


def _reference(session: Session, args):
    from ..progress import RenderProgress
    from .reference import load_reference, rendered_reference

    if args.ref is not None:
        return load_reference(args.ref, session.size)
    spp = args.ref_spp or DEFAULT_REF_SPP
    reference_config = Configuration(label="reference", integrator="pt")
    progress = RenderProgress(spp=spp, desc="reference (pt)") if sys.stderr.isatty() else None
    try:
        return rendered_reference(lambda seed: session.renderer(reference_config, seed), spp, progress=progress)
    finally:
        if progress is not None:
            progress.close()


def _write_csv(path: Path, rows: list[dict]) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})


def _run_all(session: Session, configs: list[Configuration], reference: np.ndarray, args):
    """Every configuration once per seed, interleaved; with --measure-overhead, a plain render
    after each run. Returns rows per label (a list per seed), seed 1's checkpoint images per
    label, the overhead table, and each run's final image and variance per label."""
    runs = {c.label: [] for c in configs}
    finals = {c.label: [] for c in configs}
    images, walls, plains = {}, {c.label: [] for c in configs}, {c.label: [] for c in configs}
    results = _cluster_runs(session, configs, reference, args) if getattr(args, "executor", "local") == "ray" else None
    for seed in range(1, args.seeds + 1):
        for config in configs:
            if results is not None:
                rows, kept, wall, final = results[(config.label, seed)]
            else:
                rows, kept, wall, final = session.run(config, seed, reference, keep_images=seed == 1)
                _write_partial_csv(args.out, runs, rows)
            runs[config.label].append(rows)
            finals[config.label].append(final)
            walls[config.label].append(wall)
            if seed == 1:
                images[config.label] = kept
            last = rows[-1]
            print(f"{config.label} seed {seed}: {last['spp']} spp, render {last['render_seconds']:.2f} s, "
                  f"wall {wall:.2f} s, relMSE {last['rel_mse']:.4g}, DSSIM {last['dssim']:.4g}", flush=True)
            if last["dropped_samples"]:
                print(f"  warning: {last['dropped_samples']} NaN/Inf samples dropped", flush=True)
            if args.measure_overhead:  # right after the run, so both see the same machine load
                plains[config.label].append(session.plain_render_seconds(config, seed, last["spp"]))
    overhead = {}
    for label, plain in plains.items():
        if not plain:
            continue
        ratios = [wall / p for wall, p in zip(walls[label], plain)]
        overhead[label] = {"spp": [run[-1]["spp"] for run in runs[label]], "plain_seconds": plain,
                           "compare_wall_seconds": walls[label],
                           "compare_render_seconds": [run[-1]["render_seconds"] for run in runs[label]],
                           "checkpoints": len(runs[label][0]), "ratios": ratios,
                           "median_ratio": float(np.median(ratios))}
    return runs, images, overhead, finals


def _write_partial_csv(out, runs: dict, new_rows: list[dict]) -> None:
    """metrics.csv with every run finished so far (rewritten whole as each one arrives)."""
    rows = [row for label in runs for run in runs[label] for row in run] + list(new_rows)
    if rows:
        _write_csv(Path(out) / "metrics.csv", rows)


def _cluster_runs(session: Session, configs: list[Configuration], reference: np.ndarray, args) -> dict:
    """Every (configuration, seed) run on the Ray cluster's workers (lift_gl/cluster/), as
    Session.run returns it, by (label, seed); metrics.csv grows as the runs arrive."""
    from ..cluster.options import executor_from_args
    from ..cluster.pool import Pool, Task

    if args.measure_overhead:
        raise LiftError("--measure-overhead times a plain render beside each run: not with --executor ray")
    pool = Pool(executor_from_args(args), backend=args.backend)
    results, arrived = {}, []
    try:
        ref = pool.ray.put(reference)
        tasks = [Task("compare_run", (session, config, seed, ref, seed == 1), limit=COMPARE_TASK_SECONDS,
                      key=(config.label, seed)) for seed in range(1, args.seeds + 1) for config in configs]

        def on_result(task, outcome):
            if outcome.status != "ok":
                raise LiftError(f"{task.key[0]} seed {task.key[1]}: {outcome.message}")
            results[task.key] = outcome.value
            arrived.extend(outcome.value[0])
            _write_csv(Path(args.out) / "metrics.csv", arrived)

        pool.run(tasks, on_result)
    finally:
        pool.close()
    return results


def _contact_sheet(images: dict, reference: np.ndarray, t_equal: float, path: Path, exposure: float) -> None:
    """Seed 1 of each configuration at its checkpoint nearest to t_equal (on a log scale)."""
    from ..metrics import rel_mse
    from .contact_sheet import contact_sheet

    entries = []
    for label, kept in images.items():
        spp, seconds, image = min(kept, key=lambda k: abs(math.log(k[1] / t_equal)))
        entries.append((label, f"{seconds:.2f} s, {spp} spp\nrelMSE {rel_mse(image, reference):.3g}", image))
    contact_sheet(reference, entries, path, exposure)


def cmd_compare(args) -> int:
    from ..gl.context import create_context
    from ..image_io import write_image
    from ..scene.loader import load_scene
    from . import report_md
    from .machine import describe_machine
    from .plots import plot_convergence
    from .bias import as_json as bias_json
    from .bias import consistency_of_runs
    from ..options import from_args
    from .summary import at_time, common_time, curve, final_row, verdict

    _check_arguments(args)
    check_output_folder(args.out)
    configs = _configurations(args)
    scene = load_scene(args.scene)
    size = tuple(args.size or scene.film_size)
    session = Session(scene, size, args)
    # Every configuration's plugin and settings are checked before anything long starts.
    biased = {}  # label -> why its images are biased (plugin's manifest, denoiser)
    for config in configs:
        r = session.renderer(config, 1)
        reasons = [r.plugin.biased] if r.plugin.biased else []
        if config.denoise != "off":
            from ..denoise import BIASED

            reasons.append(f"denoised ({config.denoiser}, {config.denoise}): {BIASED}")
        if reasons:
            biased[config.label] = "; ".join(reasons)
        r.release()
    out = Path(args.out)
    (out / "images").mkdir(parents=True, exist_ok=True)

    reference = _reference(session, args)
    print(f"reference: {reference.source}{' (cached)' if reference.cached else ''}", flush=True)
    image_metrics(reference.image, reference.image, args.flip)  # first-use imports stay out of the wall times
    write_image(out / "images" / "reference.exr", reference.image)
    started = time.strftime("%Y-%m-%d %H:%M")
    machine = describe_machine(create_context(args.backend))

    runs, images, overhead, run_finals = _run_all(session, configs, reference.image, args)
    consistency = consistency_of_runs(run_finals, reference, args.alpha, args.tolerance)
    consistent = {label: (c.consistent if c is not None else None) for label, c in consistency.items()}

    # ---- what the runs say ----
    _write_csv(out / "metrics.csv", [row for label in runs for run in runs[label] for row in run])
    grid = session.spp_targets if session.mode == "spp" else session.time_targets
    curves = {label: curve(r, session.mode, grid) for label, r in runs.items()}
    finals = {label: final_row(r) for label, r in runs.items()}
    verdicts = [v for v in (verdict(runs, "rel_mse", args.target_rel_mse, consistent),
                            verdict(runs, "dssim", args.target_dssim, consistent)) if v is not None]
    t_equal = common_time(runs)
    equal_time = {m: at_time(runs, t_equal, m) for m in ("rel_mse", "dssim")}

    # ---- files ----
    for config in configs:
        write_image(out / "images" / f"{config.file_stem}.exr", images[config.label][-1][2])
    title = f"{Path(args.scene).name} {size[0]}x{size[1]}, {args.seeds} seed{'s' if args.seeds > 1 else ''}, 95% CI"
    plot_convergence(curves, out / "convergence", title, {v.metric: v.target for v in verdicts},
                     biased={label for label, ok in consistent.items() if ok is False})
    _contact_sheet(images, reference.image, t_equal, out / "contact_sheet.png", args.exposure)
    summary = {"scene": str(args.scene), "size": list(size), "mode": session.mode,
               "budget": args.spp if session.mode == "spp" else args.seconds, "seeds": args.seeds,
               "configurations": [c.label for c in configs], "biased": biased, "reference": {"source": reference.source,
                                                                         "cached": reference.cached, **reference.info},
               "machine": machine, "started": started, "equal_time_seconds": t_equal, "overhead": overhead,
               "options": from_args(args).changed(),   # --option KEY=VALUE (lift_gl/options.py)
               "final": {label: {k: (v.__dict__ if hasattr(v, "__dict__") else v) for k, v in f.items()}
                         for label, f in finals.items()},
               "consistency": {label: bias_json(c) for label, c in consistency.items()},
               "verdicts": [v.as_json() for v in verdicts]}
    write_text(out / "summary.json", json.dumps(summary, indent=1, default=str))
    write_text(out / "report.md", report_md.render(summary, finals, verdicts, equal_time, t_equal, overhead, machine,
                                                   consistency))
    for v in verdicts:
        print(v.sentence().replace("**", ""))
    print(f"wrote {out / 'report.md'}, metrics.csv, convergence.png/.svg, contact_sheet.png")
    return 0
