"""Linear BVH (Karras 2012, "Maximizing parallelism in the construction of BVHs, octrees and
k-d trees") through OpenCL.

    build_lbvh(tri_positions)               # Morton order, Karras hierarchy

It returns the same `BVH` as bvh.build_bvh, so packing, the cache and the shaders do not
care which builder made a tree.

Steps, and where each runs:
1. triangle boxes and 30-bit Morton codes of their centres (OpenCL, one work-item a triangle);
2. sort of the 64-bit keys (code << 32 | triangle index): numpy. The index makes every key
   unique, which is what the Karras split search needs;
3. the hierarchy: each of the T - 1 internal nodes finds its key range and split on its own
   (OpenCL, one work-item a node);
4. flatten into the breadth-first layout of bvh.py (numpy, one step a level), turning every
   subtree of at most `max_leaf` triangles into one leaf, then the node boxes bottom-up
   (bvh.refit_boxes, one step a level).

A tree deeper than MAX_DEPTH (the traversal stack) has its deep subtrees rebuilt with SAH,
depth-limited; rare (it needs thousands of triangles in one Morton cell).

pyopencl is imported here, lazily, through lift_gl.opencl (the `opencl` extra).
"""
from __future__ import annotations

import time

import numpy as np

from .bvh import BVH, MAX_DEPTH, MAX_LEAF, bounds_of, build_bvh, empty_bvh, refit_boxes

MORTON_BITS = 10       # per axis: 30-bit codes

_KERNELS = r"""
// pos: T*k*3 floats (k corners a primitive). The box of primitive t.
void primitive_box(__global const float* pos, const int k, const uint t, float3* lo, float3* hi) {
    __global const float* p = pos + (size_t)t * k * 3;
    *lo = (float3)(p[0], p[1], p[2]);
    *hi = *lo;
    for (int c = 1; c < k; ++c) {
        float3 q = (float3)(p[3 * c], p[3 * c + 1], p[3 * c + 2]);
        *lo = fmin(*lo, q);
        *hi = fmax(*hi, q);
    }
}

uint spread_bits(uint v) {            // 10 bits -> every third bit of 30
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

// One work-item a primitive: the Morton code of its box centre, << 32 | its index.
// origin, scale map the scene box to [0, 1024).
__kernel void morton_keys(__global const float* pos, const int k, const float4 origin,
                          const float4 scale, __global ulong* keys) {
    const uint i = get_global_id(0);
    float3 lo, hi;
    primitive_box(pos, k, i, &lo, &hi);
    float3 u = (0.5f * (lo + hi) - origin.xyz) * scale.xyz;
    u = clamp(u, 0.0f, 1023.0f);   // also maps NaN (non-finite input) to 0
    uint code = (spread_bits((uint)u.x) << 2) | (spread_bits((uint)u.y) << 1) | spread_bits((uint)u.z);
    keys[i] = ((ulong)code << 32) | (ulong)i;
}

// One work-item a sorted key: the box of its primitive, in the keys' order (a gather here
// instead of two numpy row gathers: 2.2 s of a 10M-triangle build on 2 cores).
__kernel void sorted_boxes(__global const float* pos, const int k, __global const ulong* keys,
                           __global float* box_lo, __global float* box_hi) {
    const uint i = get_global_id(0);
    float3 lo, hi;
    primitive_box(pos, k, (uint)(keys[i] & 0xffffffffUL), &lo, &hi);
    vstore3(lo, i, box_lo);
    vstore3(hi, i, box_hi);
}

// Length of the common prefix of keys i and j; -1 when j is outside 0..n-1.
int delta(__global const ulong* keys, const int n, const int i, const int j) {
    if (j < 0 || j >= n) return -1;
    return (int)clz(keys[i] ^ keys[j]);
}

// One work-item an internal node i (0 .. n-2). Node ids: internal 0 .. n-2, leaf k is n-1+k.
// Each node covers a contiguous range of the sorted keys; it finds that range's other end by
// an exponential then a binary search, then the split (the highest differing bit).
__kernel void karras_nodes(__global const ulong* keys, const int n, __global int* left,
                           __global int* right, __global int* range_lo, __global int* range_hi) {
    const int i = get_global_id(0);
    const int d = (delta(keys, n, i, i + 1) - delta(keys, n, i, i - 1)) >= 0 ? 1 : -1;
    const int d_min = delta(keys, n, i, i - d);
    int l_max = 2;
    while (delta(keys, n, i, i + l_max * d) > d_min) l_max *= 2;
    int l = 0;
    for (int t = l_max / 2; t >= 1; t /= 2)
        if (delta(keys, n, i, i + (l + t) * d) > d_min) l += t;
    const int j = i + l * d;
    const int d_node = delta(keys, n, i, j);
    int s = 0;
    int t = l;
    do {
        t = (t + 1) / 2;
        if (delta(keys, n, i, i + (s + t) * d) > d_node) s += t;
    } while (t > 1);
    const int gamma = i + s * d + min(d, 0);
    const int lo = min(i, j), hi = max(i, j);
    left[i] = (lo == gamma) ? n - 1 + gamma : gamma;
    right[i] = (hi == gamma + 1) ? n - 1 + gamma + 1 : gamma + 1;
    range_lo[i] = lo;
    range_hi[i] = hi;
}
"""

_kernels = None


def _cl_kernels() -> dict:
    """The kernels by name, built once per process (PoCL caches the binary on disk too)."""
    global _kernels
    if _kernels is None:
        from ..opencl import device, import_pyopencl

        cl = import_pyopencl("the LBVH builder (lift_gl/accel/lbvh.py)")
        context, _ = device("the LBVH builder (lift_gl/accel/lbvh.py)")
        program = cl.Program(context, _KERNELS).build()
        _kernels = {name: cl.Kernel(program, name) for name in ("morton_keys", "sorted_boxes", "karras_nodes")}
    return _kernels


def _sorted_keys(pos: np.ndarray):
    """Steps 1-2: the sorted (Morton code << 32 | index) keys, uint64 (T,), and the triangle
    boxes (lo, hi), float32 (T, 3) each, in the keys' order."""
    import pyopencl as cl

    from ..opencl import device

    context, queue = device()
    n, k = pos.shape[0], pos.shape[1]
    lo, hi = (b.astype(np.float64) for b in bounds_of(pos.reshape(-1, 3)))
    extent = np.maximum(hi - lo, 1e-30)
    scale = (2 ** MORTON_BITS) / extent * (1 - 1e-6)   # keep the top cell inside 0..1023
    mf = cl.mem_flags
    pos_buf = cl.Buffer(context, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=pos)
    keys = np.empty(n, np.uint64)
    keys_buf = cl.Buffer(context, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=keys)
    _cl_kernels()["morton_keys"](queue, (n,), None, pos_buf, np.int32(k), np.array([*lo, 0], np.float32),
                                   np.array([*scale, 0], np.float32), keys_buf)
    cl.enqueue_copy(queue, keys, keys_buf)
    queue.finish()
    keys.sort()
    cl.enqueue_copy(queue, keys_buf, keys)
    box_lo = np.empty((n, 3), np.float32)
    box_hi = np.empty((n, 3), np.float32)
    boxes = [cl.Buffer(context, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=a) for a in (box_lo, box_hi)]
    _cl_kernels()["sorted_boxes"](queue, (n,), None, pos_buf, np.int32(k), keys_buf, *boxes)
    for a, b in zip((box_lo, box_hi), boxes):
        cl.enqueue_copy(queue, a, b)
    queue.finish()
    return keys, box_lo, box_hi


def _karras(keys: np.ndarray):
    """Step 3: (left, right, range_lo, range_hi), int32 (T-1,) each; T >= 2."""
    import pyopencl as cl

    from ..opencl import device

    context, queue = device()
    n = keys.shape[0]
    mf = cl.mem_flags
    keys_buf = cl.Buffer(context, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=keys)
    out = [np.empty(n - 1, np.int32) for _ in range(4)]
    bufs = [cl.Buffer(context, mf.WRITE_ONLY, a.nbytes) for a in out]
    _cl_kernels()["karras_nodes"](queue, (n - 1,), None, keys_buf, np.int32(n), *bufs)
    for a, b in zip(out, bufs):
        cl.enqueue_copy(queue, a, b)
    queue.finish()
    return out


class _PointerTree:
    """A binary tree as child pointers over node ids 0 .. size-1 (not all ids need be
    reachable): interior nodes have left/right >= 0; leaves have left == -1 and a triangle
    range first .. first + count - 1."""

    def __init__(self, left, right, first, count):
        self.left, self.right = left, right
        self.first, self.count = first, count

    def flatten(self, root: int) -> tuple[np.ndarray, int]:
        """Breadth-first nodes (boxes left 0: refit them) with sibling pairs adjacent,
        and the depth."""
        rows = []          # per level: the pointer-tree ids, in output order
        level = np.array([root], np.int64)
        n_out = 0
        while level.size:
            rows.append(level)
            n_out += level.size
            inner = level[self.left[level] >= 0]
            level = np.stack([self.left[inner], self.right[inner]], axis=1).ravel()
        nodes = np.zeros((n_out, 8), np.float32)
        u = nodes.view(np.uint32)
        start = 0
        for li, ids in enumerate(rows):
            out = np.arange(start, start + ids.size)
            start += ids.size
            leaf = self.left[ids] < 0
            u[out[leaf], 3] = self.first[ids[leaf]]
            u[out[leaf], 7] = self.count[ids[leaf]]
            inner = out[~leaf]
            # children of this level's interior nodes come next, two each, in order
            u[inner, 3] = start + 2 * np.arange(inner.size)
            u[inner, 7] = 0
        return nodes, len(rows)


def _lbvh_tree(keys: np.ndarray, max_leaf: int):
    """The Karras hierarchy as a _PointerTree whose subtrees of <= max_leaf triangles are
    leaves."""
    n = keys.shape[0]
    left, right, rlo, rhi = _karras(keys)   # int32: half the memory traffic of int64
    size = np.concatenate([rhi - rlo + 1, np.ones(n, np.int32)])
    lo = np.concatenate([rlo, np.arange(n, dtype=np.int32)])
    small = size[: n - 1] <= max_leaf
    left = np.concatenate([np.where(small, np.int32(-1), left), np.full(n, -1, np.int32)])
    right = np.concatenate([right, np.full(n, -1, np.int32)])
    return _PointerTree(left, right, lo, size)


def _limit_depth(bvh: BVH, pos_sorted: np.ndarray, max_depth: int) -> BVH:
    """Rebuild, with depth-limited binned SAH, every subtree that reaches below max_depth,
    starting at a node of level max_depth - 24 (the rebuilt part gets 24 levels)."""
    cut = max(max_depth - 24, 1)
    first = bvh.first.astype(np.int64)
    count = bvh.count.astype(np.int64)
    # triangle range of every node: leaves have theirs; interior nodes span their children's
    levels, frontier = [], np.zeros(1, np.int64)
    while frontier.size:
        levels.append(frontier)
        inner = frontier[count[frontier] == 0]
        frontier = np.concatenate([first[inner], first[inner] + 1])
    r_lo = np.where(count > 0, first, 0)
    r_hi = np.where(count > 0, first + count, 0)
    deep = np.zeros(bvh.num_nodes, bool)
    for li in range(len(levels) - 1, -1, -1):
        ids = levels[li]
        inner = ids[count[ids] == 0]
        a, b = first[inner], first[inner] + 1
        r_lo[inner] = np.minimum(r_lo[a], r_lo[b])
        r_hi[inner] = np.maximum(r_hi[a], r_hi[b])
        if li + 1 > max_depth:
            deep[ids] = True
        deep[inner] |= deep[a] | deep[b]
    # pointer form of the old tree, its cut nodes turned into leaves over their range
    n = bvh.num_nodes
    left = np.where(count == 0, first, -1)
    right = np.where(count == 0, first + 1, -1)
    f, c = r_lo.copy(), r_hi - r_lo
    order = np.arange(pos_sorted.shape[0], dtype=np.int64)
    redo = levels[cut - 1][deep[levels[cut - 1]]]
    lefts, rights, firsts, counts = [left], [right], [f], [c]
    next_id = n
    for v in redo:
        a, b = int(r_lo[v]), int(r_hi[v])
        sub = build_bvh(pos_sorted[a:b], max_depth=max_depth - cut + 1)
        order[a:b] = a + sub.order.astype(np.int64)
        s_first = sub.first.astype(np.int64)
        s_leaf = sub.count > 0
        ids = next_id - 1 + np.arange(sub.num_nodes)   # appended after the ids so far
        ids[0] = v        # the sub-root replaces v
        lefts.append(np.where(s_leaf, -1, ids[np.where(s_leaf, 0, s_first)])[1:])
        rights.append(np.where(s_leaf, -1, ids[np.where(s_leaf, 0, s_first + 1)])[1:])
        firsts.append(np.where(s_leaf, a + s_first, 0)[1:])
        counts.append(sub.count.astype(np.int64)[1:])
        left[v] = -1 if s_leaf[0] else ids[s_first[0]]
        right[v] = -1 if s_leaf[0] else ids[s_first[0] + 1]
        f[v], c[v] = (a + s_first[0], sub.count[0]) if s_leaf[0] else (0, 0)
        next_id += sub.num_nodes - 1
    tree = _PointerTree(np.concatenate(lefts), np.concatenate(rights), np.concatenate(firsts),
                        np.concatenate(counts))
    nodes, depth = tree.flatten(0)
    new_order = bvh.order[order]
    out = BVH(nodes=nodes, order=new_order, depth=depth)
    out.nodes[:, 0:3], out.nodes[:, 4:7] = refit_boxes(out, pos_sorted[order])
    return out


def build_lbvh(tri_positions: np.ndarray, *, max_leaf: int = MAX_LEAF, max_depth: int = MAX_DEPTH,
               timings: dict | None = None) -> BVH:
    """LBVH of a float32 (T, K, 3) primitive array (see bvh.build_bvh for K). Leaves hold the
    Morton-consecutive triangles of subtrees of at most max_leaf triangles. `timings`, if
    given, receives the seconds of each step (benchmarks/bvh_scale.py reports them)."""
    clock = [time.perf_counter()]

    def lap(name):
        if timings is not None:
            now = time.perf_counter()
            timings[name] = timings.get(name, 0.0) + now - clock[0]
            clock[0] = now

    pos = np.ascontiguousarray(tri_positions, dtype=np.float32)
    if pos.ndim != 3 or pos.shape[1] < 1 or pos.shape[2] != 3:
        raise ValueError(f"tri_positions must have shape (T, 3, 3) or (T, K, 3), got {pos.shape}")
    n = pos.shape[0]
    if n == 0:
        return empty_bvh()
    if n >= 2**31 - 1:
        raise ValueError("too many triangles for the LBVH's 32-bit node ids")
    if not np.isfinite(pos).all():
        pos = np.where(np.isfinite(pos), pos, np.float32(0.0))
    if n == 1:
        return build_bvh(pos)
    lap("input checks")
    keys, box_lo, box_hi = _sorted_keys(pos)
    lap("morton codes (OpenCL), sort (numpy), boxes in order (OpenCL)")
    order = (keys & np.uint64(0xFFFFFFFF)).astype(np.int64)
    tree = _lbvh_tree(keys, max_leaf)
    del keys
    lap("hierarchy (OpenCL)")
    nodes, depth = tree.flatten(0)
    lap("flatten")
    bvh = BVH(nodes=nodes, order=order.astype(np.uint32), depth=depth)
    bvh.nodes[:, 0:3], bvh.nodes[:, 4:7] = refit_boxes(bvh, None, tri_boxes=(box_lo, box_hi))
    lap("fit boxes")
    if depth > max_depth:
        bvh = _limit_depth(bvh, pos[order], max_depth)
        lap("depth limit")
    return bvh
