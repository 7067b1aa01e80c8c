"""A 4-wide BVH for GPU traversal, collapsed from the binary SAH tree (accel/bvh.py).

Why: the binary traversal (shaders/lift/bvh.glsl) fetches one node and tests two boxes per
step; a wide node gives the GPU four boxes per 128-byte fetch and half the steps, and leaves
become child entries of their parent, so a leaf is never fetched as a node of its own.

Collapse: top down, level by level (vectorised: Python work per level, not per node). Each
binary interior node that becomes a wide node starts with its two children and repeatedly
replaces its largest-area interior child by that child's two children, until it has 4
(Wald et al. 2008 / Ylitie et al. 2017's "largest area first"). The leaves keep their
triangle ranges, so the triangle arrays (and the BVH cache) stay those of the binary tree.

Node layout, 8 vec4 rows (128 bytes) per wide node, children in columns (SoA):
    row 0 min.x[4]  row 1 max.x[4]  row 2 min.y[4]  row 3 max.y[4]  row 4 min.z[4]
    row 5 max.z[4]  row 6 child entries (uint bits)  row 7 unused (zero)
A child entry is the wide node id of an interior child, or for a leaf
LEAF_BIT | (count - 1) << 27 | first (triangles first .. first + count - 1); an empty
slot is EMPTY with the box (+inf, -inf), which no ray's slab test ever enters (the GLSL
takes the near plane by the ray's direction sign, so the planes are never swapped).
Node 0 is the root; nodes are numbered breadth first.

Not here (the caller keeps the binary tree): motion blur (per-node boxes at shutter close)
and instances (BLAS roots index the node array); see scene/pack.py.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import LiftError

WIDTH_ENV_VAR = "LIFT_GL_BVH_WIDTH"
ROWS = 8                    # vec4 rows per 4-wide node
LEAF_BIT = 0x80000000
COUNT_SHIFT = 27
MAX_LEAF_COUNT = 16         # 4 bits of count - 1
MAX_FIRST = 1 << COUNT_SHIFT
EMPTY = 0xFFFFFFFF
# The GLSL stack of the wide traversal (LIFT_BVH_STACK when LIFT_BVH_WIDTH is 4): a node whose
# children are all hit pushes 3 of them, so the stack the tree needs is its largest sum of
# (children - 1) along a root path (WideBVH.stack_bound); a tree that needs more stays binary.
STACK = 64
# The width GPUs get by default (resolve_width), from the H100 measurements in docs/gpu.md.
DEFAULT_GPU_WIDTH = 2


@dataclass
class WideBVH:
    rows: np.ndarray        # float32 (W, 4 * ROWS): one wide node a row of 32 floats
    width: int
    stack_bound: int        # the deepest the traversal stack can get (see STACK)

    @property
    def num_nodes(self) -> int:
        return int(self.rows.shape[0])


def resolve_width(value: str | int | None, software: bool | None = None) -> int:
    """The BVH width to build: `value` (2, 4, auto), else $LIFT_GL_BVH_WIDTH, else auto.
    auto: 2 on CPU rasterizers and where the device is not known (software None), else
    DEFAULT_GPU_WIDTH (docs/gpu.md has the measurements it follows)."""
    if value is None:
        value = os.environ.get(WIDTH_ENV_VAR, "auto")
    text = str(value).strip().lower() or "auto"
    if text == "auto":
        return DEFAULT_GPU_WIDTH if software is False else 2
    if text not in ("2", "4"):
        raise LiftError(f"${WIDTH_ENV_VAR} must be 2, 4 or auto, not {value!r}")
    return int(text)


def _area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi.astype(np.float64) - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def collapse(nodes: np.ndarray, width: int = 4) -> WideBVH | None:
    """The 4-wide tree of a binary node array (accel/bvh.py layout, (N, 8) float32), or None
    where the layout cannot hold it: a leaf of more than MAX_LEAF_COUNT triangles, a triangle
    index past MAX_FIRST, or a tree that needs a traversal stack deeper than STACK."""
    if width != 4:
        raise ValueError(f"only 4-wide nodes are implemented, not {width}")
    nodes = np.asarray(nodes, np.float32)
    u = nodes.view(np.uint32)
    first = u[:, 3].astype(np.int64)
    count = u[:, 7].astype(np.int64)
    bmin, bmax = nodes[:, 0:3], nodes[:, 4:7]
    leaf = count > 0
    if (count > MAX_LEAF_COUNT).any() or (first[leaf] + count[leaf] > MAX_FIRST).any():
        return None
    area = _area(bmin, bmax)

    out_slots, out_ids = [], []          # per level: (m, 4) binary ids (-1 empty), wide ids
    n_wide = 1
    frontier = np.zeros(1, np.int64)     # binary nodes that become the wide nodes of a level
    root_is_leaf = bool(leaf[0])
    depth_push = np.zeros(1, np.int64)   # stack pushes on the path down to each frontier node
    stack_bound = 0
    while frontier.size:
        m = frontier.size
        slots = np.full((m, width), -1, np.int64)
        if root_is_leaf:                 # a one-leaf tree: the root's only child is itself
            slots[0, 0] = 0
            fill = np.ones(1, np.int64)
            root_is_leaf = False
        else:
            slots[:, 0] = first[frontier]
            slots[:, 1] = first[frontier] + 1
            fill = np.full(m, 2, np.int64)
        rows = np.arange(m)
        for _ in range(width - 2):
            valid = slots >= 0
            safe = np.where(valid, slots, 0)
            expandable = valid & ~leaf[safe]
            key = np.where(expandable, area[safe], -1.0)
            j = np.argmax(key, axis=1)
            go = np.flatnonzero(key[rows, j] >= 0)
            if not go.size:
                break
            c = slots[go, j[go]]
            slots[go, j[go]] = first[c]
            slots[go, fill[go]] = first[c] + 1
            fill[go] += 1
        stack_bound = max(stack_bound, int((depth_push + fill - 1).max()))
        valid = slots >= 0
        inner = valid & ~leaf[np.where(valid, slots, 0)]
        k = int(inner.sum())
        ids = np.full((m, width), -1, np.int64)
        ids[inner] = n_wide + np.arange(k)   # row-major: breadth-first numbering
        n_wide += k
        out_slots.append(slots)
        out_ids.append(ids)
        parent_push = np.repeat(depth_push + fill - 1, inner.sum(axis=1))
        frontier = slots[inner]
        depth_push = parent_push
    if stack_bound > STACK:
        return None

    slots = np.concatenate(out_slots)
    ids = np.concatenate(out_ids)
    valid = slots >= 0
    safe = np.where(valid, slots, 0)
    is_leaf = valid & leaf[safe]
    entries = np.full(slots.shape, EMPTY, np.int64)
    entries[is_leaf] = LEAF_BIT | ((count[safe[is_leaf]] - 1) << COUNT_SHIFT) | first[safe[is_leaf]]
    entries[valid & ~is_leaf] = ids[valid & ~is_leaf]

    w = slots.shape[0]
    out = np.zeros((w, ROWS, 4), np.float32)
    lo = np.where(valid[..., None], bmin[safe], np.float32(np.inf))    # (w, 4, 3)
    hi = np.where(valid[..., None], bmax[safe], np.float32(-np.inf))
    for axis in range(3):
        out[:, 2 * axis, :] = lo[:, :, axis]
        out[:, 2 * axis + 1, :] = hi[:, :, axis]
    out[:, 6, :] = entries.astype(np.uint32).view(np.float32)
    return WideBVH(rows=out.reshape(w, ROWS * 4), width=width, stack_bound=stack_bound)


def intersect_wide_numpy(wide: WideBVH, tri_positions_reordered: np.ndarray, origins: np.ndarray,
                         dirs: np.ndarray, tmin: float = 0.0, tmax: float = np.inf):
    """Closest hit of each ray through the wide tree: (t float64 (R,), tri int64 (R,)), as
    bvh.intersect_numpy does for the binary tree (tests compare the two). Wavefront: all
    (ray, wide node) pairs of a level at once, every child box tested, hit leaves' triangles
    intersected at once."""
    from .bvh import _safe_inv, moller_trumbore

    tris = np.asarray(tri_positions_reordered, np.float64)
    o_all = np.asarray(origins, np.float64).reshape(-1, 3)
    d_all = np.asarray(dirs, np.float64).reshape(-1, 3)
    n_rays = o_all.shape[0]
    best_t = np.full(n_rays, float(tmax))
    best_tri = np.full(n_rays, -1, np.int64)
    if tris.shape[0] == 0 or n_rays == 0:
        return np.where(best_tri < 0, np.inf, best_t), best_tri
    inv_all = _safe_inv(d_all)
    r = wide.rows.reshape(-1, ROWS, 4)
    lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1).astype(np.float64)   # (W, 4, 3)
    hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1).astype(np.float64)
    entry = r[:, 6].view(np.uint32).astype(np.int64)                         # (W, 4)
    pr = np.arange(n_rays)
    pn = np.zeros(n_rays, np.int64)
    while pr.size:
        o = o_all[pr][:, None, :]
        inv = inv_all[pr][:, None, :]
        with np.errstate(invalid="ignore"):
            t0 = (lo[pn] - o) * inv
            t1 = (hi[pn] - o) * inv
        near = np.where(inv >= 0, t0, t1).max(axis=2)
        far = np.where(inv >= 0, t1, t0).min(axis=2)
        hit = (np.maximum(near, tmin) <= np.minimum(far, best_t[pr][:, None]))   # (P, 4)
        e = entry[pn]
        hr, hs = np.nonzero(hit)
        ray, ent = pr[hr], e[hr, hs]
        is_leaf = (ent & LEAF_BIT) != 0
        lr, le = ray[is_leaf], ent[is_leaf]
        if lr.size:
            c = ((le >> COUNT_SHIFT) & (MAX_LEAF_COUNT - 1)) + 1
            f = le & (MAX_FIRST - 1)
            rr = np.repeat(lr, c)
            off = np.cumsum(c) - c
            tt = np.repeat(f - off, c) + np.arange(int(c.sum()))
            t, _, _, ok = moller_trumbore(tris[tt, 0], tris[tt, 1], tris[tt, 2], o_all[rr], d_all[rr])
            ok &= (t > tmin) & (t < best_t[rr])
            rr, tt, t = rr[ok], tt[ok], t[ok]
            if rr.size:
                s = np.lexsort((tt, t, rr))
                rr, tt, t = rr[s], tt[s], t[s]
                head = np.concatenate(([True], rr[1:] != rr[:-1]))
                best_t[rr[head]] = t[head]
                best_tri[rr[head]] = tt[head]
        pr, pn = ray[~is_leaf], ent[~is_leaf]
    return np.where(best_tri < 0, np.inf, best_t), best_tri
