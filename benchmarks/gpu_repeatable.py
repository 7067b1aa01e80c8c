"""Whether a GPU renders the same frames twice: pt rendered by two renderers with one seed, N
frames each, without and with the pixel queue (the option pixel_queue), images compared bit for bit.

    python benchmarks/gpu_repeatable.py SCENE... [--size 1920x1080] [--frames 3]

A pass whose writes the next one reads before they are done (a missing memory barrier) shows
up here as pixels that differ from run to run in frames after the first (docs/gpu.md, "How a
frame runs": every compute pass ends with a memory barrier).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gpu import scene_name  # noqa: E402


def render(path, size, frames, queue):
    from lift_gl.options import Options
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    r = Renderer(load_scene(path), size=size, integrator="pt", seed=3, options=Options(pixel_queue=queue))
    try:
        return r.render(spp=frames).astype(np.float64)
    finally:
        r.release()


def main(argv=None) -> int:
    from lift_gl.cli import _size

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--frames", type=int, default=3)
    args = ap.parse_args(argv)
    size = _size(args.size)
    same = True
    for path in args.scenes:
        images = {name: render(path, size, args.frames, queue)
                  for name, queue in (("off", "off"), ("off2", "off"), ("on", "on"))}
        for a, b in (("off", "off2"), ("off", "on")):
            d = np.abs(images[a] - images[b])
            differing = int((d.max(axis=-1) > 0).sum())
            same &= differing == 0
            print(f"{scene_name(path)} {a} {b}: "
                  f"max {float(d.max()):.3g}, pixels differing {differing}", flush=True)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
