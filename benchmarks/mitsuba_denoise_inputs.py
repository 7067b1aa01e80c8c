"""The denoisers on Mitsuba 3's own noisy renders: the same input for lift-gl's network and OIDN.

Renders each scene of ../shared/refs/mitsuba/ (or of --refs, --names) with Mitsuba 3's own
integrator at 1, 4 and 16 spp, with the first hit's albedo and shading normal of the same
render (Mitsuba's `aov` integrator around the scene's), and writes them, with the folder's
converged reference, in the layout of `denoise_quality.py render` (NAME/noisy1, albedo1,
normal1, ..., reference): `denoise_quality.py evaluate` then scores the denoisers on them, with
each spp level's own guides. No lift-gl renderer takes part, so the comparison is the input
alone: lift-gl's network against OIDN on the noise of another renderer.

    pip install mitsuba
    python benchmarks/mitsuba_denoise_inputs.py --out /tmp/mitsuba_inputs.npz
    python benchmarks/denoise_quality.py evaluate /tmp/mitsuba_inputs.npz --denoisers onnx,oidn
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from denoise_quality import SPP, guide_key, noisy_key  # noqa: E402  the layout it writes

REPO = Path(__file__).resolve().parents[1]
REFS = REPO.parent / "shared" / "refs" / "mitsuba"


def mitsuba_views(scene_xml: Path, spp_levels=SPP, seed: int = 1) -> dict:
    """{spp: (noisy, albedo, normal)} of Mitsuba's renders (scalar_rgb), float32 H x W x 3."""
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    scene = mi.load_file(str(scene_xml))
    aov = mi.load_dict({"type": "aov", "aovs": "albedo:albedo,nn:sh_normal", "image": scene.integrator()})
    views = {}
    for k, spp in enumerate(spp_levels):
        img = np.asarray(mi.render(scene, integrator=aov, spp=spp, seed=seed * 1000 + k), np.float32)
        if img.shape[-1] != 9:
            raise SystemExit(f"{scene_xml}: expected R, G, B, albedo and normal from Mitsuba's aov integrator, "
                             f"got {img.shape[-1]} channels")
        views[spp] = (img[..., :3], img[..., 3:6], img[..., 6:9])
    return views


def scene_arrays(name: str, scene_xml: Path, reference: np.ndarray, seed: int) -> dict:
    arrays = {f"{name}/reference": reference.astype(np.float16)}
    for spp, (noisy, albedo, normal) in mitsuba_views(scene_xml, seed=seed).items():
        arrays[f"{name}/{noisy_key(spp)}"] = noisy.astype(np.float16)
        arrays[f"{name}/{guide_key('albedo', spp)}"] = albedo.astype(np.float16)
        arrays[f"{name}/{guide_key('normal', spp)}"] = normal.astype(np.float16)
    # the default guides (NAME/albedo, NAME/normal): the highest level's, the least aliased
    for kind in ("albedo", "normal"):
        arrays[f"{name}/{kind}"] = arrays[f"{name}/{guide_key(kind, SPP[-1])}"]
    return arrays


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the npz to write")
    ap.add_argument("--refs", type=Path, default=REFS,
                    help="folders NAME/scene.xml with NAME/reference.npy (default ../shared/refs/mitsuba)")
    ap.add_argument("--names", default="", help="comma-separated folder names (default: all with a reference)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    if not a.refs.is_dir():
        raise SystemExit(f"{a.refs}: no such folder (the shared references; --refs names another)")
    names = [n for n in a.names.split(",") if n] or sorted(
        p.name for p in a.refs.iterdir() if (p / "scene.xml").exists() and (p / "reference.npy").exists())
    arrays = {}
    for name in names:
        folder = a.refs / name
        arrays.update(scene_arrays(name, folder / "scene.xml", np.load(folder / "reference.npy"), a.seed))
        print(f"rendered {name}", flush=True)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(a.out, **arrays)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
