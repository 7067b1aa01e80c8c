"""The stress suite's table for docs/robustness.md: every case of scenes/stress/ rendered with
more samples than the tests use, against the same independent answers (tests/test_stress.py):
expected, measured, the z-scores of the difference (image and worst 8x8 block), dropped
NaN/Inf samples and loop-limited pixel-frames, pass or fail. Also the caustic's error
against a long light-traced reference as the sample count grows.

    python benchmarks/stress_report.py [--scale 4] > out/stress_table.md
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import test_stress as T  # noqa: E402
from stress_reference import (caustic_light_tracer, floor_under_quad_light, furnace_box,  # noqa: E402
                              ground_and_sky, render_offsets, tilted_normals, tir_cube)
from lift_gl.gl.context import create_context, describe  # noqa: E402
from lift_gl.renderer import Renderer  # noqa: E402
from lift_gl.scene.features import SceneFeatures  # noqa: E402

ROWS = []
COUNTERS = {"dropped": 0, "loop_limited": 0}


def render(scene, seed, spp, **kwargs):
    r = Renderer(scene, seed=seed, **kwargs)
    image = r.render(spp=spp).astype(np.float64)
    COUNTERS["dropped"] += r.stats.dropped_samples
    COUNTERS["loop_limited"] += r.stats.loop_limited
    r.release()
    return image


def row(case, expected, measured, z_image, z_block, ok, check):
    ROWS.append((case, expected, measured, z_image, z_block, "pass" if ok else "FAIL", check))


def z_summary(d1, d2, scale):
    """(image text, block text, pass) with the tests' statistic and critical values."""
    (iz, idof), (bz, bdof) = T.zero_mean_z(d1, d2, scale)
    icrit = T.critical_z(T.P_IMAGE, idof)
    excess = np.abs(bz) / T.critical_z(T.P_BLOCK, bdof)
    w = np.unravel_index(np.argmax(excess), excess.shape)
    c = int(np.argmax(np.abs(iz) / icrit))
    ok = bool(np.all(np.abs(iz) < icrit) and excess.max() < 1)
    return (f"{abs(iz[c]):.2f} ({icrit[c]:.1f})", f"{abs(bz[w]):.2f} ({T.critical_z(T.P_BLOCK, bdof[w]):.1f})", ok)


def analytic(name, fn, spp, note=""):
    scene = T.load(name)
    res, exp, img = [], [], []
    for seed in T.SEEDS:
        e = fn(scene, scene.film_size, render_offsets(spp, seed))
        i = render(scene, seed, spp)
        res.append(i - e), exp.append(e), img.append(i)
    zi, zb, ok = z_summary(*res, scale=exp[0])
    row(f"`{name}` ({spp} spp x 2): {note}", f"{np.mean(exp):.6g} (image mean)", f"{np.mean(img):.6g}",
        zi, zb, ok,
        "analytic image at the render's own subpixel positions; z of the residual")


def paired(case, a_scene, b_scene, spp, note="", float_allowance=False):
    """As the tests: the float32 allowance (1e-6 of the value) where the two scenes follow the
    same paths up to rounding (the scaled rooms), none where they sample differently."""
    b = [render(b_scene, s, spp) for s in T.SEEDS]
    d = [render(a_scene, s, spp) - bs for s, bs in zip(T.SEEDS, b)]
    zi, zb, ok = z_summary(*d, scale=b[0] if float_allowance else 0.0)
    mean_diff = float(np.mean((d[0] + d[1]) / 2))
    row(f"{case}: {note}", "difference 0", f"{mean_diff:.3g} (mean difference)", zi, zb, ok,
        "paired per-seed differences; z of their mean")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scale", type=int, default=4, help="samples per pixel: this many times the tests'")
    parser.add_argument("--photons", type=int, default=4_000_000, help="light tracer photons (caustic)")
    args = parser.parse_args()
    k = args.scale
    start = time.perf_counter()

    analytic("tiny_bright_light", floor_under_quad_light, 16 * k, "radiance 1e6, area 1e-6 of the floor")
    analytic("huge_dim_light", floor_under_quad_light, 16 * k, "1e4 x the floor's area, radiance 1e-3")
    analytic("grazing_light", floor_under_quad_light, 16 * k, "emitter standing on the floor")
    analytic("close_light", floor_under_quad_light, 16 * k, "emitter 0.02 above the floor")
    analytic("grazing_camera", ground_and_sky, 16 * k, "1 cm above a 2 km floor")
    analytic("tilted_normals", tilted_normals, 16 * k, "normals 80 deg off and authored backwards")
    analytic("ior_one", ground_and_sky, 32 * k, "smooth and rough (alpha 0.3) spheres of IOR 1")
    analytic("tir_cube", tir_cube, 4 * k, "camera inside glass; up to 1000 bounces")

    rough, smooth = T.load("near_specular"), T.load("near_specular")
    for m in smooth.materials:
        m.alpha = 0.0
    paired("`near_specular`: alpha 1e-4 minus alpha 0 (same seed)", rough, smooth, 32 * k,
           "metal and glass spheres")
    unit = T.load("scale_unit")
    for name in ("scale_1e-3", "scale_1e4", "offset_1e5"):
        paired(f"`{name}` minus `scale_unit` (same seed)", T.load(name), unit, 16 * k,
               "closed thin-walled room, sky outside", float_allowance=True)

    for albedo, depth, params, what in [(1.0, 1000, {}, "albedo 1, max depth 1000"),
                                        (0.5, 1000, {}, "roulette from bounce 4"),
                                        (0.8, 5, {"rr_depth": 10000}, "depth 5, no roulette"),
                                        (0.05, 1000, {"rr_depth": 0, "rr_min_survival": 0.01},
                                         "survival 0.05 at every bounce")]:
        scene = T.load("furnace_box")
        scene.materials[0].base_color[:] = albedo
        scene.max_depth = depth
        spp = (4 if albedo == 1.0 else 16) * k
        image = render(scene, 1, spp, params=params)[..., 0].ravel()
        expected = furnace_box(albedo, 1.0, depth)
        se = image.std(ddof=1) / math.sqrt(image.size)
        z = (image.mean() - expected) / se
        row(f"`furnace_box`: {what} ({spp} spp)", f"{expected:.6g} (geometric series)",
            f"{image.mean():.6g} +- {se:.2g}", f"{abs(z):.2f}", "-", abs(z) < T.IMAGE_Z,
            "pixel mean; standard error from the pixels' spread (all have the same expectation)")

    dirty, clean = T.load("degenerate_mesh"), T.load("degenerate_mesh_clean")
    a, b = render(dirty, 1, 8 * k), render(clean, 1, 8 * k)
    row("`degenerate_mesh` vs `degenerate_mesh_clean`", "identical images", f"max |difference| {np.abs(a - b).max():g}",
        "-", "-", np.array_equal(a, b), "bit-identical images (2 triangles dropped, 2 zero-area kept)")
    for everything in (False, True):
        e = render(T.load("empty"), 1, 4, features=SceneFeatures.everything() if everything else None)
        d = render(T.load("no_lights"), 1, 4, features=SceneFeatures.everything() if everything else None)
        label = "all features" if everything else "scene's features"
        row(f"`empty` ({label})", "sky (0.25, 0.5, 1) exactly", f"max |error| {np.abs(e - [0.25, 0.5, 1.0]).max():g}",
            "-", "-", np.array_equal(e, np.broadcast_to([0.25, 0.5, 1.0], e.shape)), "exact equality")
        row(f"`no_lights` ({label})", "0 exactly", f"max {d.max():g}", "-", "-", d.max() == 0.0, "exact equality")

    scene = T.load("caustic")
    traced, traced_var = caustic_light_tracer(scene, scene.film_size, photons=args.photons, batches=16, seed=5)
    spp = 64 * k
    a, b = (render(scene, s, spp)[..., 0] for s in T.SEEDS)
    core = traced > 0.25 * traced.max()
    for label, region in (("image", np.ones_like(core)), ("caustic core", core)):
        got, want = ((a + b) / 2)[region].sum(), traced[region].sum()
        se = math.sqrt(((a - b) ** 2 / 4)[region].sum() + traced_var[region].sum())
        z = (got - want) / se
        n = region.sum()
        row(f"`caustic`: {label} mean ({spp} spp x 2)", f"{want / n:.5g} (light tracer, {args.photons:.0e} photons)",
            f"{got / n:.5g} +- {se / n:.2g}", f"{abs(z):.2f}", "-", abs(z) < T.IMAGE_Z,
            "region mean; variance of the render's pixels plus the light tracer's batches")

    print(f"Measured on: {describe(create_context())}; {time.perf_counter() - start:.0f} s in all.\n")
    print("| case | expected | measured | image \\|z\\| (critical) | worst block \\|z\\| (critical) | result | how it is checked |")
    print("| --- | --- | --- | ---: | ---: | --- | --- |")
    for r in ROWS:
        print("| " + " | ".join(str(x) for x in r) + " |")
    print(f"\nDropped NaN/Inf samples over every render above: {COUNTERS['dropped']}; "
          f"pixel-frames cut by the driver's loop limit: {COUNTERS['loop_limited']}.")

    print("\nThe caustic converges slowly: RMSE of the path tracer's pixels against the light tracer")
    print("| spp | RMSE | RMSE x sqrt(spp) |\n| ---: | ---: | ---: |")
    for spp in (16, 64, 256, 1024):
        image = render(scene, 7, spp)[..., 0]
        rmse = float(np.sqrt(np.mean((image - traced) ** 2)))
        print(f"| {spp} | {rmse:.4g} | {rmse * math.sqrt(spp):.3g} |")


if __name__ == "__main__":
    main()
