"""Where Russian roulette should start: each setting's error per sample, and with its GPU frame
time, the time it needs to reach an error (Lift's path tracer plays roulette from the first
bounce, pt from the fourth; docs/integrators.md, "Russian roulette").

    python benchmarks/roulette_efficiency.py SCENE... [--configs pt,pt:rr_depth=1:rr_min_survival=0,...]
        [--size 960x540] [--spp 256] [--seeds 3] [--ref-spp 8192] [--times MEASURE.json] [--out FILE.json]
    python benchmarks/roulette_efficiency.py --results FILE.json... --times MEASURE.json   (a table only)

Per scene: a reference (pt with its defaults, --ref-spp samples), then every configuration at
--spp samples with each seed, and its relMSE against the reference (lift_gl.metrics.rel_mse:
numpy only, so it runs where scikit-image is not installed, as on the GPU machine; `lift-gl
compare` needs it). The estimators are unbiased, so relMSE falls as 1/spp: relMSE x spp is
the error of one sample, and the reference's own noise adds spp / ref_spp of it to every
configuration alike. With --times (a `benchmarks/gpu.py measure` record with a frame of every
configuration: 1 spp a frame, the same scenes), the time to any given relMSE is proportional
to relMSE x frame ms; the table gives it relative to the first configuration (below 1: reaches
an error sooner). The per-sample error at --size stands for that at the measured frame size:
pixels of a coarser image average more of the scene, the same for every configuration.
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

from gpu import portable, scene_name  # noqa: E402
from lift_gl.report.records import write_json  # noqa: E402

DEFAULT_CONFIGS = "pt,pt:rr_depth=1:rr_min_survival=0,pt:rr_depth=2,pt:rr_depth=3,pt:rr_depth=5"


def frame_ms(records: list[dict]) -> dict:
    """{(scene name, configuration): frame ms} from gpu.py measure records (the fastest of repeats).
    A record measured at --max-depth N also answers for the configuration with max_depth=N first."""
    out = {}
    for rec in records:
        depth = rec.get("max_depth")
        for r in rec.get("results", []):
            if r.get("kind") == "frame":
                plugin, _, params = r["integrator"].partition(":")
                names = [r["integrator"]]
                if depth is not None:
                    names.append(f"{plugin}:max_depth={depth}" + (f":{params}" if params else ""))
                for name in names:
                    key = (r["scene_name"], name)
                    out[key] = min(out.get(key, np.inf), r["frame_ms"])
    return out


def image_stats(image: np.ndarray) -> dict:
    """What tells a broken image from a noisy one: mean, largest value, share of black pixels."""
    return {"mean": float(image.mean()), "max": float(image.max()),
            "black": float(np.mean(image.max(axis=-1) <= 0.0)), "p999": float(np.quantile(image, 0.999))}


def measure_scene(path: str, configs: list[str], size, spp: int, seeds: int, ref_spp: int, backend="auto") -> dict:
    from lift_gl.metrics import rel_mse
    from lift_gl.renderer import Renderer
    from lift_gl.report.configurations import parse_spec
    from lift_gl.scene.loader import load_scene

    scene = load_scene(path)
    start = time.perf_counter()
    r = Renderer(scene, size=size, integrator="pt", backend=backend, seed=1_000_003)
    r.render(spp=1)   # as lift-gl compare does: shader JIT and first use, then a reset
    r.reset()
    reference = r.render(spp=ref_spp)
    r.release()
    out = {"scene": portable(path), "scene_name": scene_name(path), "size": list(size), "spp": spp,
           "ref_spp": ref_spp, "reference_seconds": time.perf_counter() - start,
           "reference_stats": image_stats(reference), "configs": {}}
    if not np.isfinite(reference).all():
        raise SystemExit(f"{path}: the reference holds NaN or infinite values")
    for spec in configs:
        plugin, params = parse_spec(spec)
        r = Renderer(scene, size=size, integrator=plugin, backend=backend, params=params, seed=1)
        r.render(spp=1)
        errors, dropped, stats = [], 0, []
        for seed in range(1, seeds + 1):
            r.reset(seed=seed)
            image = r.render(spp=spp)
            errors.append(rel_mse(image, reference))
            stats.append(image_stats(image))
            dropped += int(r.stats.dropped_samples)
        r.release()
        e = np.array(errors)
        out["configs"][spec] = {"rel_mse": errors, "rel_mse_mean": float(e.mean()),
                                "rel_mse_sem": float(e.std(ddof=1) / np.sqrt(len(e))) if len(e) > 1 else None,
                                "per_sample": float(e.mean() * spp), "dropped_samples": dropped, "image_stats": stats}
        print(f"{out['scene_name']} {spec}: relMSE {e.mean():.4g} (seeds {', '.join(f'{x:.4g}' for x in e)})", flush=True)
    return out


def table(results: list[dict], times: dict) -> str:
    lines = ["| scene | configuration | relMSE at spp (mean of seeds ± s.e.) | relMSE x spp | vs first | "
             "GPU frame ms | time to an error, vs first |", "|---|---|---|---|---|---|---|"]
    for res in results:
        first = None
        for spec, c in res["configs"].items():
            ms = times.get((res["scene_name"], spec))
            cost = c["per_sample"] * ms if ms is not None else None
            if first is None:
                first = (c["per_sample"], cost)
            sem = f" ± {c['rel_mse_sem']:.2g}" if c["rel_mse_sem"] is not None else ""
            lines.append(f"| {res['scene_name']} | {spec} | {c['rel_mse_mean']:.4g}{sem} | {c['per_sample']:.3g} | "
                         f"{c['per_sample'] / first[0]:.2f} | {'–' if ms is None else f'{ms:.3f}'} | "
                         f"{'–' if cost is None or first[1] is None else f'{cost / first[1]:.2f}'} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    from lift_gl.cli import _size

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--configs", default=DEFAULT_CONFIGS, help="comma-separated, as lift-gl compare's --integrators; "
                                                               "the first is the baseline of the ratios")
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--times", type=Path, action="append", default=[], help="gpu.py measure JSON (repeatable)")
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--results", type=Path, action="append", default=[],
                    help="an --out file of an earlier run (repeatable): its errors tabulated with --times, nothing rendered")
    args = ap.parse_args(argv)
    if not args.scenes and not args.results:
        ap.error("give scenes to render, or --results to tabulate")
    configs = [c.strip() for c in args.configs.split(",") if c.strip()]
    times = frame_ms([json.loads(p.read_text()) for p in args.times])
    if args.results:
        print(table([r for p in args.results for r in json.loads(p.read_text())["results"]], times))
        return 0
    results = []
    for path in args.scenes:
        results.append(measure_scene(path, configs, _size(args.size), args.spp, args.seeds, args.ref_spp, args.backend))
        if args.out:
            write_json(args.out, {"configs": configs, "results": results}, indent=1)
    print(table(results, times))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
