"""Which of veach-bidir's two emitters, at what strength, makes Tungsten's reference
(Tungsten's image is 2.4x brighter than lift-gl's render of the Mitsuba 0.5 file).

    python benchmarks/veach_bidir_emitters.py render [--size 128] [--spp 512] [--integrator pt]
        [--emitters spot,floor_lamp] [--depths file,deep] [--out out/veach_bidir]
    python benchmarks/veach_bidir_emitters.py fit [--out out/veach_bidir] [--table benchmarks/results/veach_bidir_emitters.md]

`render` renders with one emitter at a time (the small rectangle inside the wall spotlight's
housing; the rectangle inside the floor lamp's shade that lights the ceiling), each at the
file's path length (maxDepth 7: 6 bounces) and at 64 bounces, as two independent halves
(seeds 1 and 2) so that each image's noise is known; `--integrator bdpt --emitters spot
--depths deep` re-renders the spot, whose light leaves a glossy housing (fireflies in `pt`).
Light is linear in the emitters, so the reference is a*spot + b*floor_lamp, with a = b = 1 if
the file is the scene Tungsten rendered. `fit` solves for (a, b) by least squares on
16x16-pixel block means (per channel and on luminance; from each half alone for the spread)
and writes a markdown table.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
SCENE = "scenes_bitterli/veach-bidir/scene.xml"
REFERENCE = "refs/bitterli/veach-bidir.exr"
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
# In the file's order: the rectangle inside the wall spotlight's housing (line 59), the one
# inside the floor lamp's shade, facing the ceiling (line 104, beside the <hide> element).
EMITTERS = ("spot", "floor_lamp")
DEPTHS = {"file": None, "deep": 64}


def _scene_with_one_emitter(keep: str):
    from lift_gl import load_scene
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(SHARED / SCENE)
    emissive = [m for m in scene.materials if m.is_emissive]
    assert len(emissive) == 2, [m.name for m in emissive]
    for name, material in zip(EMITTERS, emissive):
        if name != keep:
            material.emission = np.zeros(3)
    return scene


def render(out: Path, size: int, spp: int, integrator: str, emitters, depths) -> None:
    from lift_gl.image_io import write_image
    from lift_gl.renderer import Renderer
    out.mkdir(parents=True, exist_ok=True)
    for emitter in emitters:
        for depth_name in depths:
            depth = DEPTHS[depth_name]
            name = f"{emitter}_{depth_name}"
            params = None if depth is None else {"max_depth": depth}
            start = time.perf_counter()
            halves = []
            for seed in (1, 2):
                r = Renderer(_scene_with_one_emitter(emitter), size=(size, size), integrator=integrator,
                             seed=seed, params=params)
                halves.append(r.render(spp=spp // 2))
                r.release()
            for key, image in zip("ab", halves):
                write_image(out / f"{name}_{key}.exr", image)
            info = {"integrator": integrator, "spp": spp, "size": size, "params": params,
                    "seconds": time.perf_counter() - start}
            (out / f"{name}.json").write_text(json.dumps(info))
            print(name, info, flush=True)


def _half(out: Path, name: str, key: str) -> np.ndarray:
    from lift_gl.image_io import read_image
    return read_image(out / f"{name}_{key}.exr").astype(np.float64)


def _image(out: Path, name: str) -> np.ndarray:
    return 0.5 * (_half(out, name, "a") + _half(out, name, "b"))


def _scales(ref: np.ndarray, parts: list[np.ndarray]) -> np.ndarray:
    """Least squares ref ~ sum c_i part_i over all values; block means first, which average
    away most of the noise, and no relMSE weights, which fireflies would dominate."""
    A = np.stack([p.ravel() for p in parts], axis=1)
    return np.linalg.lstsq(A, ref.ravel(), rcond=None)[0]


def fit(out: Path, table: Path | None, block: int = 16) -> None:
    from lift_gl import metrics
    from lift_gl.image_io import read_image
    spot_info = json.loads((out / "spot_deep.json").read_text())
    size = spot_info["size"]
    ref = read_image(SHARED / REFERENCE).astype(np.float64)
    ref = metrics.box_downsample(ref, ref.shape[0] // size)
    lum = lambda x: x @ LUMINANCE  # noqa: E731
    ref_mean = lum(ref).mean()
    lines = [f"veach-bidir, {size}x{size}: Tungsten's reference (box-downsampled) against lift-gl with one "
             f"emitter at a time, {spot_info['spp']} spp each.", "",
             "| image | integrator | mean luminance | / Tungsten's |", "|---|---|---|---|"]
    rows = {}
    for emitter in EMITTERS:
        for depth_name, depth in DEPTHS.items():
            if (out / f"{emitter}_{depth_name}.json").exists():
                rows[(emitter, depth_name)] = _image(out, f"{emitter}_{depth_name}")
                bounces = "6 bounces (the file's maxDepth 7)" if depth is None else f"{depth} bounces"
                mean = lum(rows[(emitter, depth_name)]).mean()
                integrator = json.loads((out / f"{emitter}_{depth_name}.json").read_text())["integrator"]
                lines.append(f"| {emitter} alone, {bounces} | {integrator} | {mean:.4f} | {mean / ref_mean:.3f} |")
    for depth_name in DEPTHS:
        if all((e, depth_name) in rows for e in EMITTERS):
            mean = lum(sum(rows[(e, depth_name)] for e in EMITTERS)).mean()
            lines.append(f"| both, {depth_name} depth | | {mean:.4f} | {mean / ref_mean:.3f} |")
    lines.append(f"| Tungsten | | {ref_mean:.4f} | 1 |")
    lines += ["", f"Least-squares scales, reference ~ a*spot + b*floor_lamp (64 bounces) on {block}x{block}-pixel "
              "block means:", "",
              "| fitted on | a (spot) | b (floor lamp) | b x 156.3258 | correlation of fit and reference |",
              "|---|---|---|---|---|"]
    down = lambda x: metrics.box_downsample(x, block)  # noqa: E731
    R = down(ref)
    result = []
    for key in ("both halves", "half a", "half b"):
        if key == "both halves":
            S, T = down(rows[("spot", "deep")]), down(rows[("floor_lamp", "deep")])
        else:
            S, T = (down(_half(out, f"{e}_deep", key[-1])) for e in EMITTERS)
        for channel, pick in (("luminance", lum), ("red", lambda x: x[..., 0]), ("green", lambda x: x[..., 1]),
                              ("blue", lambda x: x[..., 2])):
            if key != "both halves" and channel != "luminance":
                continue
            a, b = _scales(pick(R), [pick(S), pick(T)])
            corr = float(np.corrcoef((a * pick(S) + b * pick(T)).ravel(), pick(R).ravel())[0, 1])
            result.append({"fitted_on": f"{key}, {channel}", "a": a, "b": b, "correlation": corr})
            lines.append(f"| {key}, {channel} | {a:.3f} | {b:.3f} | {b * 156.3258:.1f} | {corr:.5f} |")
    fitted = result[0]["a"] * rows[("spot", "deep")] + result[0]["b"] * rows[("floor_lamp", "deep")]
    lines += ["", f"Mean luminance of the fitted sum / Tungsten's: {lum(fitted).mean() / ref_mean:.3f}."]
    text = "\n".join(lines) + "\n"
    print(text)
    (out / "fit.json").write_text(json.dumps(result, indent=2))
    if table is not None:
        table.parent.mkdir(parents=True, exist_ok=True)
        table.write_text(text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=("render", "fit"))
    parser.add_argument("--out", type=Path, default=Path("out/veach_bidir"))
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--spp", type=int, default=512)
    parser.add_argument("--integrator", default="pt")
    parser.add_argument("--emitters", default=",".join(EMITTERS))
    parser.add_argument("--depths", default=",".join(DEPTHS))
    parser.add_argument("--table", type=Path, help="fit: also write the table here (markdown)")
    args = parser.parse_args()
    if args.command == "render":
        render(args.out, args.size, args.spp, args.integrator, args.emitters.split(","), args.depths.split(","))
    else:
        fit(args.out, args.table)


if __name__ == "__main__":
    main()
