"""Read one mesh file (OBJ, PLY, GLB, glTF) through trimesh into a model Mesh.

Shading normals are kept only when the file itself stores them (trimesh would otherwise
invent smooth ones, which would hide faceting the author meant); uvs when present.
Triangles touching NaN/Inf vertices and triangles that repeat an index are dropped with a
warning; zero-area triangles with distinct indices are kept (the BVH copes with them).
"""
from __future__ import annotations

import io
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
    if path.suffix.lower() == ".ply":
        check_ply_header(path, fail)  # before trimesh allocates what the header claims
    import trimesh  # heavy import, only when a mesh file is actually read

    try:
        # Not force="mesh": that route drops the normals stored in the file.
        text = _obj_as_utf8(path) if path.suffix.lower() == ".obj" else None
        if text is not None:  # given as UTF-8 without a byte order mark: see _obj_as_utf8
            tm = trimesh.load(io.BytesIO(text), file_type="obj", process=False,
                              resolver=trimesh.resolvers.FilePathResolver(str(path)))
        else:
            tm = trimesh.load(str(path), process=False)
        if isinstance(tm, trimesh.Scene):  # several meshes (glTF): one, in world space
            tm = tm.to_mesh() if tm.geometry else None
    except Exception as e:  # trimesh raises many kinds; all mean "unreadable"
        fail(f"cannot read mesh file ({type(e).__name__}: {e})")
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        fail("mesh file has no triangles")

    positions = np.asarray(tm.vertices, dtype=np.float64)
    indices = np.asarray(tm.faces, dtype=np.int64)
    if indices.ndim != 2 or indices.shape[1] != 3:
        fail(f"mesh faces must be triangles, got an array of shape {indices.shape}")
    if indices.min() < 0 or indices.max() >= len(positions):
        fail(f"mesh faces use vertex indices outside 0..{len(positions) - 1} "
             f"(from {indices.min()} to {indices.max()})")
    normals = None
    if _file_has_normals(path):
        n = np.asarray(tm.vertex_normals, dtype=np.float64)
        if n.shape == positions.shape:
            normals = n
    uvs = texture_coordinates(getattr(tm.visual, "uv", None), len(positions))
    if uvs is None and getattr(tm.visual, "uv", None) is not None:
        warnings.warn(f"{path}: texture coordinates are not one (u, v) pair per vertex; the mesh is drawn "
                      "without them", SceneWarning, stacklevel=2)

    positions, indices, normals, uvs = clean_triangles(positions, indices, normals, uvs, path)
    source = f"{ref[0]}:{ref[1]}" if ref is not None else str(path)
    return Mesh(path.stem, positions, indices, material, normals=normals, uvs=uvs,
                source=source)


def texture_coordinates(uv, vertices: int) -> np.ndarray | None:
    """(u, v) per vertex from what trimesh read, or None where it is not one pair (or more: a
    third coordinate is dropped) per vertex (an OBJ's odd `vt` lines give other shapes)."""
    try:
        uv = None if uv is None else np.asarray(uv, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    if uv is None or uv.ndim != 2 or uv.shape[0] != vertices or uv.shape[1] < 2:
        return None
    return uv[:, :2]


def _obj_as_utf8(path: Path) -> bytes | None:
    """An OBJ's bytes as UTF-8 without a byte order mark, where the file is not that already
    (None: it is). trimesh guesses other encodings with charset_normalizer, which lift-gl does
    not install, and reads a byte order mark as part of the first statement. OBJ's numbers
    and keywords are ASCII, so a file that is not UTF-8 is read as Latin-1 (a comment, a
    group or material name in another encoding): every byte is a character there."""
    data = path.read_bytes()
    bom = data.startswith(b"\xef\xbb\xbf")
    try:
        data.decode("utf-8")
        return data[3:] if bom else None
    except UnicodeDecodeError:
        return data.decode("latin-1").encode("utf-8")


# Bytes of each PLY scalar type; a list property has at least its count.
PLY_TYPE_BYTES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2,
                  "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4,
                  "double": 8, "float64": 8}
MAX_MESH_ELEMENTS = 1 << 28  # vertices or faces in one file: far beyond what a GPU buffer takes


def check_ply_header(path: Path, fail) -> None:
    """Refuse a PLY whose header claims more elements than its file can hold (a truncated
    or hostile file: 10^12 vertices in a few bytes), or more than MAX_MESH_ELEMENTS."""
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    if not head.startswith(b"ply"):
        fail("not a PLY file (it does not start with 'ply')")
    end = head.find(b"end_header")
    if end < 0:
        fail("PLY header has no 'end_header' in its first 64 KiB")
    newline = head.find(b"\n", end)
    body = size - (newline + 1 if newline >= 0 else end + len(b"end_header"))
    binary = False
    elements = []  # [name, count, least bytes of one row]
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "format" and len(words) > 1:
            binary = words[1].startswith("binary")
        elif words[0] == "element":
            if len(words) != 3 or not words[2].isdigit():
                fail(f"bad PLY element line {line.strip()!r}")
            count = int(words[2])
            if count > MAX_MESH_ELEMENTS:
                fail(f"PLY header claims {count:,} {words[1]} elements; the limit is "
                     f"lift_gl.scene.mesh_io.MAX_MESH_ELEMENTS = {MAX_MESH_ELEMENTS:,}")
            elements.append([words[1], count, 0])
        elif words[0] == "property" and elements and len(words) >= 3:
            kind = words[2] if words[1] == "list" else words[1]
            # ASCII: at least one character and a separator a value.
            elements[-1][2] += PLY_TYPE_BYTES.get(kind, 1) if binary else 2
    for name, count, row in elements:
        need = count * max(row, 1)
        if need > body:
            fail(f"PLY header claims {count:,} {name} elements (at least {need:,} bytes), but the "
                 f"file has only {max(body, 0):,} bytes after its header")
        body -= need


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
