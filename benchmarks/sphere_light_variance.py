"""Variance per sample of pt with emissive spheres sampled by cone (the default) and by area
(the old sampler, LIFT_SPHERE_AREA_LIGHTS), at equal spp, on a sphere-lit scene (default:
Mitsuba's glossy_mis reference scene under ../shared), and optionally of Mitsuba 3 itself.

    .venv/bin/python benchmarks/sphere_light_variance.py [SCENE] [--size 128] [--spp 16] [--runs 32]
    DRJIT_LIBLLVM_PATH=LIBLLVM.so MITSUBA_PYTHON benchmarks/sphere_light_variance.py --mitsuba [SCENE] ...

Each variant renders the image `runs` times with independent seeds, interleaved; the variance
of a pixel over the runs times spp is its variance per sample. Reported: the mean over pixels
of that variance, plain and relative (divided by ref^2 + 1e-2 as relMSE does; ref: the
reference.npy beside the scene, box-downsampled to the size, else the mean image), the ratio
area / cone of each (the variance reduction per sample), and the image means with their
standard errors (the variants must agree).
"""
from __future__ import annotations

import argparse
import math
import pathlib
import time

import numpy as np

DEFAULT = pathlib.Path(__file__).resolve().parents[1] / ".." / "shared" / "refs" / "mitsuba" / "glossy_mis" / "scene.xml"


def lift_variants():
    from lift_gl.renderer import Renderer

    class AreaRenderer(Renderer):
        """The old sphere sampler: points uniform on the sphere's area."""

        def _shader_defines(self) -> dict:
            return dict(super()._shader_defines(), LIFT_SPHERE_AREA_LIGHTS=True)

    return {"cone": Renderer, "area": AreaRenderer}


def render_lift(cls, scene, size, spp, seed):
    r = cls(scene, size=(size, size), seed=seed)
    image = r.render(spp=spp).astype(np.float64)
    assert r.stats.dropped_samples == 0, r.stats.dropped_samples
    r.release()
    return image


def reference(scene_path: pathlib.Path, size: int):
    path = scene_path.parent / "reference.npy"
    if not path.exists():
        return None
    ref = np.load(path).astype(np.float64)[..., :3]
    f = ref.shape[0] // size
    return ref.reshape(size, f, size, f, 3).mean(axis=(1, 3))


def summarise(stacks: dict, spp: int, ref, save=None) -> dict:
    if ref is None:
        ref = np.mean([s.mean(axis=0) for s in stacks.values()], axis=0)
    out = {}
    for name, s in stacks.items():
        per_sample = s.var(axis=0, ddof=1) * spp
        if save:
            np.save(pathlib.Path(save) / f"variance_{name}.npy", per_sample.astype(np.float32))
        means = s.reshape(len(s), -1).mean(axis=1)
        out[name] = (per_sample.mean(), (per_sample / (ref ** 2 + 1e-2)).mean(),
                     means.mean(), means.std(ddof=1) / math.sqrt(len(means)))
        print(f"{name}: variance per sample {out[name][0]:.4g} (relative {out[name][1]:.4g}); "
              f"image mean {out[name][2]:.5f} +- {out[name][3]:.5f}")
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", nargs="?", default=str(DEFAULT))
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=32)
    parser.add_argument("--mitsuba", action="store_true", help="render with Mitsuba 3 instead (its Python)")
    parser.add_argument("--save", help="folder for the per-pixel variance maps (variance_NAME.npy)")
    parser.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (scalar_rgb needs no LLVM)")
    args = parser.parse_args()
    path = pathlib.Path(args.scene)
    ref = reference(path, args.size)
    if args.mitsuba:
        import mitsuba as mi
        mi.set_variant(args.variant)
        scene = mi.load_file(str(path))
        film_size = scene.sensors()[0].film().size()
        assert int(film_size[0]) == args.size, f"the scene's film is {film_size}: pass --size {film_size[0]}"
        images = [np.array(mi.render(scene, spp=args.spp, seed=run + 1), np.float64)[..., :3] for run in range(args.runs)]
        summarise({"mitsuba": np.stack(images)}, args.spp, ref, args.save)
        return
    from lift_gl.scene.loader import load_scene
    scene = load_scene(path)
    variants = lift_variants()
    images = {name: [] for name in variants}
    seconds = {name: 0.0 for name in variants}
    for run in range(args.runs):
        for name, cls in variants.items():  # interleaved: both see the same machine load
            start = time.perf_counter()
            images[name].append(render_lift(cls, scene, args.size, args.spp, 1000 * run + (name == "area")))
            seconds[name] += time.perf_counter() - start
    result = summarise({name: np.stack(v) for name, v in images.items()}, args.spp, ref, args.save)
    print(f"area / cone, per sample: variance {result['area'][0] / result['cone'][0]:.2f}x, "
          f"relative variance {result['area'][1] / result['cone'][1]:.2f}x; wall time cone / area "
          f"{seconds['cone'] / seconds['area']:.2f}x ({args.runs} x {args.spp} spp at {args.size}x{args.size})")
    t = (result["cone"][2] - result["area"][2]) / math.hypot(result["cone"][3], result["area"][3])
    print(f"image means differ by t = {t:.2f}")


if __name__ == "__main__":
    main()
