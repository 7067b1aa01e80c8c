"""A 4-wide BVH for GPU traversal, collapsed from the binary SAH tree (accel/bvh.py).

Why: the binary traversal (shaders/lift/bvh.glsl) fetches one node and tests two boxes per
step; a wide node gives the GPU four boxes per 128-byte fetch and half the steps, and leaves
become child entries of their parent, so a leaf is never fetched as a node of its own.

Collapse: chosen by cost (accel/wide_sah.py: which binary nodes become wide nodes and which
subtrees one leaf, by dynamic programming). The leaves are runs of the binary tree's
triangles, so the triangle arrays (and the BVH cache) stay those of the binary tree.

Node layout, 8 vec4 rows (128 bytes) per wide node, children in columns (SoA):
    row 0 min.x[4]  row 1 max.x[4]  row 2 min.y[4]  row 3 max.y[4]  row 4 min.z[4]
    row 5 max.z[4]  row 6 child entries (uint bits)  row 7 unused (zero)
A child entry is the wide node id of an interior child, or for a leaf
LEAF_BIT | (count - 1) << 27 | first (triangles first .. first + count - 1); an empty
slot is EMPTY with the box (+inf, -inf), which no ray's slab test ever enters (the GLSL
takes the near plane by the ray's direction sign, so the planes are never swapped).
Node 0 is the root; nodes are numbered breadth first. quantize() turns the same tree into
64-byte nodes with 8-bit child boxes (the option bvh_width=4q). Which layout, order of
children and stack a device gets is lift_gl/options.py's choice.

Not here (the caller keeps the binary tree): motion blur (per-node boxes at shutter close)
and instances (BLAS roots index the node array); see scene/pack.py.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ROWS = 8                    # vec4 rows per 4-wide node
QROWS = 4                   # vec4 rows per 4-wide node with quantized boxes (quantize())
LEAF_BIT = 0x80000000
COUNT_SHIFT = 27
MAX_LEAF_COUNT = 16         # 4 bits of count - 1
MAX_FIRST = 1 << COUNT_SHIFT
EMPTY = 0xFFFFFFFF
# The GLSL stack of the wide traversal (LIFT_BVH_STACK when LIFT_BVH_WIDTH is 4): a node whose
# children are all hit pushes 3 of them, so the stack the tree needs is its largest sum of
# (children - 1) along a root path (WideBVH.stack_bound); a tree that needs more stays binary.
STACK = 64


def stack_size(stack_bound: int) -> int:
    """The traversal stack the shaders declare (LIFT_BVH_STACK_SIZE) for a tree whose
    traversal needs `stack_bound` entries: rounded up to a multiple of 8, so that an edit that
    deepens the tree a little recompiles nothing, and at most STACK. On GPUs the stack lives in
    shared memory, which bounds how many warps an SM holds: a smaller one lets more run
    (docs/gpu.md, the stack sized to the tree: 1.67x on the cornell-box)."""
    return min(STACK, max(8, -(-int(stack_bound) // 8) * 8))


STACKS = ("children", "groups")
# A stack of node groups (shaders/lift/bvh.glsl LIFT_BVH_GROUP_STACK) packs a node id in 24 bits.
GROUP_MAX_NODES = 1 << 24
# Node groups rarely go more than a few levels deep: with only the top 8 in shared memory (1 KiB
# a work group) pt's plain megakernel ran 1.21x faster on the dining room than with all 24 there,
# 1.04x on the dragon, 1.02x on the classroom (H100; 12 entries: 1.13 / 0.98 / 0.98x). pt's
# queued megakernel keeps its whole stack in a local array on GPUs (lift_gl/options.py), and
# drt, hybrid and ao keep this.
GROUP_SHARED_DEPTH = 8
STACK_DEFINES = ("LIFT_BVH_GROUP_STACK", "LIFT_BVH_STACK_SIZE", "LIFT_BVH_SHARED_DEPTH")   # what stack_defines sets


def stack_defines(wide_stack_bound: int, levels: int, entries: str) -> dict:
    """The defines that size a 4-wide tree's traversal stack of `entries` (STACKS; the option
    bvh_stack_entries, resolved by lift_gl/options.py): LIFT_BVH_STACK_SIZE, with
    LIFT_BVH_GROUP_STACK where its entries are node groups, whose top GROUP_SHARED_DEPTH entries
    then stay in shared memory on GPUs (LIFT_BVH_SHARED_DEPTH) and deeper ones go to a local
    array. A stack of node groups holds one entry a level; a stack of children, the tree's
    stack_bound (shaders/lift/bvh.glsl)."""
    if entries not in STACKS:
        raise ValueError(f"stack entries must be one of {STACKS}, not {entries!r}")
    if entries == "groups":
        return {"LIFT_BVH_GROUP_STACK": True, "LIFT_BVH_STACK_SIZE": stack_size(levels),
                "LIFT_BVH_SHARED_DEPTH": GROUP_SHARED_DEPTH}
    return {"LIFT_BVH_STACK_SIZE": stack_size(wide_stack_bound)}


@dataclass
class WideBVH:
    rows: np.ndarray        # float32 (W, 4 * ROWS) (quantized: (W, 4 * QROWS)), one wide node a row
    width: int
    stack_bound: int        # the deepest the traversal stack can get (see STACK)
    quantized: bool = False
    levels: int = 0         # wide nodes on the longest root path: the deepest a stack of node groups gets

    @property
    def num_nodes(self) -> int:
        return int(self.rows.shape[0])


LAYOUTS = ("2", "4", "4q")   # binary, 4-wide with float boxes, 4-wide with 8-bit boxes (quantize)
# The order of a wide node's four children. The traversal sorts the children it enters by entry
# distance, but every child box that holds the ray's origin has the same one (the ray's tmin),
# and so do the boxes around a path vertex, where shadow and bounce rays start: those ties go
# in slot order (shaders/lift/bvh.glsl). Shadow rays outside the paired loop (CPU rasterizers,
# the ray-casting shader) take all their children in slot order. `area` puts the largest box
# first: for a shadow ray the child most likely to hold an occluder; `build` keeps the
# collapse's own order (a node's slots from its left subtree first). Which a device gets:
# lift_gl/options.py.
SLOT_ORDERS = ("area", "build")


def wide_layout(nodes: np.ndarray, layout: str, slot_order: str = "area") -> WideBVH | None:
    """The binary node array in `layout` ("4" or "4q"), each node's children in `slot_order`
    (SLOT_ORDERS), or None where that layout cannot hold the tree (wide_sah.collapse_sah,
    quantize)."""
    from .wide_sah import collapse_sah

    wide = collapse_sah(nodes, slot_order=slot_order)
    if wide is not None and layout == "4q":
        wide = quantize(wide)
    return wide


def _area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi.astype(np.float64) - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def quantize(wide: WideBVH) -> WideBVH | None:
    """The same tree with 8-bit child boxes (Ylitie, Karras and Laine 2017): 64 bytes a node,
    two nodes a 128-byte line. Per node, QROWS vec4 rows:
        row 0  origin.xyz (float), w: uint bits, the biased exponents of the per-axis scales
               s = 2^(e - 127) in bytes 0, 1, 2
        row 1  uint bits: qlo.x, qhi.x, qlo.y, qhi.y   (child i in byte i of each word)
        row 2  uint bits: qlo.z, qhi.z, 0, 0
        row 3  the child entries, as row 6 of the float layout
    A child's plane is origin + q * s: q * s is exact (8 bits times a power of two), so the GPU
    decodes exactly what numpy checks here, and every decoded box contains the float one
    (rounded outwards, corrected where the final add rounded inwards): the traversal visits a
    superset of the float layout's boxes and finds the same hits. Empty slots: qlo 255, qhi 0,
    and their EMPTY entry, which the GLSL masks out. None where a scale would leave float's
    exponent range."""
    r = wide.rows.reshape(-1, ROWS, 4)
    entry = r[:, 6].view(np.uint32)
    valid = entry != EMPTY
    lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1)          # (W, 4, 3), +inf where empty
    hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1)
    origin = np.where(valid[..., None], lo, np.inf).min(axis=1).astype(np.float32)   # (W, 3)
    top = np.where(valid[..., None], hi, -np.inf).max(axis=1).astype(np.float32)
    extent = np.maximum(top.astype(np.float64) - origin, 0.0)
    # the smallest power of two with 253 steps covering the extent (2 steps spare for rounding)
    with np.errstate(divide="ignore"):
        e = np.ceil(np.log2(np.maximum(extent / 253.0, 2.0 ** -126)))
    e = np.maximum(e, -126).astype(np.int64)
    if (e > 127).any() or not np.isfinite(origin).all():
        return None
    scale = np.exp2(e).astype(np.float32)                         # (W, 3), exact powers of two
    o = origin[:, None, :]
    s = scale[:, None, :]
    qlo = np.floor((lo.astype(np.float64) - o) / s)
    qhi = np.ceil((hi.astype(np.float64) - o) / s)
    qlo = np.clip(np.where(valid[..., None], qlo, 255), 0, 255)
    qhi = np.clip(np.where(valid[..., None], qhi, 0), 0, 255)

    def decode(q):   # what the GLSL computes: one float32 add of an exact product
        return (o + (q.astype(np.float32) * s)).astype(np.float32)

    for _ in range(2):   # where the add rounded inwards, one step outwards
        qlo = np.where(valid[..., None] & (decode(qlo) > lo), np.maximum(qlo - 1, 0), qlo)
        qhi = np.where(valid[..., None] & (decode(qhi) < hi), np.minimum(qhi + 1, 255), qhi)
    v = valid[..., None]
    if (v & (decode(qlo) > lo)).any() or (v & (decode(qhi) < hi)).any():
        return None
    qlo, qhi = qlo.astype(np.uint32), qhi.astype(np.uint32)
    shifts = np.array([0, 8, 16, 24], np.uint32)

    def pack(q):     # (W, 4) bytes -> (W,) words, child i in byte i
        return (q << shifts).sum(axis=1).astype(np.uint32)

    w = r.shape[0]
    out = np.zeros((w, QROWS, 4), np.uint32)
    out[:, 0, :3] = origin.view(np.uint32)
    out[:, 0, 3] = ((e[:, 0] + 127) | (e[:, 1] + 127) << 8 | (e[:, 2] + 127) << 16).astype(np.uint32)
    out[:, 1] = np.stack([pack(qlo[..., 0]), pack(qhi[..., 0]), pack(qlo[..., 1]), pack(qhi[..., 1])], axis=1)
    out[:, 2, 0], out[:, 2, 1] = pack(qlo[..., 2]), pack(qhi[..., 2])
    out[:, 3] = entry
    return WideBVH(rows=out.view(np.float32).reshape(w, QROWS * 4), width=wide.width,
                   stack_bound=wide.stack_bound, quantized=True, levels=wide.levels)


def decoded_boxes(wide: WideBVH) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, entries) of every child slot, (W, 4, 3), (W, 4, 3), (W, 4): what the GLSL
    traversal tests, for either layout (tests and intersect_wide_numpy)."""
    if not wide.quantized:
        r = wide.rows.reshape(-1, ROWS, 4)
        lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1)
        hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1)
        return lo, hi, r[:, 6].view(np.uint32)
    u = wide.rows.reshape(-1, QROWS, 4).view(np.uint32)
    origin = u[:, 0, :3].view(np.float32)
    e = (u[:, 0, 3:4] >> np.array([0, 8, 16], np.uint32)) & 0xFF
    scale = (e << 23).astype(np.uint32).view(np.float32)          # 2^(e - 127), as the GLSL builds it
    byte = lambda word: ((word[:, None] >> np.array([0, 8, 16, 24], np.uint32)) & 0xFF).astype(np.float32)
    qlo = np.stack([byte(u[:, 1, 0]), byte(u[:, 1, 2]), byte(u[:, 2, 0])], axis=-1)
    qhi = np.stack([byte(u[:, 1, 1]), byte(u[:, 1, 3]), byte(u[:, 2, 1])], axis=-1)
    lo = (origin[:, None, :] + qlo * scale[:, None, :]).astype(np.float32)
    hi = (origin[:, None, :] + qhi * scale[:, None, :]).astype(np.float32)
    entry = u[:, 3]
    empty = entry == EMPTY     # masked out by the GLSL: shown here as the float layout's (+inf, -inf)
    lo[empty], hi[empty] = np.inf, -np.inf
    return lo, hi, entry


def wide_rows(slots: np.ndarray, is_leaf: np.ndarray, ids: np.ndarray, leaf_first: np.ndarray,
              leaf_count: np.ndarray, bmin: np.ndarray, bmax: np.ndarray, slot_order: str = "area") -> np.ndarray:
    """The float layout's rows (W, 4 * ROWS) of a wide tree given per slot (W, 4) the binary
    node it stands for (-1: empty), whether it is a leaf entry and the wide id of an interior
    one; a leaf entry of binary node x holds triangles leaf_first[x] .. + leaf_count[x] - 1 and
    every slot the box (bmin[x], bmax[x]). Each node's slots in `slot_order` (SLOT_ORDERS)."""
    valid = slots >= 0
    safe = np.where(valid, slots, 0)
    if slot_order not in SLOT_ORDERS:
        raise ValueError(f"slot order must be one of {SLOT_ORDERS}, not {slot_order!r}")
    if slot_order == "area":
        # largest box first, empty slots last: see SLOT_ORDERS
        order = np.argsort(-np.where(valid, _area(bmin[safe], bmax[safe]), -1.0), axis=1, kind="stable")
        slots, is_leaf, ids = (np.take_along_axis(a, order, 1) for a in (slots, is_leaf, ids))
        valid = slots >= 0
        safe = np.where(valid, slots, 0)
    entries = np.full(slots.shape, EMPTY, np.int64)
    lf = valid & is_leaf
    entries[lf] = LEAF_BIT | ((leaf_count[safe[lf]] - 1) << COUNT_SHIFT) | leaf_first[safe[lf]]
    entries[valid & ~is_leaf] = ids[valid & ~is_leaf]
    w = slots.shape[0]
    out = np.zeros((w, ROWS, 4), np.float32)
    lo = np.where(valid[..., None], bmin[safe], np.float32(np.inf))    # (w, 4, 3)
    hi = np.where(valid[..., None], bmax[safe], np.float32(-np.inf))
    for axis in range(3):
        out[:, 2 * axis, :] = lo[:, :, axis]
        out[:, 2 * axis + 1, :] = hi[:, :, axis]
    out[:, 6, :] = entries.astype(np.uint32).view(np.float32)
    return out.reshape(w, ROWS * 4)


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
    lo, hi, entry = decoded_boxes(wide)
    lo, hi, entry = lo.astype(np.float64), hi.astype(np.float64), entry.astype(np.int64)  # (W, 4, 3), (W, 4)
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
