"""Bounding volume hierarchy over triangles: a binned-SAH build in vectorised numpy, the flat
node layout the GPU traverses (shaders/lift/bvh.glsl), and a numpy traversal for tests.

Why level by level: a recursive build costs one Python call per node (about 2T of them),
which is minutes for a million triangles. Here every node of one tree level is handled by
the same handful of array operations (gather, segment reductions, one sort), so Python
work is proportional to the tree depth, not the node count.

Node layout, one float32 row of 8 per node (two vec4 on the GPU):
    [bmin.x, bmin.y, bmin.z, first, bmax.x, bmax.y, bmax.z, count]
`first` and `count` are uint32 bit patterns stored in the float32 array. count == 0 marks an
interior node whose children are nodes `first` and `first + 1`; count > 0 a leaf holding
triangles first .. first + count - 1 of the array reordered by `BVH.order`. Node 0 is the
root. Nodes are numbered breadth first.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Bump when the node layout or the build's meaning changes: the on-disk cache keys on it.
LAYOUT_VERSION = "lift-bvh-1:f32x8(bmin,first,bmax,count);bfs;sah"

MAX_DEPTH = 48      # the GLSL traversal stack holds 48 entries; deeper trees would overflow it
MAX_LEAF = 4        # a leaf may hold at most this many triangles unless depth forces it
MIN_SPLIT = 3       # nodes of 1 or 2 triangles are always leaves
SAH_BINS = 32
SMALL_NODE = 8      # nodes of at most this many triangles are binned with this many bins
# build_bvh's large_bins are for nodes of at least this many triangles: the few nodes at the
# top of the tree, where a plane between two of 32 bins may miss the split that separates a
# room's rows of furniture (docs/bvh.md, "Finer bins at the top").
LARGE_NODE = 1024
LARGE_BINS = 128
# Cost of one box test relative to one triangle test; both are a few dozen flops on a GPU.
TRAVERSAL_COST = 1.0

_INV_GUARD = 1e-30  # |dir| below this is treated as this, so 1/dir stays finite (no 0 * inf)


@dataclass
class BVH:
    nodes: np.ndarray   # float32 (N, 8), layout above
    order: np.ndarray   # uint32 (T,): reordered triangle i is input triangle order[i]
    depth: int          # number of node levels (root alone = 1)

    @property
    def num_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def first(self) -> np.ndarray:
        return self.nodes.view(np.uint32)[:, 3]

    @property
    def count(self) -> np.ndarray:
        return self.nodes.view(np.uint32)[:, 7]

    @property
    def bmin(self) -> np.ndarray:
        return self.nodes[:, 0:3]

    @property
    def bmax(self) -> np.ndarray:
        return self.nodes[:, 4:7]

    @property
    def num_leaves(self) -> int:
        return int(np.count_nonzero(self.count))


def empty_bvh() -> BVH:
    """One empty leaf-like root with an inverted box. Because count is 0 it reads as an
    interior node, so traversals must skip the BVH entirely when there are no triangles
    (bvh.glsl checks u_num_triangles == 0, intersect_numpy checks T == 0)."""
    nodes = np.zeros((1, 8), np.float32)
    nodes[0, 0:3] = 1.0
    nodes[0, 4:7] = -1.0
    return BVH(nodes=nodes, order=np.zeros(0, np.uint32), depth=1)


def _box_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half surface area (the factor 2 cancels in SAH ratios); empty boxes (lo > hi) give 0.

    A tiny multiple of the squared half perimeter is added so that boxes flat in two axes
    (triangles all on one line) still have a measure that favours even splits; with pure
    area every split of such a node costs 0, SAH peels off one bin per level and the tree
    hits the depth limit."""
    e = np.maximum(hi - lo, 0.0)      # empty: (-inf) - (+inf) = -inf -> 0
    p = e[..., 0] + e[..., 1] + e[..., 2]
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0] + 1e-6 * p * p


def _sah_sweep(n_rows: int, width: int, flat: np.ndarray, count: np.ndarray, lo: np.ndarray,
               hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Best plane split of each row of a (n_rows, width) bin grid whose non-empty cells
    `flat` hold `count` triangles with bounds lo..hi. Returns (SAH cost numerator
    NL*AL + NR*AR, NL) per row; cost is inf where no split leaves both sides non-empty.
    Split k puts bins 0..k left and k+1..width-1 right."""
    cnt = np.zeros(n_rows * width, np.int64)
    cnt[flat] = count
    blo = np.full((n_rows * width, 3), np.inf)
    bhi = np.full((n_rows * width, 3), -np.inf)
    blo[flat] = lo
    bhi[flat] = hi
    cnt = cnt.reshape(n_rows, width)
    blo = blo.reshape(n_rows, width, 3)
    bhi = bhi.reshape(n_rows, width, 3)
    l_cnt = np.cumsum(cnt, axis=1)[:, :-1]
    l_area = _box_area(np.minimum.accumulate(blo, axis=1), np.maximum.accumulate(bhi, axis=1))[:, :-1]
    r_cnt = cnt.sum(axis=1, keepdims=True) - l_cnt
    r_area = _box_area(np.minimum.accumulate(blo[:, ::-1], axis=1)[:, ::-1],
                       np.maximum.accumulate(bhi[:, ::-1], axis=1)[:, ::-1])[:, 1:]
    cost = l_cnt * l_area + r_cnt * r_area
    cost[(l_cnt == 0) | (r_cnt == 0)] = np.inf
    best = np.argmin(cost, axis=1)
    rows = np.arange(n_rows)
    return cost[rows, best], l_cnt[rows, best]


def _bin_keys(axis, c, c_lo, c_hi, n_bins, seg, bins, total):
    """Each triangle's (node, bin) key for binning its node's centroids along `axis` (one per
    node), the stable order that sorts the keys, and where each (node, bin) group starts in
    that order."""
    n_act = axis.size
    ax_lo = c_lo[np.arange(n_act), axis]
    extent = c_hi[np.arange(n_act), axis] - ax_lo
    scale = np.where(extent > 0, n_bins / np.where(extent > 0, extent, 1.0), 0.0)
    b = ((c[np.arange(total), axis[seg]] - ax_lo[seg]) * scale[seg]).astype(np.int64)
    np.clip(b, 0, (n_bins - 1)[seg], out=b)
    key = seg * bins + b
    perm = np.argsort(key, kind="stable")
    sorted_key = key[perm]
    gstart = np.flatnonzero(np.concatenate(([True], sorted_key[1:] != sorted_key[:-1])))
    return key, perm, gstart


def _best_splits(sorted_key, d, gstart, total, bins, n_bins, forced, n_act, act_count):
    """The cheapest plane split of each node from its (node, bin)-sorted triangles `d`:
    (SAH cost numerator, left count) per node, cost inf where none or the node is forced."""
    gkey = sorted_key[gstart]
    gcount = np.diff(np.append(gstart, total))
    glo = np.minimum.reduceat(d[:, 0:3], gstart, axis=0)
    ghi = np.maximum.reduceat(d[:, 3:6], gstart, axis=0)
    gseg, gbin = np.divmod(gkey, bins)
    best_cost = np.full(n_act, np.inf)
    n_left = act_count // 2
    for width in sorted({int(w) for w in np.unique(n_bins)}):
        sel = np.flatnonzero(~forced & (n_bins == width))
        if sel.size:
            row = np.full(n_act, -1, np.int64)
            row[sel] = np.arange(sel.size)
            g = np.flatnonzero(row[gseg] >= 0)
            cost, nl = _sah_sweep(sel.size, width, row[gseg[g]] * width + gbin[g],
                                  gcount[g], glo[g], ghi[g])
            best_cost[sel] = cost
            n_left[sel] = np.where(np.isfinite(cost), nl, n_left[sel])
    return best_cost, n_left


def build_bvh(tri_positions: np.ndarray, *, bins: int = SAH_BINS, max_leaf: int = MAX_LEAF,
              max_depth: int = MAX_DEPTH, min_split: int = MIN_SPLIT,
              traversal_cost: float = TRAVERSAL_COST, large_bins: int = 0) -> BVH:
    """Binned SAH BVH of a float32 (T, 3, 3) triangle array (triangle, corner, xyz).

    More generally (T, K, 3): primitive i is bounded by the box of its K points. A moving
    triangle passes its corners at shutter open and at shutter close, (T, 6, 3), and gets
    the box it sweeps (a linear motion stays inside the union of the two end boxes).

    Each node bins its triangles' bounding-box centroids into `bins` bins along each of the
    three axes and takes the cheapest of the 3 x (bins - 1) plane splits (nodes of at least
    LARGE_NODE triangles: `large_bins` bins where that is more): the longest axis alone builds
    2.3x faster but cost the classroom's tree 16.3 against 10.3 (docs/bvh.md). A node
    becomes a leaf when it has <= 2 triangles, when it has <= max_leaf and SAH says a split
    does not pay (a split costs `traversal_cost` box tests, relative to one triangle test, plus
    its children's expected cost), or at depth max_depth (the traversal stack size); `min_split` = 2 with
    max_leaf = 1 gives one primitive a leaf (lbvh.py builds over clusters so). When all centroids
    coincide (duplicated or degenerate triangles) no plane separates them and the node is cut
    in half by count, so the build always terminates.
    Non-finite coordinates are treated as 0 for the build (callers should drop such triangles).
    """
    pos = np.asarray(tri_positions, dtype=np.float32)
    if pos.ndim != 3 or pos.shape[1] < 1 or pos.shape[2] != 3:
        raise ValueError(f"tri_positions must have shape (T, 3, 3) or (T, K, 3), got {pos.shape}")
    n_tris = pos.shape[0]
    if n_tris == 0:
        return empty_bvh()
    if n_tris >= 2**32 - 1:
        raise ValueError("too many triangles for 32-bit indices")
    if not np.isfinite(pos).all():
        pos = np.where(np.isfinite(pos), pos, np.float32(0.0))

    # Per-triangle build data [lo.xyz, hi.xyz, centroid.xyz], kept in the same (tree) order
    # as `order`: each level then reads nearly contiguous memory instead of gathering at
    # random, which is what dominates the build time for large inputs otherwise.
    # float32 throughout halves the memory traffic, which is what the build is bound by; the
    # bin index itself is computed in float64 (see below).
    data = np.empty((n_tris, 9), np.float32)
    data[:, 0:3] = pos.min(axis=1)
    data[:, 3:6] = pos.max(axis=1)
    data[:, 6:9] = (data[:, 0:3] + data[:, 3:6]) * np.float32(0.5)

    order = np.arange(n_tris, dtype=np.int64)
    nodes = np.zeros((max(2 * n_tris - 1, 1), 8), np.float32)
    nodes_u = nodes.view(np.uint32)

    # the nodes of the current level: id, start in `order`, triangle count
    act_node = np.zeros(1, np.int64)
    act_start = np.zeros(1, np.int64)
    act_count = np.full(1, n_tris, np.int64)
    n_nodes = 1
    level = 0
    while act_node.size:
        level += 1
        n_act = act_node.size
        seg_off = np.zeros(n_act, np.int64)
        np.cumsum(act_count[:-1], out=seg_off[1:])
        total = int(act_count.sum())
        seg = np.repeat(np.arange(n_act), act_count)
        where = np.arange(total, dtype=np.int64) + np.repeat(act_start - seg_off, act_count)
        d = data[where]
        t_lo = d[:, 0:3]
        t_hi = d[:, 3:6]
        c = d[:, 6:9]
        node_lo = np.minimum.reduceat(t_lo, seg_off, axis=0)
        node_hi = np.maximum.reduceat(t_hi, seg_off, axis=0)
        nodes[act_node, 0:3] = node_lo
        nodes[act_node, 4:7] = node_hi

        # --- bin centroids along each axis ----
        # Small nodes get few bins: with <= SMALL_NODE triangles, SMALL_NODE bins are nearly an
        # exact sweep, and the dense per-node bin grids below are then 4x smaller. Deep levels
        # hold mostly small nodes, so this roughly halves the build time.
        forced = (act_count < min_split) | (level >= max_depth)
        n_bins = np.where(act_count <= SMALL_NODE, min(SMALL_NODE, bins), bins)
        grid = bins   # the width of the (node, bin) key space: the most bins any node has
        if large_bins > bins and act_count.max() >= LARGE_NODE:
            n_bins = np.where(act_count >= LARGE_NODE, large_bins, n_bins)
            grid = large_bins
        # float64 here: extents of nearly coincident float32 centroids may be denormal-small
        c_lo = np.minimum.reduceat(c, seg_off, axis=0).astype(np.float64)
        c_hi = np.maximum.reduceat(c, seg_off, axis=0).astype(np.float64)
        longest = np.argmax(c_hi - c_lo, axis=1)
        best_cost = np.full(n_act, np.inf)
        n_left = act_count // 2   # no separating plane (all centroids equal): cut by count
        best_axis = longest.copy()
        keys = []
        for axis in (np.full(n_act, k, np.int64) for k in range(3)):   # each on its own (node, bin)-sorted copy
            key, perm, gstart = _bin_keys(axis, c, c_lo, c_hi, n_bins, seg, grid, total)
            keys.append(key)
            sorted_d = d[perm]
            cost, nl = _best_splits(key[perm], sorted_d, gstart, total, grid, n_bins, forced, n_act, act_count)
            better = cost < best_cost
            best_cost = np.where(better, cost, best_cost)
            n_left = np.where(better & np.isfinite(cost), nl, n_left)
            best_axis = np.where(better, axis, best_axis)
        # each node's triangles in the order of its chosen axis's bins
        chosen = np.take_along_axis(np.stack(keys, axis=1), best_axis[seg][:, None], axis=1)[:, 0]
        perm = np.argsort(chosen, kind="stable")
        sorted_d = d[perm]
        # Sorting by (node, bin) groups each bin's triangles contiguously inside its node's
        # range, so a split after bin k is simply "the first NL triangles of the range".
        d = sorted_d
        data[where] = d
        order[where] = order[where][perm]

        area = _box_area(node_lo.astype(np.float64), node_hi.astype(np.float64))
        # only a node whose triangles are all one point has area 0; it has no plane split
        split_cost = traversal_cost + np.divide(best_cost, area, out=np.zeros(n_act), where=area > 0)
        split_cost[~np.isfinite(best_cost)] = np.inf
        leaf_cost = act_count.astype(np.float64)

        make_leaf = forced | ((act_count <= max_leaf) & (leaf_cost <= split_cost))

        leaf = np.flatnonzero(make_leaf)
        nodes_u[act_node[leaf], 3] = act_start[leaf]
        nodes_u[act_node[leaf], 7] = act_count[leaf]

        split = np.flatnonzero(~make_leaf)
        k = split.size
        child = n_nodes + 2 * np.arange(k, dtype=np.int64)
        n_nodes += 2 * k
        nodes_u[act_node[split], 3] = child
        nodes_u[act_node[split], 7] = 0
        nl = n_left[split]
        act_node = np.stack([child, child + 1], axis=1).ravel()
        act_start = np.stack([act_start[split], act_start[split] + nl], axis=1).ravel()
        act_count = np.stack([nl, act_count[split] - nl], axis=1).ravel()

    return BVH(nodes=nodes[:n_nodes].copy(), order=order.astype(np.uint32), depth=level)


def sah_cost(bvh: BVH) -> float:
    """The expected number of box and triangle tests of a random ray that hits the root box
    (leaves: their references, so a triangle split into several counts in each)."""
    e = np.maximum(bvh.bmax.astype(np.float64) - bvh.bmin, 0)
    area = e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]
    count = bvh.count.astype(np.float64)
    per_node = np.where(count > 0, count, 2 * TRAVERSAL_COST)  # interior: test both children
    return float((area * per_node).sum() / max(area[0], 1e-300))


def bounds_of(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of an (N, D) array, each column reduced on its own: numpy reduces an (N, 3)
    array along axis 0 a 3-wide row at a time, 13x slower (30M points here: 1.06 s against
    0.08 for min). The same values, NaN included."""
    pts = np.asarray(points)
    columns = range(pts.shape[1])
    return (np.array([pts[:, i].min() for i in columns], pts.dtype),
            np.array([pts[:, i].max() for i in columns], pts.dtype))


def refit_boxes(bvh: BVH, tri_points_reordered: np.ndarray | None,
                tri_boxes: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The node boxes of the same tree over other positions of its triangles: float32 (T, K, 3)
    in the tree's order. Returns (lo, hi), float32 (N, 3) each. Motion blur keeps one tree and
    two sets of boxes, at shutter open and at shutter close (shaders/lift/bvh.glsl).
    `tri_boxes`: the triangles' boxes (lo, hi), (T, 3) each in tree order, instead of points."""
    if tri_boxes is None:
        pts = np.asarray(tri_points_reordered, np.float32)
        tri_lo, tri_hi = (pts.min(axis=1), pts.max(axis=1)) if pts.shape[0] else (None, None)
    else:
        tri_lo, tri_hi = tri_boxes
    if tri_lo is None or tri_lo.shape[0] == 0:
        return bvh.bmin.copy(), bvh.bmax.copy()
    n = bvh.num_nodes
    first = bvh.first.astype(np.int64)
    count = bvh.count.astype(np.int64)
    box = np.empty((n, 6), np.float32)   # lo and hi side by side: one gather a child, not two
    # Leaves: their triangle ranges are contiguous and cover 0..T-1, so one segment
    # reduction over the ranges' sorted starts gives every leaf box.
    leaves = np.flatnonzero(count > 0)
    leaves = leaves[np.argsort(first[leaves])]
    box[leaves, :3] = np.minimum.reduceat(tri_lo, first[leaves], axis=0)
    box[leaves, 3:] = np.maximum.reduceat(tri_hi, first[leaves], axis=0)
    # Interior nodes, deepest level first: a child's box is ready before its parent's.
    levels, frontier = [], np.zeros(1, np.int64)
    while frontier.size:
        inner = frontier[count[frontier] == 0]
        levels.append(inner)
        frontier = np.concatenate((first[inner], first[inner] + 1))
    for inner in reversed(levels):
        # np.take gathers rows faster than fancy indexing (random rows: 4x, 10M of them)
        children = first[inner]
        a = np.take(box, children, axis=0)
        b = np.take(box, children + 1, axis=0)
        np.minimum(a[:, :3], b[:, :3], out=a[:, :3])
        np.maximum(a[:, 3:], b[:, 3:], out=a[:, 3:])
        box[inner] = a
    return np.ascontiguousarray(box[:, :3]), np.ascontiguousarray(box[:, 3:])


# --- reference traversal (tests) -----------------------------------------------------------

def _safe_inv(d: np.ndarray) -> np.ndarray:
    d = np.where(np.abs(d) < _INV_GUARD, np.where(np.signbit(d), -_INV_GUARD, _INV_GUARD), d)
    return 1.0 / d


def moller_trumbore(p0, p1, p2, o, d):
    """Vectorised Möller–Trumbore: (t, b1, b2, ok) for matching rows of triangles and rays.
    Triangles seen edge-on (det ~ 0, which includes zero-area ones) never hit."""
    e1 = p1 - p0
    e2 = p2 - p0
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    ok = np.abs(det) > 1e-9 * scale
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    tv = o - p0
    b1 = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    b2 = np.einsum("ij,ij->i", d, qv) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    ok &= (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1)
    return t, b1, b2, ok


def intersect_numpy(bvh: BVH, tri_positions_reordered: np.ndarray, origins: np.ndarray,
                    dirs: np.ndarray, tmin: float = 0.0, tmax: float = np.inf):
    """Closest hit of each ray through `bvh`: (t float64 (R,), tri int64 (R,)), with
    t = inf and tri = -1 for a miss; tri indexes the reordered triangle array.

    Wavefront traversal: all (ray, node) pairs of one tree level are tested at once, pruned
    by each ray's closest hit so far. Slower than a stack per ray in C but has no Python loop
    over rays, and exercises exactly the node layout the GPU reads.
    """
    tris = np.asarray(tri_positions_reordered, np.float64)
    o_all = np.asarray(origins, np.float64).reshape(-1, 3)
    d_all = np.asarray(dirs, np.float64).reshape(-1, 3)
    n_rays = o_all.shape[0]
    best_t = np.full(n_rays, np.inf if tmax is None else float(tmax))
    best_tri = np.full(n_rays, -1, np.int64)
    if tris.shape[0] == 0 or n_rays == 0:
        return np.where(best_tri < 0, np.inf, best_t), best_tri
    inv_all = _safe_inv(d_all)
    bmin = bvh.bmin.astype(np.float64)
    bmax = bvh.bmax.astype(np.float64)
    first = bvh.first.astype(np.int64)
    count = bvh.count.astype(np.int64)

    pr = np.arange(n_rays)
    pn = np.zeros(n_rays, np.int64)
    while pr.size:
        o = o_all[pr]
        inv = inv_all[pr]
        t0 = (bmin[pn] - o) * inv
        t1 = (bmax[pn] - o) * inv
        tn = np.maximum(np.minimum(t0, t1).max(axis=1), tmin)
        tf = np.minimum(np.maximum(t0, t1).min(axis=1), best_t[pr])
        keep = tn <= tf
        pr, pn = pr[keep], pn[keep]
        is_leaf = count[pn] > 0

        lr, ln = pr[is_leaf], pn[is_leaf]
        if lr.size:
            c = count[ln]
            rr = np.repeat(lr, c)
            off = np.cumsum(c) - c
            tt = np.repeat(first[ln] - off, c) + np.arange(int(c.sum()))
            t, _, _, ok = moller_trumbore(tris[tt, 0], tris[tt, 1], tris[tt, 2], o_all[rr], d_all[rr])
            ok &= (t > tmin) & (t < best_t[rr])
            rr, tt, t = rr[ok], tt[ok], t[ok]
            if rr.size:
                s = np.lexsort((t, rr))           # by ray, then nearest first
                rr, tt, t = rr[s], tt[s], t[s]
                head = np.concatenate(([True], rr[1:] != rr[:-1]))
                best_t[rr[head]] = t[head]
                best_tri[rr[head]] = tt[head]

        ir, inode = pr[~is_leaf], pn[~is_leaf]
        pr = np.concatenate((ir, ir))
        pn = np.concatenate((first[inode], first[inode] + 1))
    return np.where(best_tri < 0, np.inf, best_t), best_tri


def check_invariants(bvh: BVH, tri_positions_reordered: np.ndarray) -> None:
    """Raise AssertionError if the tree breaks a layout rule (used by tests and debugging):
    every row in exactly one leaf and every triangle in at least one (`order` repeats those
    split by accel/presplit.py), every node reached once, children inside parents, leaf boxes
    contain their triangles (only where a triangle has one row: a split one's leaf bounds its
    part), depth within bounds."""
    tris = np.asarray(tri_positions_reordered, np.float32)
    n_tris = tris.shape[0]
    nodes = bvh.nodes
    assert nodes.dtype == np.float32 and nodes.ndim == 2 and nodes.shape[1] == 8
    assert bvh.order.dtype == np.uint32 and bvh.order.shape == (n_tris,)
    if n_tris == 0:
        assert nodes.shape[0] == 1 and (nodes[0, 0:3] > nodes[0, 4:7]).all()
        return
    n_source = int(bvh.order.max()) + 1
    assert np.array_equal(np.unique(bvh.order), np.arange(n_source, dtype=np.uint32))
    single = (np.bincount(bvh.order, minlength=n_source) == 1)[bvh.order]  # rows of unsplit triangles
    first = bvh.first.astype(np.int64)
    count = bvh.count.astype(np.int64)
    n = nodes.shape[0]
    interior = np.flatnonzero(count == 0)
    leaves = np.flatnonzero(count > 0)
    assert (first[interior] + 1 < n).all() and (first[interior] > interior).all()
    # each node except the root is the child of exactly one interior node
    parents = np.full(n, -1, np.int64)
    kids = np.concatenate((first[interior], first[interior] + 1))
    assert np.unique(kids).size == kids.size == n - 1 and 0 not in kids
    parents[kids] = np.concatenate((interior, interior))
    # children inside parents
    kid = np.arange(1, n)
    assert (nodes[kid, 0:3] >= nodes[parents[kid], 0:3]).all()
    assert (nodes[kid, 4:7] <= nodes[parents[kid], 4:7]).all()
    # leaves partition 0..T-1
    cover = np.zeros(n_tris, np.int64)
    np.add.at(cover, np.repeat(first[leaves], count[leaves])
              + np.arange(count[leaves].sum()) - np.repeat(np.cumsum(count[leaves]) - count[leaves], count[leaves]), 1)
    assert (cover == 1).all(), "every triangle must be in exactly one leaf"
    # leaf boxes contain their triangles (where the coordinates are finite)
    owner = np.repeat(leaves, count[leaves])
    tri_idx = np.repeat(first[leaves], count[leaves]) + np.arange(count[leaves].sum()) \
        - np.repeat(np.cumsum(count[leaves]) - count[leaves], count[leaves])
    t = tris[tri_idx]
    fin = np.isfinite(t).all(axis=(1, 2)) & single[tri_idx]
    assert (t[fin].min(axis=1) >= nodes[owner[fin], 0:3]).all()
    assert (t[fin].max(axis=1) <= nodes[owner[fin], 4:7]).all()
    # depth: walk the levels (children of the frontier form the next frontier)
    levels, frontier = 0, np.zeros(1, np.int64)
    while frontier.size:
        levels += 1
        inner = frontier[count[frontier] == 0]
        frontier = np.concatenate((first[inner], first[inner] + 1))
    assert levels == bvh.depth <= MAX_DEPTH
