"""A mesh with 4^N times the triangles of another, same shape (midpoint subdivision, no
smoothing): a multi-million-triangle test scene from a small shared asset, made where it is
used instead of carried (1.6M triangles are 30 MB as PLY).

    python benchmarks/subdivided_mesh.py IN.ply OUT.ply [--levels 2]
"""
from __future__ import annotations

import argparse

import trimesh


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mesh")
    parser.add_argument("out")
    parser.add_argument("--levels", type=int, default=2)
    args = parser.parse_args(argv)
    mesh = trimesh.load(args.mesh, force="mesh", process=False)
    vertices, faces = mesh.vertices, mesh.faces
    for _ in range(args.levels):
        vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    trimesh.Trimesh(vertices, faces, process=False).export(args.out)
    print(f"{args.out}: {len(faces):,} triangles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
