"""An experimental BVH layout, kept for `benchmarks/gpu.py ab`: the builder's binary BVH
(lift_gl/accel/bvh.py: one row per node, box in the node) turned into one record per
*interior* node that holds both children's boxes, for a GLSL traversal that fetches one
64-byte record per step and tests leaf children from their parent (branch gpu-speed, commit
b18f611, shaders/lift/bvh.glsl there). On llvmpipe it traced 1.0-1.4x faster than the
binary layout; on an H100 0.45-1.0x as fast (docs/gpu.md), so lift-gl does not use it.

Record i, four float32 vec4 (columns 0..15 of row i):
    [A.lo.xyz, A.ref]  [A.hi.xyz, A.count]  [B.lo.xyz, B.ref]  [B.hi.xyz, B.count]
for its two children A and B; ref and count are uint32 bit patterns. count == 0: the child
is interior and ref its record; count > 0: the child is a leaf of triangles ref .. ref +
count - 1 (the builder's order). Record 0 holds the root's children; records are numbered
depth first. A tree that is a single leaf gets one record whose children are that leaf
twice; an empty one a record whose boxes no ray reaches.
"""
from __future__ import annotations

import numpy as np

# Bump when the record layout changes (nothing caches it on disk: it is rebuilt on packing).
GPU_LAYOUT_VERSION = "lift-bvh-gpu-1:f32x16(2 child boxes);dfs"
RECORD_FLOATS = 16

_FAR = np.float32(3e38)  # a point box here is beyond every ray's tmax (at most 1e30)


def _plan(nodes: np.ndarray):
    """The records of a binary node array (accel/bvh.py layout): for each record, its
    binary node and the two children's binary ids; and each interior node's record index."""
    u = nodes.view(np.uint32)
    first = u[:, 3].astype(np.int64)
    count = u[:, 7].astype(np.int64)
    n = nodes.shape[0]
    interior = count == 0
    if n == 1 or not interior[0]:
        return None
    # interior nodes by level, top down
    levels, frontier = [], np.zeros(1, np.int64)
    while frontier.size:
        inner = frontier[interior[frontier]]
        if inner.size:
            levels.append(inner)
        frontier = np.concatenate((first[inner], first[inner] + 1))
    # interior nodes in each subtree, bottom up (a leaf counts 0)
    size = np.zeros(n, np.int64)
    for inner in reversed(levels):
        size[inner] = 1 + size[first[inner]] + size[first[inner] + 1]
    # depth-first (preorder) record numbers, top down: A right after its parent, B after A's subtree
    record = np.full(n, -1, np.int64)
    record[0] = 0
    for inner in levels:
        a, b = first[inner], first[inner] + 1
        record[a] = np.where(interior[a], record[inner] + 1, -1)
        record[b] = np.where(interior[b], record[inner] + 1 + size[a], -1)
    owners = np.flatnonzero(interior)
    by_record = np.empty(owners.size, np.int64)
    by_record[record[owners]] = owners
    return by_record, first[by_record], first[by_record] + 1, record, interior, first, count


def gpu_nodes(nodes: np.ndarray) -> np.ndarray:
    """float32 (M, 16) records (module docstring) of a binary node array (N, 8)."""
    nodes = np.asarray(nodes, np.float32)
    u = nodes.view(np.uint32)
    plan = _plan(nodes)
    if plan is None:
        out = np.zeros((1, RECORD_FLOATS), np.float32)
        ou = out.view(np.uint32)
        if u[0, 7] > 0:  # a single leaf: both children are it
            for c in (0, 8):
                out[0, c + 0:c + 3] = nodes[0, 0:3]
                out[0, c + 4:c + 7] = nodes[0, 4:7]
                ou[0, c + 3] = u[0, 3]
                ou[0, c + 7] = u[0, 7]
        else:            # empty: boxes that no ray reaches
            for c in (0, 8):
                out[0, c + 0:c + 3] = _FAR
                out[0, c + 4:c + 7] = _FAR
        return out
    _, a, b, record, interior, first, count = plan
    out = np.empty((a.size, RECORD_FLOATS), np.float32)
    ou = out.view(np.uint32)
    for c, child in ((0, a), (8, b)):
        out[:, c + 0:c + 3] = nodes[child, 0:3]
        out[:, c + 4:c + 7] = nodes[child, 4:7]
        ou[:, c + 3] = np.where(interior[child], record[child], first[child]).astype(np.uint32)
        ou[:, c + 7] = np.where(interior[child], 0, count[child]).astype(np.uint32)
    return out


def gpu_close_boxes(nodes: np.ndarray, close_rows: np.ndarray) -> np.ndarray:
    """Motion blur: the binary tree's boxes at shutter close, two vec4 rows per node
    (bmin.xyz, bmax.xyz; scene/pack.py), as four vec4 rows per record, laid out as the
    records' box columns: (A.lo, A.hi, B.lo, B.hi) at close."""
    close = np.asarray(close_rows, np.float32).reshape(-1, 2, 4)
    plan = _plan(np.asarray(nodes, np.float32))
    if plan is None:
        out = np.zeros((1, 4, 4), np.float32)
        out[0, [0, 2]] = close[0, 0]
        out[0, [1, 3]] = close[0, 1]
        if np.asarray(nodes).view(np.uint32)[0, 7] == 0:
            out[0, :, :3] = _FAR
        return out.reshape(-1, 4)
    _, a, b = plan[:3]
    out = np.zeros((a.size, 4, 4), np.float32)
    out[:, 0], out[:, 1] = close[a, 0], close[a, 1]
    out[:, 2], out[:, 3] = close[b, 0], close[b, 1]
    out[:, :, 3] = 0.0
    return out.reshape(-1, 4)
