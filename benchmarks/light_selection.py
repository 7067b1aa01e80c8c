"""pt's error per sample with each light selection (the option light_selection: power, tree)
against Mitsuba 3's `path`, at equal spp, on Mitsuba's reference scenes and on lift-gl's own
many-light scenes.

    python benchmarks/light_selection.py lift [--out out/light_selection] [--spp 16,64,256] [--seeds 2]
    MITSUBA_PYTHON benchmarks/light_selection.py mitsuba [--out ...] [--variant scalar_rgb] [--ref-spp 4096]
    python benchmarks/light_selection.py table [--out ...] [--table benchmarks/results/light_selection.md]

`lift` renders each scene with pt at each spp, once a seed, with light_selection=power (the
old selection, the baseline) and =tree interleaved, and writes each image (.npy) and its
seconds. `mitsuba` (a Python with `mitsuba`; lift_gl on PYTHONPATH) renders the same scenes
with Mitsuba 3 at the same spp and seeds, and the references that ../shared lacks (lift-gl's
own scenes, which the lift command exports with export_mitsuba.py, at --ref-spp). `table` writes relMSE (mean over
seeds) of each against the reference, relMSE x spp (per sample: constant where noise
dominates), the ratio of tree to Mitsuba, the seconds per sample of each selection, and
per-pixel variance maps (variance x spp over the seeds, relative: / (ref^2 + 0.01)) as PNGs
beside the images.
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
# name: (scene file, Mitsuba scene or None to export, reference or None to render with Mitsuba)
SCENES = {
    "cbox": (SHARED / "refs/mitsuba/cbox/scene.xml", SHARED / "refs/mitsuba/cbox/scene.xml",
             SHARED / "refs/mitsuba/cbox/reference.npy"),
    "furnace": (SHARED / "refs/mitsuba/furnace/scene.xml", SHARED / "refs/mitsuba/furnace/scene.xml",
                SHARED / "refs/mitsuba/furnace/reference.npy"),
    "glossy_mis": (SHARED / "refs/mitsuba/glossy_mis/scene.xml", SHARED / "refs/mitsuba/glossy_mis/scene.xml",
                   SHARED / "refs/mitsuba/glossy_mis/reference.npy"),
    "many_lights": (REPO / "scenes/many_lights.toml", None, None),
    "glass_caustic": (REPO / "scenes/glass_caustic.toml", None, None),
}
SELECTIONS = ("power", "tree")
REL_EPS = 1e-2


def _spps(text: str) -> list[int]:
    return [int(v) for v in text.split(",")]


def _machine() -> str:
    import os
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}"


def run_lift(out: Path, spps: list[int], seeds: int, names: list[str]) -> None:
    from lift_gl import load_scene
    from lift_gl.options import Options
    from lift_gl.renderer import Renderer
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        if SCENES[name][1] is None:  # Mitsuba's copy of a lift-gl scene, for the mitsuba command
            subprocess.run([sys.executable, str(REPO / "benchmarks/export_mitsuba.py"), str(SCENES[name][0]),
                            str(out / f"{name}_mitsuba_scene"), "--size", "128"], check=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = load_scene(SCENES[name][0])
        info = {"machine": _machine(), "seconds": {}}
        for spp in spps:
            for seed in range(1, seeds + 1):
                for selection in SELECTIONS:  # interleaved: both see the same load
                    r = Renderer(scene, size=(128, 128), seed=seed, options=Options(light_selection=selection))
                    r.render(spp=1)  # compile and warm up outside the timing
                    r.reset()
                    start = time.perf_counter()
                    image = r.render(spp=spp)
                    seconds = time.perf_counter() - start
                    assert r.stats.dropped_samples == 0, (name, selection, r.stats.dropped_samples)
                    info["seconds"][f"{selection}_{spp}_{seed}"] = seconds
                    info.setdefault("chosen", {})[selection] = r.choices.choices["light_selection"].text()
                    r.release()
                    np.save(out / f"{name}_{selection}_{spp}_{seed}.npy", image.astype(np.float32))
                    print(name, selection, spp, seed, f"{seconds:.2f} s", flush=True)
        (out / f"{name}_lift.json").write_text(json.dumps(info, indent=2))


def run_mitsuba(out: Path, spps: list[int], seeds: int, names: list[str], variant: str, ref_spp: int) -> None:
    import mitsuba as mi
    mi.set_variant(variant)
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        scene_file, xml, ref = SCENES[name]
        if xml is None:  # written by the lift command (export_mitsuba.py needs lift-gl's packages)
            xml = out / f"{name}_mitsuba_scene" / "scene.xml"
        scene = mi.load_file(str(xml))
        info = {"machine": _machine(), "variant": variant, "seconds": {}}
        if ref is None and not (out / f"{name}_reference.npy").exists():
            start = time.perf_counter()
            image = np.zeros((128, 128, 3))
            chunk = 256
            for k in range(ref_spp // chunk):  # chunks of independent seeds: bounded memory
                image += np.array(mi.render(scene, spp=chunk, seed=1000 + k))[..., :3]
            np.save(out / f"{name}_reference.npy", (image / (ref_spp // chunk)).astype(np.float32))
            info["reference"] = {"spp": ref_spp, "seconds": time.perf_counter() - start}
            print(name, "reference", info["reference"], flush=True)
        for spp in spps:
            for seed in range(1, seeds + 1):
                start = time.perf_counter()
                image = np.array(mi.render(scene, spp=spp, seed=seed))[..., :3]
                info["seconds"][f"{spp}_{seed}"] = time.perf_counter() - start
                np.save(out / f"{name}_mitsuba_{spp}_{seed}.npy", image.astype(np.float32))
                print(name, "mitsuba", spp, seed, flush=True)
        (out / f"{name}_mitsuba.json").write_text(json.dumps(info, indent=2))


def _reference(out: Path, name: str) -> np.ndarray:
    ref = SCENES[name][2]
    return np.load(ref if ref is not None else out / f"{name}_reference.npy").astype(np.float64)[..., :3]


def _variance_map(images: list[np.ndarray], ref: np.ndarray, spp: int, path: Path) -> None:
    """Relative variance per sample of each pixel, over the seeds, as a grey PNG (log scale)."""
    from PIL import Image
    var = np.var(np.stack(images), axis=0, ddof=1).mean(axis=-1) * spp / (ref.mean(axis=-1) ** 2 + REL_EPS)
    level = np.clip((np.log10(np.maximum(var, 1e-6)) + 4.0) / 6.0, 0.0, 1.0)  # 1e-4 .. 1e2
    Image.fromarray((level * 255).astype(np.uint8)).save(path)


def table(out: Path, spps: list[int], seeds: int, names: list[str], target: Path | None) -> None:
    lines = ["pt's relMSE against Mitsuba 3 `path` at equal spp (128x128, mean over "
             f"{seeds} seeds; relMSE = mean((x - ref)^2 / (ref^2 + 0.01))). power: emitters picked by "
             "power (the old selection); tree: the light tree. x spp: relMSE times spp (per sample).", "",
             "| scene | spp | power | tree | Mitsuba 3 | tree / Mitsuba | power x spp | tree x spp | Mitsuba x spp "
             "| ms a sample, power / tree |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    result = {}
    for name in names:
        ref = _reference(out, name)
        lift = json.loads((out / f"{name}_lift.json").read_text())
        for spp in spps:
            err = {}
            for kind in (*SELECTIONS, "mitsuba"):
                images = [np.load(out / f"{name}_{kind}_{spp}_{s}.npy").astype(np.float64)[..., :3]
                          for s in range(1, seeds + 1)]
                err[kind] = float(np.mean([np.mean((x - ref) ** 2 / (ref ** 2 + REL_EPS)) for x in images]))
                if seeds > 1:
                    _variance_map(images, ref, spp, out / f"{name}_{kind}_{spp}_variance.png")
            ms = {sel: 1e3 * np.mean([lift["seconds"][f"{sel}_{spp}_{s}"] for s in range(1, seeds + 1)]) / spp
                  for sel in SELECTIONS}
            result[f"{name}_{spp}"] = {**err, "ms_per_sample": ms}
            lines.append(f"| {name} | {spp} | {err['power']:.4g} | {err['tree']:.4g} | {err['mitsuba']:.4g} | "
                         f"{err['tree'] / err['mitsuba']:.2f} | {err['power'] * spp:.3g} | {err['tree'] * spp:.3g} | "
                         f"{err['mitsuba'] * spp:.3g} | {ms['power']:.2f} / {ms['tree']:.2f} |")
    chosen = {name: json.loads((out / f"{name}_lift.json").read_text()).get("chosen", {}) for name in names}
    machine = json.loads((out / f"{names[0]}_lift.json").read_text())["machine"]
    lines += ["", f"Machine: {machine}, Mesa llvmpipe; Mitsuba 3.9.1 "
              f"{json.loads((out / f'{names[0]}_mitsuba.json').read_text())['variant']}. References: "
              "../shared/refs/mitsuba (Mitsuba 3, thousands of spp); many_lights: Mitsuba 3 at "
              "the `mitsuba` command's --ref-spp, on export_mitsuba.py's copy of the scene."]
    text = "\n".join(lines) + "\n"
    print(text)
    (out / "table.json").write_text(json.dumps({"result": result, "chosen": chosen}, indent=2))
    if target is not None:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=("lift", "mitsuba", "table"))
    parser.add_argument("--out", type=Path, default=Path("out/light_selection"))
    parser.add_argument("--spp", type=_spps, default=[16, 64, 256])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--variant", default="scalar_rgb")
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--table", type=Path)
    args = parser.parse_args()
    names = args.scenes.split(",")
    if args.command == "lift":
        run_lift(args.out, args.spp, args.seeds, names)
    elif args.command == "mitsuba":
        run_mitsuba(args.out, args.spp, args.seeds, names, args.variant, args.ref_spp)
    else:
        table(args.out, args.spp, args.seeds, names, args.table)


if __name__ == "__main__":
    main()
