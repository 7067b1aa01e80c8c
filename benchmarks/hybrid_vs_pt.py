"""Error against render time: the biased `hybrid` plugin (half and quarter resolution indirect
light) against `pt`, on two scenes, measured against a long pt render.

    .venv/bin/python benchmarks/hybrid_vs_pt.py [--size 96] [--ref-spp 2048] [--times 0.5,1,2,4,8,16,32]
                                                [--out out/hybrid_vs_pt]

For every scene: a reference from two pt renders of ref-spp/2 samples with independent seeds
(their mean; relMSE(A, B) / 4 estimates the reference's own error, the floor below which no
comparison means anything), then each integrator renders progressively and, when its render
time (Renderer.stats: frames only, read-backs excluded) passes each checkpoint, its relMSE
against the reference is recorded, over the whole image and split into the pixels whose
first hit is diffuse and those whose first hit is glossy, glass or a mirror (material ids
from the G-buffer).

Writes DIR/metrics.csv, DIR/report.md (tables), DIR/error_vs_time.png (log-log plot) and
DIR/SCENE-images.png (reference, pt, hybrid at the last checkpoint, and their error maps).
`lift-gl compare` (another branch) will make this a command; this script uses only Renderer
and lift_gl.metrics. Timings on a shared CPU are noisy: every number of one table comes
from one run, and only ratios between rows should be read.
"""
from __future__ import annotations

import argparse
import csv
import platform
from pathlib import Path

import numpy as np

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.metrics import rel_mse
from lift_gl.renderer import Renderer
from lift_gl.tonemap import to_srgb8

REPO = Path(__file__).resolve().parent.parent
SCENES = {"cornell-glass-gold": REPO / "scenes" / "cornell.toml",
          "lift-cornell-diffuse": REPO.parent / "shared" / "scenes_lift" / "cornell-box" / "scene.pbrt"}
RUNS = [("pt", "pt", {}), ("hybrid 1/2", "hybrid", {"indirect_scale": 2}),
        ("hybrid 1/4", "hybrid", {"indirect_scale": 4})]


def reference(scene, size, spp, cache: Path):
    if cache.is_file():
        data = np.load(cache)
        return data["reference"], float(data["floor"])
    halves = []
    for seed in (1001, 1002):
        r = Renderer(scene, size=size, seed=seed)
        halves.append(r.render(spp=spp // 2).astype(np.float64))
        r.release()
    ref = 0.5 * (halves[0] + halves[1])
    floor = rel_mse(halves[0], halves[1]) / 4
    np.savez(cache, reference=ref, floor=floor)
    return ref, floor


def specular_mask(scene, size) -> np.ndarray:
    """Pixels whose first hit is not diffuse (material ids from the G-buffer's visibility)."""
    r = Renderer(scene, size=size)
    r.render(spp=1)
    w, h = size
    vis = np.frombuffer(r.gbuffer.visibility.read(), np.uint32).reshape(h, w, 4)[::-1]
    r.release()
    types = np.array([m.type for m in scene.materials] + ["none"])
    material = np.where(vis[..., 0] > 0, vis[..., 3], len(scene.materials))
    return (types[material] != "diffuse") & (types[material] != "none")


def masked_rel_mse(image, ref, mask) -> float:
    if not mask.any():
        return float("nan")
    return rel_mse(image[mask], ref[mask])


def run(name, scene, size, ref, mask, times, integrator, params, seed=7):
    r = Renderer(scene, size=size, integrator=integrator, params=params, seed=seed)
    r.render(spp=1)  # compile and warm up, then start over
    r.reset()
    rows, image = [], None
    for t in times:
        image = r.render(seconds=max(t - r.stats.render_seconds, 0.0)).astype(np.float64)
        rows.append({"run": name, "target_s": t, "seconds": r.stats.render_seconds, "spp": r.stats.spp,
                     "rel_mse": rel_mse(image, ref), "rel_mse_diffuse": masked_rel_mse(image, ref, ~mask),
                     "rel_mse_specular": masked_rel_mse(image, ref, mask), "dropped": r.stats.dropped_samples})
        print(f"  {name:<11} {rows[-1]['seconds']:6.2f} s {rows[-1]['spp']:6d} spp relMSE {rows[-1]['rel_mse']:.5f}",
              flush=True)
    r.release()
    return rows, image


def error_map(image, ref) -> np.ndarray:
    """Per-pixel relative squared error, as a grey image (white: relMSE 0.1 or more)."""
    err = ((image - ref) ** 2 / (ref ** 2 + 1e-2)).mean(axis=-1)
    return (np.clip(np.sqrt(err / 0.1), 0, 1)[..., None] * 255).repeat(3, axis=-1).astype(np.uint8)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--size", type=int, default=96)
    p.add_argument("--ref-spp", type=int, default=2048)
    p.add_argument("--times", default="0.5,1,2,4,8,16,32")
    p.add_argument("--scenes", default=",".join(SCENES))
    p.add_argument("--out", type=Path, default=REPO / "out" / "hybrid_vs_pt")
    args = p.parse_args(argv)
    times = [float(t) for t in args.times.split(",")]
    size = (args.size, args.size)
    args.out.mkdir(parents=True, exist_ok=True)
    from PIL import Image

    all_rows, report = [], []
    device = None
    for scene_name in args.scenes.split(","):
        scene = load_scene(SCENES[scene_name])
        print(f"{scene_name}: reference ({args.ref_spp} spp pt)", flush=True)
        ref, floor = reference(scene, size, args.ref_spp, args.out / f"{scene_name}-reference-{args.size}-{args.ref_spp}.npz")
        mask = specular_mask(scene, size)
        finals = {}
        for label, integrator, params in RUNS:
            rows, finals[label] = run(label, scene, size, ref, mask, times, integrator, params)
            for row in rows:
                row["scene"] = scene_name
            all_rows += rows
        if device is None:
            r = Renderer(scene, size=(8, 8))
            device = describe(r.ctx)
            r.release()
        # ---- the report's table for this scene ----
        report.append(f"\n### {scene_name} ({args.size}x{args.size}; reference: pt {args.ref_spp} spp, "
                      f"its own relMSE about {floor:.1e}; {mask.mean():.0%} of pixels see glass, metal or glossy first)\n")
        report.append("| render time (s) | " + " | ".join(f"{label}: spp, relMSE (diffuse / specular pixels)"
                                                       for label, _, _ in RUNS) + " |")
        report.append("| --- |" + " --- |" * len(RUNS))
        for t in times:
            cells = []
            for label, _, _ in RUNS:
                row = next(r for r in all_rows if r["scene"] == scene_name and r["run"] == label and r["target_s"] == t)
                cells.append(f"{row['spp']}, **{row['rel_mse']:.4f}** ({row['rel_mse_diffuse']:.4f} / "
                             f"{row['rel_mse_specular']:.4f})")
            report.append(f"| {t:g} | " + " | ".join(cells) + " |")
        tiles = [ref] + [finals[label] for label, _, _ in RUNS]
        top = np.concatenate([to_srgb8(t) for t in tiles], axis=1)
        bottom = np.concatenate([np.zeros_like(to_srgb8(ref))] + [error_map(finals[label], ref) for label, _, _ in RUNS], axis=1)
        Image.fromarray(np.concatenate([top, bottom], axis=0)).save(args.out / f"{scene_name}-images.png")

    with open(args.out / "metrics.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(all_rows[0]))
        writer.writeheader()
        writer.writerows(all_rows)
    header = [f"# hybrid vs pt: relMSE against render time\n",
              f"Device: {device}; host: {platform.processor() or platform.machine()}, shared 2-core CPU. "
              f"Columns: samples per pixel reached, relMSE of the whole image in bold, then of the pixels "
              f"whose first hit is diffuse / not diffuse. Images: `*-images.png` (top: reference, "
              + ", ".join(label for label, _, _ in RUNS) + f" at {times[-1]:g} s; bottom: their error maps).\n"]
    (args.out / "report.md").write_text("\n".join(header + report) + "\n")
    _plot(all_rows, args.out / "error_vs_time.png")
    print(f"wrote {args.out}/report.md, metrics.csv, error_vs_time.png")
    return 0


def _plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = sorted({r["scene"] for r in rows})
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.5 * len(scenes), 4.2), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        for label, _, _ in RUNS:
            pts = [r for r in rows if r["scene"] == scene and r["run"] == label]
            ax.loglog([r["seconds"] for r in pts], [r["rel_mse"] for r in pts], "o-", label=label)
        ax.set_title(scene)
        ax.set_xlabel("render time (s)")
        ax.set_ylabel("relMSE vs long pt render")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    raise SystemExit(main())
