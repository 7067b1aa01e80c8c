"""The 4-wide tree chosen by cost, not by a fixed rule: which binary nodes become wide nodes,
which subtrees become one leaf, by dynamic programming over the binary SAH tree (Ylitie,
Karras and Laine 2017, "Efficient incoherent ray traversal on GPUs through compressed wide
BVHs", section 3.1).

Why: the simple rule (open the largest interior child until a node has four, keep every
binary leaf as a leaf: Wald et al. 2008) never asks what a wide traversal pays, and traced
0.965-0.99x as fast on an H100 (docs/alternatives.md). Here every binary subtree may be
  - one leaf entry (its triangles are contiguous in the binary tree's order, so any subtree of
    at most MAX_LEAF_COUNT triangles can be), tested when its box is hit;
  - a wide node, whose four slots the subtree's descendants fill;
  - or spread over several slots of its parent's wide node;
and the choice minimises the expected cost of a ray that enters the root, each part weighted
by the surface area of the box whose hit triggers it (the SAH):
    wide node visit:  COST_NODE x area of the node's box
    leaf test:        (COST_LEAF + COST_TRIANGLE x its triangles) x area of the leaf's box
With the costs of a GPU (a leaf's triangles are tested one after another by one lane while its
warp waits) the tree gets larger leaves where their boxes are small, and fewer, fuller nodes.

The result is a wide.WideBVH (breadth-first ids, wide.wide_rows' rows), which quantize, the
shaders and the cache read; the leaves' triangle ranges are runs of the binary tree's leaves,
and the triangle arrays stay the binary tree's.
Vectorised by level: bottom-up over the binary tree's depths, top-down over the wide tree's.
"""
from __future__ import annotations

import numpy as np

from .wide import MAX_FIRST, MAX_LEAF_COUNT, STACK, WideBVH, _area, wide_rows

# Relative costs (see the module's docstring). On an H100, pt's trace at 1920x1080 with these
# against (leaf, triangle) of (0.3, 0.4), (0.2, 0.25), (0.3, 0.8), (0.3, 1.0) and (0.5, 0.6):
# the fastest or within 0.3% of it on each of the dining room, the classroom and the Covered
# Dragon ((0.2, 0.25) made the classroom's 1.02x slower than the greedy tree's, the others lie
# within 1.3% of each other; docs/gpu.md "Seventeenth session").
COST_NODE = 1.0
COST_LEAF = 0.3
COST_TRIANGLE = 0.6

SLOTS = 4
# choice codes of the DP tables
_LEAF, _NODE, _FEWER = -1, -2, -3      # >= 1: split, the left child's share of the slots


def collapse_sah(nodes: np.ndarray, cost_node: float = COST_NODE, cost_leaf: float = COST_LEAF,
                 cost_triangle: float = COST_TRIANGLE, slot_order: str = "area") -> WideBVH | None:
    """The cost-optimal 4-wide tree of a binary node array (accel/bvh.py layout, (N, 8)
    float32), or None where the layout cannot hold it: a binary leaf of more than
    MAX_LEAF_COUNT triangles, a triangle index past MAX_FIRST, or a traversal stack deeper than
    STACK. Each node's children in `slot_order` (wide.SLOT_ORDERS)."""
    nodes = np.asarray(nodes, np.float32)
    u = nodes.view(np.uint32)
    first = u[:, 3].astype(np.int64)
    count = u[:, 7].astype(np.int64)
    n = nodes.shape[0]
    leaf = count > 0
    if (count > MAX_LEAF_COUNT).any():
        return None
    bmin, bmax = nodes[:, 0:3], nodes[:, 4:7]
    if leaf[0]:   # a one-leaf tree: one wide node whose only child is that leaf
        if first[0] + count[0] > MAX_FIRST:
            return None
        slots = np.array([[0, -1, -1, -1]], np.int64)
        rows = wide_rows(slots, slots >= 0, np.full((1, SLOTS), -1, np.int64), first, count, bmin, bmax, slot_order)
        return WideBVH(rows=rows, width=SLOTS, stack_bound=0, levels=1)
    area = _area(bmin, bmax)
    left = np.where(leaf, -1, first)           # children of interior nodes: left, left + 1

    # the binary tree's levels, and each subtree's triangles: a contiguous range (start, size)
    frontier = np.zeros(1, np.int64)
    levels = []
    while frontier.size:
        levels.append(frontier)
        inner = frontier[~leaf[frontier]]
        kids = np.sort(np.concatenate([left[inner], left[inner] + 1]))   # sorted: gathers in memory order
        frontier = kids
    start = np.where(leaf, first, 0)
    size = np.where(leaf, count, 0)
    for lv in reversed(levels):
        inner = lv[~leaf[lv]]
        a, b = left[inner], left[inner] + 1
        start[inner] = np.minimum(start[a], start[b])
        size[inner] = size[a] + size[b]
    if (start + size > MAX_FIRST).any():
        return None

    # F[x, i]: the least cost of subtree x as at most i slot roots (i = 1..4); choice[x, i]
    # how (_LEAF, _NODE, _FEWER or a split: the left child's share), choice[x, 0] the split of
    # D(x, 4), which a wide node made of x takes
    F = np.full((n, SLOTS + 1), np.inf)
    choice = np.zeros((n, SLOTS + 1), np.int8)
    as_leaf = np.where(size <= MAX_LEAF_COUNT, area * (cost_leaf + cost_triangle * size), np.inf)
    F[leaf, 1:] = as_leaf[leaf, None]
    choice[leaf, 1:] = _LEAF
    for lv in reversed(levels):
        x = lv[~leaf[lv]]
        if not x.size:
            continue
        Fa, Fb = F[left[x]], F[left[x] + 1]
        Fx = np.empty((x.size, SLOTS + 1))
        Cx = np.empty((x.size, SLOTS + 1), np.int8)
        D = {}
        for i in range(2, SLOTS + 1):   # D(x, i): the best split of i slots between the children
            ks = np.arange(1, i)
            sums = Fa[:, ks] + Fb[:, i - ks]
            best = np.argmin(sums, axis=1)
            D[i] = (sums[np.arange(x.size), best], best + 1)
        as_node = area[x] * cost_node + D[SLOTS][0]
        take_leaf = as_leaf[x] <= as_node
        Fx[:, 1] = np.where(take_leaf, as_leaf[x], as_node)
        Cx[:, 1] = np.where(take_leaf, _LEAF, _NODE)
        for i in range(2, SLOTS + 1):
            fewer = Fx[:, i - 1] <= D[i][0]
            Fx[:, i] = np.where(fewer, Fx[:, i - 1], D[i][0])
            Cx[:, i] = np.where(fewer, _FEWER, D[i][1])
        Cx[:, 0] = D[SLOTS][1]          # column 0: how a wide node made of x splits its slots
        F[x, 1:] = Fx[:, 1:]
        choice[x] = Cx

    # Top down: each wide node's slots, from its binary node's children split as D(x, 4) says
    out_slots, out_kind = [], []            # per level: (m, 4) binary ids (-1 empty), leaf flags
    out_ids = []
    n_wide = 1
    frontier = np.zeros(1, np.int64)
    depth_push = np.zeros(1, np.int64)
    stack_bound = 0
    while frontier.size:
        m = frontier.size
        # pending (wide row, binary node, slots it may take); the root's split as its D(., 4)
        x = frontier
        k = choice[x, 0].astype(np.int64)
        row = np.concatenate([np.arange(m), np.arange(m)])
        item = np.concatenate([left[x], left[x] + 1])
        budget = np.concatenate([k, SLOTS - k])
        done_row, done_node, done_leaf = [], [], []
        while item.size:
            c = choice[item, budget]
            while (c == _FEWER).any():          # fewer slots do as well: step down (never below 1)
                fewer = c == _FEWER
                budget = np.where(fewer, budget - 1, budget)
                c = np.where(fewer, choice[item, budget], c)
            final = (c == _LEAF) | (c == _NODE)
            done_row.append(row[final])
            done_node.append(item[final])
            done_leaf.append(c[final] == _LEAF)
            split = ~final
            s_item, s_k, s_budget, s_row = item[split], c[split], budget[split], row[split]
            row = np.concatenate([s_row, s_row])
            item = np.concatenate([left[s_item], left[s_item] + 1])
            budget = np.concatenate([s_k, s_budget - s_k])
        d_row = np.concatenate(done_row)
        d_node = np.concatenate(done_node)
        d_leaf = np.concatenate(done_leaf)
        order = np.argsort(d_row, kind="stable")
        d_row, d_node, d_leaf = d_row[order], d_node[order], d_leaf[order]
        fill = np.bincount(d_row, minlength=m)
        if (fill > SLOTS).any():
            raise AssertionError("a wide node with more than four slots")
        col = np.arange(d_row.size) - np.repeat(np.cumsum(fill) - fill, fill)
        slots = np.full((m, SLOTS), -1, np.int64)
        is_leaf = np.zeros((m, SLOTS), bool)
        slots[d_row, col] = d_node
        is_leaf[d_row, col] = d_leaf
        stack_bound = max(stack_bound, int((depth_push + fill - 1).max()))
        inner = (slots >= 0) & ~is_leaf
        kcount = int(inner.sum())
        ids = np.full((m, SLOTS), -1, np.int64)
        ids[inner] = n_wide + np.arange(kcount)
        n_wide += kcount
        out_slots.append(slots)
        out_kind.append(is_leaf)
        out_ids.append(ids)
        depth_push = np.repeat(depth_push + fill - 1, inner.sum(axis=1))
        frontier = slots[inner]
    if stack_bound > STACK:
        return None

    rows = wide_rows(np.concatenate(out_slots), np.concatenate(out_kind), np.concatenate(out_ids), start, size,
                     bmin, bmax, slot_order)
    return WideBVH(rows=rows, width=SLOTS, stack_bound=stack_bound, levels=len(out_slots))
