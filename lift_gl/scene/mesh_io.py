"""Read one mesh file (OBJ, PLY, GLB, glTF) through trimesh into a model Mesh.

Shading normals are kept only when the file itself stores them (trimesh would otherwise
invent smooth ones, which would hide faceting the author meant); uvs when present.
Triangles touching NaN/Inf vertices and triangles that repeat an index are dropped with a
warning; zero-area triangles with distinct indices are kept (the BVH copes with them).
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from ..errors import SceneError
from .loader import SceneWarning
from .model import Mesh

MESH_EXTENSIONS = (".obj", ".ply", ".glb", ".gltf")


def load_mesh_file(path, ref: tuple | None = None, material: int = 0) -> Mesh:
    """`ref` = (scene_file, line) of the directive that referenced the mesh: errors then
    point at the scene file and name the mesh file, so the author knows what to fix."""
    path = Path(path)

    def fail(msg):
        if ref is not None:
            raise SceneError(f"{msg}: {path}", ref[0], ref[1])
        raise SceneError(msg, path)

    if not path.is_file():
        fail("mesh file not found")
    if path.suffix.lower() not in MESH_EXTENSIONS:
        fail(f"unsupported mesh format '{path.suffix}' (use {', '.join(MESH_EXTENSIONS)})")
    import trimesh  # heavy import, only when a mesh file is actually read

    try:
        # Not force="mesh": that route drops the normals stored in the file.
        tm = trimesh.load(str(path), process=False)
        if isinstance(tm, trimesh.Scene):  # several meshes (glTF): one, in world space
            tm = tm.to_mesh() if tm.geometry else None
    except Exception as e:  # trimesh raises many kinds; all mean "unreadable"
        fail(f"cannot read mesh file ({type(e).__name__}: {e})")
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        fail("mesh file has no triangles")

    positions = np.asarray(tm.vertices, dtype=np.float64)
    indices = np.asarray(tm.faces, dtype=np.int64)
    normals = None
    if _file_has_normals(path):
        n = np.asarray(tm.vertex_normals, dtype=np.float64)
        if n.shape == positions.shape:
            normals = n
    uvs = None
    uv = getattr(tm.visual, "uv", None)
    if uv is not None and len(uv) == len(positions):
        uvs = np.asarray(uv, dtype=np.float64)

    positions, indices, normals, uvs = clean_triangles(positions, indices, normals, uvs, path)
    source = f"{ref[0]}:{ref[1]}" if ref is not None else str(path)
    return Mesh(path.stem, positions, indices, material, normals=normals, uvs=uvs,
                source=source)


def clean_triangles(positions, indices, normals, uvs, label):
    """Drop triangles with non-finite vertices or repeated indices (both with a warning)."""
    bad_vertex = ~np.isfinite(positions).all(axis=1)
    if bad_vertex.any():
        bad_tri = bad_vertex[indices].any(axis=1)
        warnings.warn(f"{label}: {int(bad_vertex.sum())} vertices are NaN/Inf; dropped the "
                      f"{int(bad_tri.sum())} triangles that use them", SceneWarning,
                      stacklevel=3)
        indices = indices[~bad_tri]
        # Compact so no NaN vertex survives to upset bounding boxes downstream.
        keep = ~bad_vertex
        remap = np.cumsum(keep) - 1
        indices = remap[indices]
        positions = positions[keep]
        normals = normals[keep] if normals is not None else None
        uvs = uvs[keep] if uvs is not None else None
    repeated = ((indices[:, 0] == indices[:, 1]) | (indices[:, 1] == indices[:, 2])
                | (indices[:, 0] == indices[:, 2]))
    if repeated.any():
        warnings.warn(f"{label}: dropped {int(repeated.sum())} degenerate triangles "
                      "(repeated vertex index)", SceneWarning, stacklevel=3)
        indices = indices[~repeated]
    if normals is not None and not np.isfinite(normals).all():
        warnings.warn(f"{label}: non-finite vertex normals; using flat shading", SceneWarning,
                      stacklevel=3)
        normals = None
    return positions, indices, normals, uvs


def _file_has_normals(path: Path) -> bool:
    """Pragmatic check of whether the file stores normals (not whether trimesh made some)."""
    ext = path.suffix.lower()
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    if ext == ".ply":
        header = head.split(b"end_header", 1)[0]
        return any(line.split()[-1:] == [b"nx"] for line in header.splitlines())
    if ext == ".obj":
        with open(path, "rb") as f:
            return any(line.startswith(b"vn ") or line.startswith(b"vn\t") for line in f)
    if ext == ".gltf":
        return '"NORMAL"' in path.read_text(errors="replace")
    if ext == ".glb":
        # The JSON chunk follows the 12-byte header and the 8-byte chunk header.
        length = int.from_bytes(head[12:16], "little")
        if 20 + length > len(head):
            with open(path, "rb") as f:
                head = f.read(20 + length)
        try:
            doc = json.loads(head[20:20 + length].decode("utf-8", "replace"))
        except ValueError:
            return b'"NORMAL"' in head
        return any("NORMAL" in p.get("attributes", {})
                   for m in doc.get("meshes", []) for p in m.get("primitives", []))
    return False
