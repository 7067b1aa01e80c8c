"""PT against BDPT on a caustic: a glass sphere focusing a small light onto a diffuse floor.

    python benchmarks/equal_time.py reference scenes/glass_caustic.toml --size 96 --minutes 9 --chunk 64
    python benchmarks/glass_caustic.py [--seconds 75] [--spp 256] [--repeats 4] [--size 96] [--out out/glass_caustic]
        [--results benchmarks/results] [--figure docs/glass_caustic.png]

The first command renders the reference (a long BDPT run as two independent halves; PT and
BDPT have the same expectation, which tests/test_bdpt.py checks on this scene). This script
then renders with pt and with bdpt for the same wall time (slices of about a second taken in
turn, so that both see the same load) and, separately, for the same samples per pixel, and
reports against the reference (at equal samples, the mean over --repeats independent runs:
one run's relMSE is dominated by its few brightest outliers):

- relMSE = mean((x - ref)^2 / (ref^2 + 0.01)) over all pixels, raw and less the reference's own
  noise (measured from its halves: mean((a - b)^2 / (ref^2 + eps)) / 4);
- SSIM (lift_gl.metrics.ssim: sRGB, clipped);
- the same relMSE restricted to the caustic region: the floor pixels in the sphere's shadow
  from the lamp's centre (the camera ray hits the floor without passing the sphere, and the
  segment from that floor point to the lamp's centre passes through the sphere). Direct light
  from the lamp is blocked there, so what is left is the caustic and the dim fill; also the
  SSIM of that region's bounding box and its mean against the reference's.

Writes glass_caustic_equal_time.json, glass_caustic.md (the tables) and a figure of crops
around the caustic (reference | pt | bdpt at equal time) with the mask's outline.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from equal_time import image_size, load_halves, machine  # noqa: E402

from lift_gl import load_scene  # noqa: E402
from lift_gl.image_io import write_srgb8  # noqa: E402
from lift_gl.metrics import REL_MSE_EPS, rel_mse, ssim  # noqa: E402
from lift_gl.renderer import Renderer  # noqa: E402
from lift_gl.tonemap import srgb_encode  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
SCENE = REPO / "scenes" / "glass_caustic.toml"


def _hits_sphere(o, d, center, radius, t_max):
    """Whether each ray o + t d (d unit) meets the sphere for 0 < t < t_max."""
    oc = o - center
    b = np.einsum("...i,...i->...", oc, d)
    disc = b * b - (np.einsum("...i,...i->...", oc, oc) - radius ** 2)
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = -b - root, -b + root
    return (disc > 0) & (far > 1e-6) & (near < t_max)


def caustic_mask(scene, size) -> np.ndarray:
    """(H, W) bool: floor pixels in the sphere's shadow from the lamp's centre (see the docstring).
    Rays through pixel centres of a pinhole camera, row 0 at the top."""
    w, h = size
    cam = scene.camera
    right, up, forward = cam.basis()
    tan_half = np.tan(np.radians(cam.fov_deg) / 2)
    x = (2 * (np.arange(w) + 0.5) / w - 1) * tan_half * w / h
    y = (1 - 2 * (np.arange(h) + 0.5) / h) * tan_half
    d = forward + x[None, :, None] * right + y[:, None, None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.broadcast_to(np.asarray(cam.position, np.float64), d.shape)
    sphere = scene.spheres[0]
    center, radius = np.asarray(sphere.center, np.float64), float(sphere.radius)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(d[..., 1] < 0, -o[..., 1] / d[..., 1], np.inf)  # the floor is y = 0
    floor = np.isfinite(t) & ~_hits_sphere(o, d, center, radius, np.where(np.isfinite(t), t, 1e30))
    p = o + np.where(np.isfinite(t), t, 0)[..., None] * d
    lamp = next(m for m in scene.meshes if m.name == "lamp")
    to_lamp = lamp.positions.astype(np.float64).mean(axis=0) - p
    dist = np.linalg.norm(to_lamp, axis=-1)
    shadow = _hits_sphere(p, to_lamp / dist[..., None], center, radius, dist)
    return floor & shadow


def measures(image, ref, a, b, mask) -> dict:
    """relMSE (raw and less the reference's noise) and SSIM, overall and in the mask."""
    noise_px = np.mean((a - b) ** 2 / (ref ** 2 + REL_MSE_EPS), axis=-1) / 4
    err_px = np.mean((image - ref) ** 2 / (ref ** 2 + REL_MSE_EPS), axis=-1)
    rows, cols = np.nonzero(mask)
    box = np.s_[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    return {"rel_mse": float(err_px.mean()), "rel_mse_less_reference_noise": float(err_px.mean() - noise_px.mean()),
            "ssim": ssim(image, ref),
            "mean_over_reference_mean": float(image.mean() / ref.mean()),
            "caustic_rel_mse": float(err_px[mask].mean()),
            "caustic_rel_mse_less_reference_noise": float(err_px[mask].mean() - noise_px[mask].mean()),
            "caustic_ssim": ssim(image[box], ref[box]),
            "caustic_mean_over_reference_mean": float(image[mask].mean() / ref[mask].mean())}


def run(scene, size, seed, spp=None, seconds=None, slice_s=1.0):
    """pt and bdpt images, for the same samples per pixel or the same wall time (in turns)."""
    renderers = {name: Renderer(scene, size=size, integrator=name, seed=seed) for name in ("pt", "bdpt")}
    for r in renderers.values():
        r.render(spp=1)  # compile and warm up, then start from zero
        r.reset()
    if spp is not None:
        for r in renderers.values():
            r.render(spp=spp)
    else:
        while min(r.stats.render_seconds for r in renderers.values()) < seconds:
            for r in renderers.values():
                if r.stats.render_seconds < seconds:
                    r.render(seconds=min(slice_s, seconds - r.stats.render_seconds))
    return renderers


def crop_figure(images, mask, path: Path, scale: int = 2) -> None:
    """Crops around the mask (padded), side by side, the mask's outline in the first."""
    rows, cols = np.nonzero(mask)
    pad = 6
    r0, r1 = max(rows.min() - pad, 0), min(rows.max() + pad + 1, mask.shape[0])
    c0, c1 = max(cols.min() - pad, 0), min(cols.max() + pad + 1, mask.shape[1])
    tiles = []
    for k, image in enumerate(images):
        tile = np.clip(srgb_encode(np.asarray(image, np.float64)), 0, 1)[r0:r1, c0:c1]
        if k == 0:
            m = mask[r0:r1, c0:c1]
            edge = m & ~(np.roll(m, 1, 0) & np.roll(m, -1, 0) & np.roll(m, 1, 1) & np.roll(m, -1, 1))
            tile = tile.copy()
            tile[edge] = (1.0, 0.55, 0.0)
        tiles.append(np.kron(tile, np.ones((scale, scale, 1))))
        tiles.append(np.ones((tiles[-1].shape[0], 4, 3)))
    write_srgb8(path, (np.concatenate(tiles[:-1], axis=1) * 255 + 0.5).astype(np.uint8))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=75.0, help="wall time each at equal time")
    parser.add_argument("--spp", type=int, default=256, help="samples per pixel each at equal samples")
    parser.add_argument("--size", type=int, default=96, help="image width (the reference's)")
    parser.add_argument("--repeats", type=int, default=4, help="independent runs at equal samples (seeds seed + 1...)")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", type=Path, default=REPO / "out" / "glass_caustic", help="the reference's folder")
    parser.add_argument("--results", type=Path, default=REPO / "benchmarks" / "results")
    parser.add_argument("--figure", type=Path, default=REPO / "docs" / "glass_caustic.png")
    args = parser.parse_args()

    scene = load_scene(SCENE)
    size = image_size(scene, args.size)
    a, b, ref_info = load_halves(args.out)
    if a.shape[:2] != size[::-1]:
        raise SystemExit(f"the reference is {a.shape[1]}x{a.shape[0]}; run with --size {a.shape[1]}")
    ref = (a + b) / 2
    mask = caustic_mask(scene, size)
    result = {"scene": str(SCENE.relative_to(REPO)), "size": list(size), "reference": ref_info,
              "reference_rel_mse_noise": float(np.mean((a - b) ** 2 / (ref ** 2 + REL_MSE_EPS)) / 4),
              "caustic_pixels": int(mask.sum())}
    images = {}
    runs = [("equal_time", args.seed, {"seconds": args.seconds})]
    runs += [("equal_spp", args.seed + 1 + k, {"spp": args.spp}) for k in range(args.repeats)]
    per_run = {"equal_time": [], "equal_spp": []}
    for label, seed, kwargs in runs:
        renderers = run(scene, size, seed, **kwargs)
        result["machine"] = machine(renderers["pt"])
        rows = {}
        for name, r in renderers.items():
            image = r.image().astype(np.float64)
            images.setdefault((label, name), image)
            rows[name] = {"seed": seed, "spp": r.stats.spp, "seconds": round(r.stats.render_seconds, 2),
                          **measures(image, ref, a, b, mask),
                          "dropped_samples": r.stats.dropped_samples, "dropped_splats": r.stats.dropped_splats}
            print(f"{label:10s} {name:4s} {r.stats.spp:5d} spp {r.stats.render_seconds:6.1f} s  "
                  f"relMSE {rows[name]['rel_mse_less_reference_noise']:.5f}  SSIM {rows[name]['ssim']:.3f}  "
                  f"caustic relMSE {rows[name]['caustic_rel_mse_less_reference_noise']:.4f} "
                  f"SSIM {rows[name]['caustic_ssim']:.3f}", flush=True)
            r.release()
        per_run[label].append(rows)
    for label, rows_list in per_run.items():  # the mean of each measure over the runs, and the runs
        result[label] = {name: {key: (float(np.mean([rows[name][key] for rows in rows_list]))
                                      if key not in ("seed", "spp", "dropped_samples", "dropped_splats") else
                                      rows_list[0][name][key] if key == "spp" else
                                      [rows[name][key] for rows in rows_list])
                                for key in rows_list[0][name]} for name in ("pt", "bdpt")}
        result[label]["runs"] = rows_list
    args.results.mkdir(parents=True, exist_ok=True)
    (args.results / "glass_caustic_equal_time.json").write_text(json.dumps(result, indent=1) + "\n")
    crop_figure([ref, images["equal_time", "pt"], images["equal_time", "bdpt"]], mask, args.figure)

    lines = ["# PT against BDPT on a glass-sphere caustic (benchmarks/glass_caustic.py)", "",
             f"Scene `{result['scene']}`, {size[0]}x{size[1]}; reference: BDPT, {ref_info['spp']} spp "
             f"(its own relMSE noise {result['reference_rel_mse_noise']:.2e}, subtracted below). "
             f"Caustic region: {result['caustic_pixels']} floor pixels in the sphere's shadow. "
             f"Machine: {result['machine']}.", ""]
    for label, title in (("equal_time", f"Equal time ({args.seconds:g} s each, in turns)"),
                         ("equal_spp", f"Equal samples ({args.spp} spp each; the mean of {args.repeats} runs)")):
        rows = {name: result[label][name] for name in ("pt", "bdpt")}
        lines += [f"## {title}", "",
                  "| integrator | spp | seconds | relMSE | SSIM | caustic relMSE | caustic SSIM | caustic mean / ref |",
                  "|---|---|---|---|---|---|---|---|"]
        for name, row in rows.items():
            lines.append(f"| {name} | {row['spp']} | {row['seconds']:.1f} | {row['rel_mse_less_reference_noise']:.2e} | "
                         f"{row['ssim']:.3f} | {row['caustic_rel_mse_less_reference_noise']:.2e} | "
                         f"{row['caustic_ssim']:.3f} | {row['caustic_mean_over_reference_mean']:.3f} |")
        pt, bd = rows["pt"], rows["bdpt"]
        lines += ["", f"relMSE pt / bdpt: {pt['rel_mse_less_reference_noise'] / bd['rel_mse_less_reference_noise']:.1f} "
                      f"overall, {pt['caustic_rel_mse_less_reference_noise'] / bd['caustic_rel_mse_less_reference_noise']:.1f} "
                      "in the caustic.", ""]
        if len(result[label]["runs"]) > 1:
            lines += ["Each run's relMSE (overall / in the caustic): " + "; ".join(
                f"{name} " + ", ".join(f"{run[name]['rel_mse_less_reference_noise']:.2e} / "
                                       f"{run[name]['caustic_rel_mse_less_reference_noise']:.2e}" for run in result[label]["runs"])
                for name in ("pt", "bdpt")) + ".", ""]
    (args.results / "glass_caustic.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
