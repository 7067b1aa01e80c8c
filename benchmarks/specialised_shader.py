"""Trace-pass GPU time of the shader specialised to a scene's features vs. one compiled with
every feature, on the same scene and settings (timer queries; ratio measured in one run).

    python benchmarks/specialised_shader.py [SCENE] [--size 128] [--frames 64]
"""
from __future__ import annotations

import argparse
from pathlib import Path

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.renderer import Renderer
from lift_gl.scene.features import SceneFeatures

DEFAULT = Path(__file__).resolve().parent.parent.parent / "shared/scenes_lift/cornell-box/scene.pbrt"


def trace_ms(scene, size, frames, features):
    renderer = Renderer(scene, size=(size, size), features=features, timers=True)
    renderer.render(spp=4)  # warm up
    renderer.reset()
    renderer.timers["trace"].total_ns = renderer.timers["trace"].count = 0
    renderer.render(spp=frames)
    return renderer.stats.pass_ms["trace"], renderer


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("scene", nargs="?", default=str(DEFAULT))
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--frames", type=int, default=64)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    scene = load_scene(args.scene)
    results = {"specialised": [], "everything": []}
    for _ in range(args.rounds):  # interleaved, so drift in machine load hits both alike
        ms, renderer = trace_ms(scene, args.size, args.frames, None)
        results["specialised"].append(ms)
        ms, _ = trace_ms(scene, args.size, args.frames, SceneFeatures.everything())
        results["everything"].append(ms)
    print(f"device: {describe(renderer.ctx)}")
    print(f"scene: {args.scene}  features: {', '.join(renderer.features.defines()) or 'none'}")
    best = {k: min(v) for k, v in results.items()}
    for name, values in results.items():
        print(f"{name:12s} trace pass {best[name]:8.2f} ms/frame (best of {args.rounds}: {', '.join(f'{v:.2f}' for v in values)})")
    print(f"everything / specialised = {best['everything'] / best['specialised']:.3f}")


if __name__ == "__main__":
    main()
