"""Ambient occlusion as a GLSL plugin (ao) and as an OpenCL plugin (ao_cl) on the same scenes:
wall time per frame (one sample per pixel, G-buffer and accumulation included, the OpenCL
round trip through host memory included), and how long a hot reload takes (edit -> new
program), for GLSL and OpenCL plugins. Ratios are measured in one run, interleaved.

    python benchmarks/plugin_languages.py [--size 128] [--frames 32] [--rounds 3]
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.opencl import describe_device
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
SCENES = {"cornell (24 triangles, 1 sphere)": REPO / "scenes" / "cornell.toml",
          "dragon (100k triangles)": REPO.parent / "shared" / "assets" / "meshes" / "dragon_100k.ply"}


def frame_ms(renderer, frames):
    renderer.render(spp=2)  # warm up: first-use costs
    renderer.reset()
    start = time.perf_counter()
    renderer.render(spp=frames)
    return (time.perf_counter() - start) / frames * 1e3


# A real edit in each plugin: a constant that changes the compiled code, so that no compile
# cache (Mesa's, pyopencl's, PoCL's) can answer from an earlier build.
EDITS = {"ao": ("? vec3(0.0) : vec3(1.0);", "? vec3(0.0) : vec3(1.0 - {n}e-7);"),
         "ao_cl": ("(float3)(0.0f) : (float3)(1.0f);", "(float3)(0.0f) : (float3)(1.0f - {n}e-7f);"),
         "pt": ("    return L;", "    return L * (1.0 - {n}e-7);")}


def reload_ms(scene, size, name, repeats=3):
    """Edit a temporary copy of the plugin; time reload() and the first frame of the new program."""
    old, new = EDITS[name]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / name
        shutil.copytree(REPO / "plugins" / name, folder)
        renderer = Renderer(scene, size=size, integrator=str(folder))
        entry = renderer.plugin.entry_path
        original = entry.read_text()
        assert old in original
        best = float("inf")
        for _ in range(repeats):
            entry.write_text(original.replace(old, new.format(n=time.time_ns() % 1000003)))
            start = time.perf_counter()
            assert renderer.reload()
            renderer.render(spp=1)  # drivers may finish compiling at the first dispatch
            best = min(best, time.perf_counter() - start)
        renderer.release()
    return best * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--frames", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    size = (args.size, args.size)
    renderer = None
    for label, path in SCENES.items():
        if not path.is_file():
            print(f"{label}: {path} absent, skipped")
            continue
        scene = load_scene(path)
        renderers = {name: Renderer(scene, size=size, integrator=name, params={"radius": 0.5}, samples_per_frame=1)
                     for name in ("ao", "ao_cl")}
        times = {name: [] for name in renderers}
        for _ in range(args.rounds):  # interleaved: drift in the machine's load hits both alike
            for name, r in renderers.items():
                times[name].append(frame_ms(r, args.frames))
        best = {name: min(v) for name, v in times.items()}
        print(f"{label}, {args.size}x{args.size}, 1 spp a frame, best of {args.rounds}:")
        for name, values in times.items():
            print(f"  {name:6s} {best[name]:8.2f} ms/frame  ({', '.join(f'{v:.2f}' for v in values)})")
        print(f"  ao_cl / ao = {best['ao_cl'] / best['ao']:.2f}")
        renderer = renderers["ao"]
    print("hot reload: an edit, then reload() and the first frame of the new program, best of 3:")
    scene = load_scene(SCENES["cornell (24 triangles, 1 sphere)"])
    for name in ("ao", "pt", "ao_cl"):
        print(f"  {name:6s} {reload_ms(scene, size, name):8.1f} ms")
    print(f"GL: {describe(renderer.ctx)}")
    print(f"OpenCL: {describe_device()}")


if __name__ == "__main__":
    main()
