"""A set of tiny renders that covers what a Renderer puts together: every built-in plugin, the
denoise modes, temporal reprojection, motion blur, instances, the AOVs, scene edits, hot
reload, resizing and the options that change the shaders' defines.

It uses the public Renderer API only, so that two versions of lift-gl can be compared bit for
bit on one driver (a refactoring must give the same images):

    python tests/frame_images.py --out before.npz                     # one version
    PYTHONPATH=/path/to/other/tree python tests/frame_images.py --out after.npz
    python tests/frame_images.py --compare before.npz after.npz

tests/test_frame_images.py checks the renders against the digests recorded on llvmpipe.
"""
from __future__ import annotations

import argparse
import copy
import dataclasses
import hashlib
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"


def _cornell():
    from lift_gl import load_scene

    return load_scene(SCENES / "cornell.toml")


def _shifted(camera, dx: float):
    step = np.array([dx, 0.0, 0.0])
    return dataclasses.replace(camera, position=camera.position + step, target=camera.target + step)


def _plugin(name: str, scene: str = "cornell.toml", size=(16, 12), spp=2, **kw) -> dict:
    from lift_gl import load_scene
    from lift_gl.renderer import Renderer

    r = Renderer(load_scene(SCENES / scene), size=size, integrator=name, seed=3, **kw)
    try:
        return {"image": r.render(spp=spp)}
    finally:
        r.release()


def _options(**values) -> dict:
    from lift_gl.options import Options
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(16, 12), seed=4, options=Options(**values))
    try:
        return {"image": r.render(spp=2)}
    finally:
        r.release()


def _denoise(mode: str, integrator: str = "pt") -> dict:
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(16, 12), integrator=integrator, seed=5, denoise=mode)
    try:
        out = {"image": r.render(spp=2), "noisy": r.noisy_image(), "display": r.display()}
        out["display_noisy"] = r.display(source="noisy")
        r.set_denoise(mode="final" if mode == "every" else "every")
        out["switched"] = r.render(spp=1)
        return out
    finally:
        r.release()


def _reproject(**settings) -> dict:
    """Renderer keywords for temporal reprojection with `settings` (min_blend, clamp_sigma)."""
    try:
        from lift_gl.frame_settings import TemporalSettings
    except ImportError:   # a version of lift-gl that took them as keywords of their own
        return {"temporal": "reproject", **settings}
    return {"temporal": TemporalSettings("reproject", **settings)}


def _temporal() -> dict:
    from lift_gl.renderer import Renderer

    scene = _cornell()
    r = Renderer(scene, size=(16, 12), seed=6, **_reproject(clamp_sigma=1.0))
    try:
        out = {"still": r.render(spp=2)}
        r.set_camera(_shifted(scene.camera, 0.1))
        out["moved"] = r.render(spp=2)
        for name in ("history", "rejection", "variance"):
            out[name] = r.aov(name)
        moved = copy.deepcopy(r.scene)
        moved.spheres[0].center = np.asarray(moved.spheres[0].center) + np.array([0.05, 0.0, 0.0])
        r.update_scene(moved)
        out["object moved"] = r.render(spp=2)
        return out
    finally:
        r.release()


def _aovs() -> dict:
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(16, 12), seed=7)
    try:
        out = {"image": r.render(spp=2)}
        for name in ("albedo", "normal", "depth", "history", "variance", "irradiance"):
            out[name] = r.aov(name)
        out["display"] = r.display(exposure=0.5, operator="reinhard")
        return out
    finally:
        r.release()


def _camera_plugin_aovs() -> dict:
    """A plugin without a G-buffer: its guides' G-buffer is made when an AOV first asks."""
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(16, 12), integrator="drt", seed=8)
    try:
        return {"image": r.render(spp=4), "albedo": r.aov("albedo"), "after": r.render(spp=4)}
    finally:
        r.release()


def _edits() -> dict:
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(16, 12), seed=9)
    try:
        out = {"image": r.render(spp=2)}
        scene = copy.deepcopy(r.scene)
        scene.materials[0].base_color = np.asarray(scene.materials[0].base_color) * 0.5
        r.update_scene(scene, geometry=False)
        out["colour"] = r.render(spp=2)
        scene = copy.deepcopy(r.scene)
        scene.spheres[0].radius *= 1.2
        r.update_scene(scene)
        out["geometry"] = r.render(spp=2)
        r.set_params(max_depth=3)
        out["params"] = r.render(spp=2)
        r.resize((12, 10))
        out["resized"] = r.render(spp=2)
        r.reload(force=True)
        out["reloaded"] = r.render(spp=2)
        r.reset(seed=11)
        out["reseeded"] = r.render(spp=2)
        return out
    finally:
        r.release()


def _bdpt_define() -> dict:
    from lift_gl.renderer import Renderer

    r = Renderer(_cornell(), size=(12, 10), integrator="bdpt", seed=10)
    try:
        out = {"image": r.render(spp=1)}
        r.set_params(max_depth=3)   # a compile-time parameter (`define` in its manifest)
        out["depth 3"] = r.render(spp=1)
        return out
    finally:
        r.release()


def _instances() -> dict:
    return _plugin("pt", "instances.toml", size=(16, 12), spp=2)


def _motion() -> dict:
    return _plugin("drt", "motion_blur.toml", size=(16, 12), spp=4)


def _hybrid() -> dict:
    return _plugin("hybrid", size=(16, 12), spp=2, params={"indirect_scale": 2})


CASES = {
    "pt": lambda: _plugin("pt"),
    "bdpt": lambda: _plugin("bdpt", size=(12, 10), spp=1),
    "drt": lambda: _plugin("drt", "dof.toml", spp=4),
    "ao": lambda: _plugin("ao"),
    "ao_cl": lambda: _plugin("ao_cl"),
    "debug": lambda: _plugin("debug"),
    "template": lambda: _plugin("template"),
    "hybrid": _hybrid,
    "pt samples_per_frame": lambda: _plugin("pt", spp=4, samples_per_frame=2),
    "denoise final": lambda: _denoise("final"),
    "denoise every": lambda: _denoise("every"),
    "denoise drt": lambda: _denoise("final", "drt"),
    "temporal": _temporal,
    "motion": _motion,
    "instances": _instances,
    "aovs": _aovs,
    "camera plugin aovs": _camera_plugin_aovs,
    "edits": _edits,
    "bdpt define": _bdpt_define,
    "binary bvh": lambda: _options(bvh_width="2"),
    "wide bvh, node groups, paired": lambda: _options(bvh_width="4", bvh_stack="shared",
                                                      bvh_stack_entries="groups", trace_paired="on"),
    "pixel queue": lambda: _options(pixel_queue="on"),
    "coherent sampling": lambda: _options(coherent_sampling="on", coherent_interleave=2),
    "traced gbuffer": lambda: _options(gbuffer="traced"),
    "storage buffers": lambda: _options(uniform_blocks="off"),
}


def render_all(names=None) -> dict[str, np.ndarray]:
    """'case/key' -> array, for the CASES named (all by default)."""
    out = {}
    for name in names or CASES:
        for key, array in CASES[name]().items():
            out[f"{name}/{key}"] = np.ascontiguousarray(array)
    return out


# Plugins that splat (bdpt's light tracing) add to pixels with float atomics, whose order, and
# so the last bits of a sum, change from run to run: their images are compared within this.
ATOMIC_SUMS = ("bdpt", "bdpt define")
ATOMIC_RTOL, ATOMIC_ATOL = 1e-5, 1e-7


def atomic_sums(key: str) -> bool:
    return key.split("/")[0] in ATOMIC_SUMS


def digest(array: np.ndarray) -> str:
    return hashlib.sha256(array.dtype.str.encode() + str(array.shape).encode() + array.tobytes()).hexdigest()[:16]


def same(key: str, a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit, or within the rounding of float atomics for the ATOMIC_SUMS cases."""
    if atomic_sums(key):
        return a.shape == b.shape and np.allclose(a, b, rtol=ATOMIC_RTOL, atol=ATOMIC_ATOL)
    return digest(a) == digest(b)


def compare(a: dict, b: dict) -> list[str]:
    """The keys whose arrays differ (or that only one set has)."""
    return sorted(k for k in set(a) | set(b) if k not in a or k not in b or not same(k, a[k], b[k]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", help="write the renders to this .npz")
    parser.add_argument("--compare", nargs=2, metavar="NPZ", help="compare two sets bit for bit")
    parser.add_argument("--cases", help="comma-separated case names (default: all)")
    args = parser.parse_args(argv)
    if args.compare:
        a, b = (dict(np.load(path)) for path in args.compare)
        differ = compare(a, b)
        for key in differ:
            print(f"differs: {key}")
        print(f"{len(set(a) | set(b)) - len(differ)} of {len(set(a) | set(b))} arrays the same (bit for bit, "
              f"but {', '.join(ATOMIC_SUMS)} within float atomics' rounding)")
        return 1 if differ else 0
    import lift_gl

    print(f"lift_gl from {Path(lift_gl.__file__).parent}")
    images = render_all(args.cases.split(",") if args.cases else None)
    for key, array in images.items():
        print(f"{digest(array)}  {key}")
    if args.out:
        np.savez(args.out, **images)
    return 0


if __name__ == "__main__":
    sys.exit(main())
