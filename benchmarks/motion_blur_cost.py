"""What motion blur costs the trace pass: drt on a scene (1) frozen (shutter [0, 0]: no motion
code), (2) frozen but compiled with the motion code (HAS_MOTION, zero motion), (3) moving
(motion code; node boxes at shutter open and close, blended at the ray's moment), and (4)
moving with each node's box the one it sweeps over the whole shutter (the same tree, the
blend switched off by making both boxes the swept one), the simpler scheme. Wall time per frame, the GPU
drained at the end (llvmpipe's timer queries do not time compute dispatches; on llvmpipe
the GPU is the CPU, so wall time is its time). The three are interleaved in each round so
that machine load hits them alike; only ratios measured in the same run are reported.

    python benchmarks/motion_blur_cost.py [--mesh PLY] [--size 128] [--frames 32] [--rounds 3]

The default mesh is the Stanford bunny from the shared assets: it moves sideways by a third
of its width while the shutter is open.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from lift_gl.gl.context import describe
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene
from lift_gl.scene.features import SceneFeatures
from lift_gl.scene.loader import framing_camera
from lift_gl.scene.mesh_io import load_mesh_file
from lift_gl.scene.primitives import quad

DEFAULT_MESH = Path(__file__).resolve().parent.parent.parent / "shared/assets/meshes/bunny.ply"


def mesh_scene(path: Path, shutter) -> Scene:
    """The mesh, scaled to unit height, on a floor under an area light, moving along x."""
    mesh = load_mesh_file(path, material=0)
    lo, hi = mesh.positions.min(axis=0), mesh.positions.max(axis=0)
    mesh.positions = (mesh.positions - [(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2]) / (hi[1] - lo[1])
    width = float(np.ptp(mesh.positions[:, 0]))
    mesh.velocity = np.array([width / 3, 0.0, 0.0])
    materials = [Material("white", base_color=[0.7, 0.7, 0.7]),
                 Material("light", base_color=[0, 0, 0], emission=[6, 6, 6])]
    floor = quad([-3, 0, 3], [6, 0, 0], [0, 0, -6], 0, "floor")
    light = quad([-0.5, 3, -0.5], [1, 0, 0], [0, 0, 1], 1, "light")  # faces down
    scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0], shutter=shutter),
                  materials=materials, meshes=[mesh, floor, light], max_depth=4)
    framed = framing_camera(Scene(camera=scene.camera, meshes=[mesh]), fov_deg=35)
    framed.shutter = shutter
    scene.camera = framed
    return scene


def use_swept_boxes(renderer: Renderer) -> None:
    """Both boxes of every node := the box it sweeps, the union of its boxes at open and
    close (each triangle sweeps the union of its two end boxes)."""
    packed = renderer.packed
    nodes, motion = packed.bvh_nodes.copy(), packed.motion.copy()
    close = motion[packed.num_triangles + packed.num_spheres:]
    lo = np.minimum(nodes[:, 0:3], close[0::2, :3])
    hi = np.maximum(nodes[:, 4:7], close[1::2, :3])
    nodes[:, 0:3], nodes[:, 4:7] = lo, hi
    close[0::2, :3], close[1::2, :3] = lo, hi
    renderer.buffers.buffers["bvh_nodes"].write(nodes.tobytes())
    renderer.buffers.motion.write(motion.tobytes())


def frame_ms(scene, size, frames, features=None, swept=False) -> tuple[float, Renderer]:
    renderer = Renderer(scene, size=(size, size), integrator="drt", features=features)
    if swept:
        use_swept_boxes(renderer)
    renderer.render(spp=4)  # warm up: shader compile, first dispatch
    renderer.reset()
    renderer.render(spp=frames * renderer.samples_per_frame)
    ms = 1000.0 * renderer.stats.render_seconds / renderer.stats.frames
    assert renderer.stats.dropped_samples == 0
    renderer.release()
    return ms, renderer


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mesh", default=str(DEFAULT_MESH))
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--frames", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    frozen = mesh_scene(Path(args.mesh), (0.0, 0.0))
    moving = mesh_scene(Path(args.mesh), (0.0, 1.0))
    with_motion_code = dataclasses.replace(SceneFeatures.of(frozen), motion=True)
    cases = {"frozen": (frozen, None, False), "frozen + motion code": (frozen, with_motion_code, False),
             "moving": (moving, None, False), "moving, swept boxes": (moving, None, True)}
    results = {name: [] for name in cases}
    for _ in range(args.rounds):
        for name, (scene, features, swept) in cases.items():
            ms, renderer = frame_ms(scene, args.size, args.frames, features, swept)
            results[name].append(ms)
    print(f"device: {describe(renderer.ctx)}")
    print(f"scene: {Path(args.mesh).name}, {frozen.triangle_count} triangles, {args.size}x{args.size}, "
          f"drt, {renderer.samples_per_frame} spp per frame")
    best = {name: min(values) for name, values in results.items()}
    for name, values in results.items():
        print(f"{name:22s} {best[name]:8.2f} ms/frame  x{best[name] / best['frozen']:.3f}  "
              f"(best of {args.rounds}: {', '.join(f'{v:.2f}' for v in values)})")


if __name__ == "__main__":
    main()
