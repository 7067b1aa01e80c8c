"""The 4-wide BVH (lift_gl/accel/wide.py, shaders/lift/bvh.glsl with LIFT_BVH_WIDTH 4): its
structure, and that its traversals find exactly what the binary tree's find: the same
closest hit distance for every ray (the primitive may differ only where two hits are at the
same distance), the same any-hit answer, the same pt images; scenes the wide layout does not
cover keep the binary tree."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import REPO, skip_without_shared
from lift_gl.accel.bvh import build_bvh, intersect_numpy
from lift_gl.accel.wide import (COUNT_SHIFT, EMPTY, GROUP_SHARED_DEPTH, LEAF_BIT, MAX_FIRST, ROWS, STACK,
                                decoded_boxes, intersect_wide_numpy, quantize, stack_defines, stack_size, wide_layout)
from lift_gl.accel.wide_sah import COST_LEAF, COST_NODE, COST_TRIANGLE, collapse_sah
from lift_gl.options import Options
from lift_gl.scene.loader import load_scene
from lift_gl.scene.pack import pack_scene
from test_bvh import NO_HIT, gl, random_rays, run_glsl, soup  # noqa: F401 (gl: a fixture)

WIDE = {"4": {"LIFT_BVH_WIDTH": 4}, "4q": {"LIFT_BVH_WIDTH": 4, "LIFT_BVH_QUANTIZED": True}}


def _entries(wide):
    r = wide.rows.reshape(-1, ROWS, 4)
    return r[:, 6].view(np.uint32).astype(np.int64), r


def _check_structure(wide, tris):
    """What every 4-wide tree must be: each wide node but the root the child of one entry,
    after it; leaf entries covering every triangle row (`tris`, in the tree's order) once, each
    inside its entry's box; interior boxes holding their children's; empty slots (+inf, -inf).
    Returns the entries and slot masks."""
    assert wide is not None and wide.stack_bound <= STACK
    e, r = _entries(wide)
    w = e.shape[0]
    valid = e != EMPTY
    leaf = valid & ((e & LEAF_BIT) != 0)
    inner = valid & ~leaf
    # every wide node but the root is the child of exactly one entry, and comes after it
    kids = e[inner]
    assert np.array_equal(np.sort(kids), np.arange(1, w))
    assert (kids > np.nonzero(inner)[0]).all()
    # the leaf entries cover every triangle row exactly once, as the binary leaves do
    first, count = e[leaf] & (MAX_FIRST - 1), ((e[leaf] >> COUNT_SHIFT) & 15) + 1
    cover = np.zeros(len(tris), np.int64)
    for f, c in zip(first, count):
        cover[f:f + c] += 1
    assert (cover == 1).all()
    assert (count <= 16).all()
    # an interior child's box holds its node's children boxes; empty slots are (+inf, -inf)
    lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1)
    hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1)
    for (f, c), box_lo, box_hi in zip(zip(first, count), lo[leaf], hi[leaf]):
        corners = tris[f:f + c].reshape(-1, 3)
        assert (corners >= box_lo).all() and (corners <= box_hi).all()
    node, slot = np.nonzero(inner)
    child = e[node, slot]
    ok = valid[child]
    assert (lo[child][ok] >= np.repeat(lo[node, slot], 4, axis=0).reshape(-1, 4, 3)[ok]).all()
    assert (hi[child][ok] <= np.repeat(hi[node, slot], 4, axis=0).reshape(-1, 4, 3)[ok]).all()
    assert np.isposinf(lo[~valid]).all() and np.isneginf(hi[~valid]).all()
    assert valid.sum(axis=1).min() >= 1
    return e, valid, leaf, inner


COSTS = (COST_NODE, COST_LEAF, COST_TRIANGLE)


def _wide_cost(wide, costs=COSTS) -> float:
    """The expected cost collapse_sah minimises, read from a tree's rows: each wide node's visit
    (its box: the union of its children's) and each leaf's test, weighted by box area."""
    node, leaf_cost, tri = costs
    e, r = _entries(wide)
    valid = e != EMPTY
    lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1).astype(np.float64)
    hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1).astype(np.float64)

    def area(a, b):
        x = np.maximum(b - a, 0.0)
        return x[..., 0] * x[..., 1] + x[..., 1] * x[..., 2] + x[..., 2] * x[..., 0]

    is_leaf = valid & ((e & LEAF_BIT) != 0)
    count = ((e >> COUNT_SHIFT) & 15) + 1
    root = area(np.where(valid[0, :, None], lo[0], np.inf).min(axis=0), np.where(valid[0, :, None], hi[0], -np.inf).max(axis=0))
    slots = area(lo, hi)
    return float(node * root + (node * slots)[valid & ~is_leaf].sum()
                 + (slots * (leaf_cost + tri * count))[is_leaf].sum())


def _least_cost(nodes, costs=COSTS) -> float:
    """The least cost of any 4-wide tree over this binary tree, by plain recursion over every
    choice (a subtree as one leaf, as a wide node, or spread over slots of its parent): what
    collapse_sah's vectorised tables must reach, for trees small enough to recurse."""
    node_cost, leaf_cost, tri = costs
    u = nodes.view(np.uint32)
    first, count = u[:, 3].astype(int), u[:, 7].astype(int)
    ext = np.maximum(nodes[:, 4:7].astype(np.float64) - nodes[:, 0:3], 0.0)
    area = ext[:, 0] * ext[:, 1] + ext[:, 1] * ext[:, 2] + ext[:, 2] * ext[:, 0]

    def size(x):
        return count[x] if count[x] else size(first[x]) + size(first[x] + 1)

    def forest(x, i):   # subtree x as at most i slot roots
        best = single(x)
        if not count[x]:
            for k in range(1, i):
                best = min(best, forest(first[x], k) + forest(first[x] + 1, i - k))
        return best

    def single(x):      # subtree x as one slot: a leaf, or a wide node of its own
        best = area[x] * (leaf_cost + tri * size(x)) if size(x) <= 16 else np.inf
        if not count[x]:
            best = min(best, area[x] * node_cost + min(forest(first[x], k) + forest(first[x] + 1, 4 - k)
                                                       for k in range(1, 4)))
        return best

    return area[0] * node_cost + min(forest(first[0], k) + forest(first[0] + 1, 4 - k) for k in range(1, 4))


@pytest.mark.parametrize("n", [1, 2, 7, 100, 3000])
def test_sah_collapse_structure(n):
    tris = soup(n, seed=n, degenerate=n >= 100)
    b = build_bvh(tris)
    wide = collapse_sah(b.nodes)
    e, valid, leaf, inner = _check_structure(wide, tris[b.order])
    if b.num_nodes == 1:   # a one-leaf tree: one wide node whose only child is that leaf
        assert (wide.num_nodes, wide.levels, wide.stack_bound, int(valid.sum()), int(leaf.sum())) == (1, 1, 0, 1, 1)


@pytest.mark.parametrize("seed", range(6))
def test_sah_collapse_is_least_cost(seed):
    """On small trees (up to 12 binary leaves, of one triangle each so that merging matters) the
    tree built has exactly the least cost a plain recursion over every choice finds, under the
    default costs and under costs that favour big leaves or many nodes."""
    rng = np.random.default_rng(seed)
    tris = soup(int(rng.integers(6, 13)) * 4, seed=seed)[: int(rng.integers(5, 13))]
    b = build_bvh(tris, max_leaf=1, min_split=2)
    for costs in (COSTS, (1.0, 0.05, 0.05), (1.0, 2.0, 3.0)):
        wide = collapse_sah(b.nodes, *costs)
        _check_structure(wide, tris[b.order])
        assert _wide_cost(wide, costs) == pytest.approx(_least_cost(b.nodes, costs), rel=1e-9)


def test_slots_largest_box_first():
    """By default a node's children go largest box first, empty slots last (the order the
    traversal keeps among children it enters at the same distance); `build` keeps the
    collapse's own order, the same children."""
    b = build_bvh(soup(3000, seed=8))
    wide = wide_layout(b.nodes, "4")
    e, r = _entries(wide)
    ext = np.maximum(np.stack([r[:, 1] - r[:, 0], r[:, 3] - r[:, 2], r[:, 5] - r[:, 4]], -1).astype(np.float64), 0)
    area = np.where(e != EMPTY, ext[..., 0] * ext[..., 1] + ext[..., 1] * ext[..., 2] + ext[..., 2] * ext[..., 0], -1.0)
    assert (np.diff(area, axis=1) <= 0).all()
    e_build, _ = _entries(wide_layout(b.nodes, "4", slot_order="build"))
    assert not np.array_equal(e_build, e)
    np.testing.assert_array_equal(np.sort(e_build, axis=1), np.sort(e, axis=1))
    with pytest.raises(ValueError, match="slot order"):
        wide_layout(b.nodes, "4", slot_order="biggest")


def test_collapse_refuses_what_the_layout_cannot_hold():
    b = build_bvh(soup(64, seed=3), max_depth=1)     # one leaf of 64 triangles: count has 4 bits
    assert b.num_nodes == 1 and collapse_sah(b.nodes) is None and wide_layout(b.nodes, "4") is None


@pytest.mark.parametrize("offset", [0.0, 1e4])
def test_quantized_boxes_contain_the_float_boxes(offset):
    """8-bit boxes, decoded as the GLSL decodes them, hold the float boxes (far from the origin
    too, where the final add rounds), and stay tight: a few percent larger."""
    tris = soup(5000, seed=4) * np.float32(30) + np.float32(offset)
    wide = collapse_sah(build_bvh(tris).nodes)
    q = quantize(wide)
    assert q is not None and q.rows.nbytes * 2 == wide.rows.nbytes
    lo, hi, e = decoded_boxes(wide)
    qlo, qhi, qe = decoded_boxes(q)
    np.testing.assert_array_equal(qe, e)
    v = e != EMPTY
    assert (qlo[v] <= lo[v]).all() and (qhi[v] >= hi[v]).all()
    grow = (qhi - qlo)[v].astype(np.float64).sum(axis=-1) / np.maximum((hi - lo)[v].sum(axis=-1), 1e-12)
    assert np.median(grow) < 1.05


def _assert_ties_only(tris, o, d, t, p_a, p_b):
    """Where two traversals found the same distance t but other triangles, both triangles hold
    the hit point: a ray through an edge or vertex they share, or where coplanar triangles
    overlap (the cornell-box's light on its ceiling); which one a traversal keeps depends on
    the order it tests them in."""
    rows = np.flatnonzero((p_a != p_b) & np.isfinite(t))
    x = o[rows] + t[rows, None] * d[rows]
    for p in (p_a[rows], p_b[rows]):
        a, b, c = (tris[p, k].astype(np.float64) for k in range(3))
        n = np.cross(b - a, c - a)
        nn = np.einsum("ij,ij->i", n, n)
        bary = np.stack([np.einsum("ij,ij->i", np.cross(q - x, r - x), n) / nn for q, r in ((b, c), (c, a), (a, b))], 1)
        assert (bary.min(axis=1) > -1e-4).all()


@pytest.mark.parametrize("layout", ["4", "4q"])
def test_numpy_wide_traversal_matches_binary(layout):
    tris = soup(4000, seed=11)
    b = build_bvh(tris)
    o, d = random_rays(4000, seed=12)
    t2, p2 = intersect_numpy(b, tris[b.order], o, d)
    t4, p4 = intersect_wide_numpy(wide_layout(b.nodes, layout), tris[b.order], o, d)
    np.testing.assert_array_equal(t4, t2)
    _assert_ties_only(tris[b.order], o, d, t2, p4, p2)


def _camera_rays(lo, hi, n_side, seed):
    """Coherent rays: a pinhole camera outside the box aimed at its centre, an n x n grid."""
    rng = np.random.default_rng(seed)
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    eye = centre + 1.6 * radius * rng.standard_normal(3) / np.sqrt(3)
    fwd = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(fwd, [0.0, 0.0, 1.0] if abs(fwd[2]) < 0.9 else [1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    u, v = np.meshgrid(np.linspace(-0.6, 0.6, n_side), np.linspace(-0.6, 0.6, n_side))
    d = fwd + u.reshape(-1, 1) * right + v.reshape(-1, 1) * up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.repeat(eye[None], len(d), axis=0), d


def _scene_rays(lo, hi, seed):
    """Random rays from inside and around the box, and two coherent camera grids."""
    rng = np.random.default_rng(seed)
    ext = hi - lo
    o = lo + ext * rng.uniform(-0.2, 1.2, (6000, 3))
    d = lo + ext * rng.random((6000, 3)) - o
    d[:2000] = rng.standard_normal((2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    cams = [_camera_rays(lo, hi, 64, seed + k) for k in range(2)]
    o = np.concatenate([o] + [c[0] for c in cams]).astype(np.float32).astype(np.float64)
    d = np.concatenate([d] + [c[1] for c in cams]).astype(np.float32).astype(np.float64)
    return o, d


def _packed_triangles(name):
    skip_without_shared(REPO / "scenes" / name)
    packed = pack_scene(load_scene(REPO / "scenes" / name), bvh_width=2, bvh_splits="off")
    return packed.bvh_nodes, packed.tri_pos[:packed.num_triangles, :, :3]


def _case_triangles(case: str):
    """A test case's binary BVH nodes and its triangles in the tree's order: a random soup, or a
    scene of scenes/ as the renderer packs it."""
    if case == "soup":
        tris = soup(20000, seed=5, size=0.03)
        b = build_bvh(tris)
        return b.nodes, tris[b.order]
    return _packed_triangles(case)


def _stack_placement(stack: str) -> dict:
    """Where a test's stack lives: shared (a column for each of the test kernel's 64
    invocations), with only its top 3 entries there (shared3), or a local array."""
    shared = stack.startswith(("shared", "groups")) and stack != "groups_local"
    extra = {"LIFT_BVH_SHARED_STACK": 64} if shared else {}
    if stack.endswith("shared3"):
        extra["LIFT_BVH_SHARED_DEPTH"] = 3
    return extra


def _wide_defines(wide, layout: str, stack: str) -> dict:
    """The wide traversal with the stack the renderer declares for this tree (wide.stack_size;
    node groups: as many entries as the tree has levels)."""
    tight = dict(WIDE[layout], LIFT_BVH_STACK_SIZE=stack_size(wide.stack_bound), **_stack_placement(stack))
    if stack.startswith("groups"):
        assert 1 < wide.levels < wide.stack_bound
        tight.update(LIFT_BVH_GROUP_STACK=True, LIFT_BVH_STACK_SIZE=wide.levels)
    return tight


@pytest.mark.parametrize("case", ["soup", "cornell.toml", "covered_dragon.toml"])
@pytest.mark.parametrize("stack, layout", [
    ("local", "4"), ("shared", "4"), ("shared", "4q"), ("shared3", "4"), ("shared3", "4q"), ("groups", "4"),
    ("groups", "4q"), ("groups_local", "4"), ("groups_shared3", "4")])
def test_glsl_wide_traversal_matches_binary(gl, case, stack, layout):
    """shared3: only the top 3 stack entries in shared memory, the deeper ones spilled to the
    local array (LIFT_BVH_SHARED_DEPTH; by default the whole stack is shared). groups: a stack
    of node groups (LIFT_BVH_GROUP_STACK) exactly as deep as the tree has levels: entries past
    it would land in the next invocation's column (shared) or out of the array."""
    nodes, tris = _case_triangles(case)
    wide = wide_layout(nodes, layout)
    assert wide is not None
    lo, hi = tris.reshape(-1, 3).min(axis=0).astype(np.float64), tris.reshape(-1, 3).max(axis=0).astype(np.float64)
    o, d = _scene_rays(lo, hi, seed=7)
    extra = _stack_placement(stack)
    t2, p2, occ2, found2, _ = run_glsl(gl, nodes, tris, o, d, defines=extra)
    tight = _wide_defines(wide, layout, stack)
    t4, p4, occ4, found4, _ = run_glsl(gl, wide.rows, tris, o, d, defines=tight)
    assert found2.mean() > 0.3
    if extra:   # the binary traversal on a shared (or spilling) stack finds what it finds on a local one
        t_local, p_local, occ_local, found_local, _ = run_glsl(gl, nodes, tris, o, d)
        np.testing.assert_array_equal(found2, found_local)
        np.testing.assert_array_equal(t2[found2], t_local[found2])
        np.testing.assert_array_equal(occ2, occ_local)
    np.testing.assert_array_equal(found4, found2)
    np.testing.assert_array_equal(t4[found2], t2[found2])     # the same nearest distance, bit for bit
    _assert_ties_only(tris, o, d, t2, p4.astype(np.int64), p2.astype(np.int64))   # another primitive only at a tie
    np.testing.assert_array_equal(occ4, occ2)
    # any-hit on bounded intervals (shadow rays): ending before, at and after the nearest hit
    tmax = np.where(found2, t2, 1.0).astype(np.float64) * np.random.default_rng(3).uniform(0.5, 1.5, len(o))
    _, _, occ2, _, _ = run_glsl(gl, nodes, tris, o, d, tmax=tmax.astype(np.float32), defines=extra)
    _, _, occ4, _, _ = run_glsl(gl, wide.rows, tris, o, d, tmax=tmax.astype(np.float32), defines=tight)
    assert 0.1 < occ2.mean() < 0.9
    np.testing.assert_array_equal(occ4, occ2)


@pytest.mark.parametrize("case", ["soup", "cornell.toml", "covered_dragon.toml"])
@pytest.mark.parametrize("stack", ["local", "shared", "groups", "groups_shared3"])
@pytest.mark.parametrize("layout", ["4", "4q"])
def test_glsl_shadow_and_next_in_one_loop_answer_as_two_traversals(gl, case, stack, layout):
    """trace_shadow_and_next with LIFT_TRACE_PAIRED (one traversal loop: the shadow ray, then the
    next ray) finds the closest hit, its t and barycentrics bit for bit, and the occlusion that
    trace_closest and trace_occluded find apart; with neither ray, or one, wanted. With spheres
    on the soup (a sphere may block the shadow ray before the tree is entered)."""
    nodes, tris = _case_triangles(case)
    wide = wide_layout(nodes, layout)
    lo, hi = tris.reshape(-1, 3).min(axis=0).astype(np.float64), tris.reshape(-1, 3).max(axis=0).astype(np.float64)
    o, d = _scene_rays(lo, hi, seed=11)
    n = len(o)
    spheres = None
    if case == "soup":
        rng = np.random.default_rng(3)
        spheres = np.concatenate([lo + (hi - lo) * rng.random((6, 3)), 0.05 * np.ones((6, 1))], axis=1).astype(np.float32)
    base = _wide_defines(wide, layout, stack)
    # shadow intervals ending before, at and after the nearest hit, as pt's end at their light
    t0, _, _, found0, _ = run_glsl(gl, wide.rows, tris, o, d, spheres=spheres, defines=base)
    tmax = (np.where(found0, t0, 1.0).astype(np.float64) * np.random.default_rng(4).uniform(0.5, 1.5, n)).astype(np.float32)
    t, prim, occ, found, bary = run_glsl(gl, wide.rows, tris, o, d, tmax=tmax, spheres=spheres, defines=base)
    tp, primp, occp, foundp, baryp = run_glsl(gl, wide.rows, tris, o, d, tmax=tmax, spheres=spheres, paired=True,
                                              defines=dict(base, LIFT_TRACE_PAIRED=True))
    i = np.arange(n)
    j = (7 * i + 3) % n
    shadow, nxt = i % 3 != 1, i % 3 != 2
    assert 0.1 < occ[shadow].mean() < 0.9 and 0.3 < found[j[nxt]].mean()
    np.testing.assert_array_equal(occp, occ & shadow)
    np.testing.assert_array_equal(foundp, found[j] & nxt)
    np.testing.assert_array_equal(primp[nxt], prim[j[nxt]])
    np.testing.assert_array_equal(tp[nxt], t[j[nxt]])
    np.testing.assert_array_equal(baryp[nxt], bary[j[nxt]])
    assert (primp[~nxt] == NO_HIT).all()


def test_pack_scene_width_and_fallbacks():
    cornell = load_scene(REPO / "scenes" / "cornell.toml")
    assert pack_scene(cornell, bvh_width=4).bvh_width == 4
    assert pack_scene(cornell, bvh_width=2).bvh_width == 2
    assert pack_scene(cornell).bvh_width == 2   # the device unknown: the binary tree
    packed = pack_scene(cornell, bvh_width="4q")
    assert (packed.bvh_width, packed.bvh_quantized, packed.bvh_nodes.shape[1]) == (4, True, 16)
    # motion blur (per-node close boxes) and traced instances (BLAS roots) keep the binary tree
    for name in ("motion_blur.toml", "instances.toml"):
        packed = pack_scene(load_scene(REPO / "scenes" / name), bvh_width=4)
        assert packed.bvh_width == 2 and packed.bvh_nodes.shape[1] == 8
    with pytest.raises(ValueError, match="bvh_width must be one of 2, 4, 4q"):
        pack_scene(cornell, bvh_width=8)


def test_the_renderer_keeps_the_binary_tree_where_it_must_and_says_why():
    """Options asking for a 4-wide tree: motion blur keeps the binary one, and explain() and
    the choices say why."""
    from lift_gl.renderer import Renderer

    r = Renderer(load_scene(REPO / "scenes" / "motion_blur.toml"), size=(8, 8), integrator="drt",
                 options=Options(bvh_width="4"))
    try:
        assert r.packed.bvh_width == 2 and r.choices["bvh_width"] == "2"
        assert "bvh_width           4 -> 2 because shaders with motion blur keep the binary tree" in r.explain()
        assert r.choices["bvh_stack_entries"] is None and r.choices["trace_paired"] is None
    finally:
        r.release()


def _render(width, scene, integrator, size=(40, 32), spp=4, group_stack=False, options=None, **kw):
    from lift_gl.renderer import Renderer

    options = dataclasses.replace(options or Options(), bvh_width=width)
    r = Renderer(scene, size=size, integrator=integrator, seed=5, options=options, **kw)
    try:
        assert ("LIFT_BVH_GROUP_STACK" in r.defines) == group_stack
        return r.render(spp=spp), r.packed.bvh_width, r.defines.get("LIFT_BVH_WIDTH"), r.defines.get("LIFT_BVH_QUANTIZED")
    finally:
        r.release()


@pytest.mark.parametrize("scene_name, integrator", [
    ("cornell.toml", "pt"),          # closest hits and shadow rays
    ("showcase.toml", "pt"),         # spheres beside the triangles, textures
    ("cornell.toml", "drt"),         # camera rays through the trace pass
])
@pytest.mark.parametrize("stack, layout, entries", [("local", "4", "children"), ("shared", "4", "children"),
                                                    ("shared", "4q", "children"), ("shared", "4", "groups"),
                                                    ("local", "4q", "groups")])
def test_wide_renders_the_binary_image(scene_name, integrator, stack, layout, entries):
    options = Options(bvh_stack=stack, bvh_stack_entries=entries)
    scene = load_scene(REPO / "scenes" / scene_name)
    binary, w2, d2, q2 = _render("2", scene, integrator, options=options)
    wide, w4, d4, q4 = _render(layout, scene, integrator, group_stack=entries == "groups", options=options)
    assert (w2, d2, q2, w4, d4, q4) == (2, None, None, 4, 4, True if layout == "4q" else None)
    assert np.isfinite(binary).all() and binary.max() > 0
    np.testing.assert_array_equal(wide, binary)


@pytest.mark.parametrize("entries", ["children", "groups"])
def test_wide_split_scene_renders_the_same_image(entries):
    """A scene split across buffers (scene/split.py) reads the wide nodes through the heap, the
    node groups' entries too."""
    from lift_gl.renderer import Renderer
    from test_split_buffers import _small_limit

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    whole = _render("4", scene, "pt", group_stack=entries == "groups", options=Options(bvh_stack_entries=entries))[0]
    r = Renderer(scene, size=(40, 32), integrator="pt", seed=5,
                 options=Options(bvh_width="4", bvh_stack_entries=entries,
                                 max_buffer_bytes=_small_limit(pack_scene(scene, bvh_width=4))))
    try:
        assert r.buffers.plan.split and r.buffers.plan.chunks >= 2 and r.packed.bvh_width == 4
        assert ("LIFT_BVH_GROUP_STACK" in r.defines) == (entries == "groups")
        split = r.render(spp=4)
    finally:
        r.release()
    np.testing.assert_array_equal(split, whole)


def test_the_shaders_declare_the_stack_the_tree_needs():
    """LIFT_BVH_STACK_SIZE: the tree's own stack bound rounded up to a multiple of 8 (8 to
    STACK), so a small scene's traversal takes a fraction of the shared memory; the renderer
    compiles its passes with it (the images above are rendered so)."""
    from lift_gl.renderer import Renderer

    assert [stack_size(n) for n in (0, 1, 8, 9, 46, 64)] == [8, 8, 8, 16, 48, 64] and stack_size(99) == STACK
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(16, 16), integrator="pt")
    try:
        if r.packed.bvh_width == 4:
            assert 0 < r.packed.bvh_stack <= r.defines["LIFT_BVH_STACK_SIZE"] == stack_size(r.packed.bvh_stack) < STACK
            assert "#define LIFT_BVH_STACK_SIZE" in r.trace.source.text
    finally:
        r.release()


def _cornell_with_a_cloud(triangles: int = 6000):
    """The cornell-box with a cloud of small triangles inside the room: a deeper tree."""
    from lift_gl.scene.model import Mesh

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    tris = soup(triangles, seed=31, size=0.05, degenerate=False).astype(np.float64)
    pts = np.concatenate([m.positions for m in scene.meshes])
    box_lo, box_hi = pts.min(axis=0), pts.max(axis=0)
    tris = box_lo + (0.2 + 0.3 * tris) * (box_hi - box_lo)
    cloud = Mesh("cloud", tris.reshape(-1, 3), np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3),
                 scene.meshes[0].material)
    return dataclasses.replace(scene, meshes=[*scene.meshes, cloud])


def test_an_edit_that_deepens_the_tree_recompiles_with_the_deeper_stack():
    """A geometry edit whose tree needs a deeper stack changes LIFT_BVH_STACK_SIZE: the passes
    are recompiled with it, and the frame equals a fresh renderer's."""
    from lift_gl.renderer import Renderer

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    bigger = _cornell_with_a_cloud()
    r = Renderer(scene, size=(32, 32), integrator="pt", seed=1)
    try:
        before = r.defines["LIFT_BVH_STACK_SIZE"]
        r.update_scene(bigger)
        after = r.defines["LIFT_BVH_STACK_SIZE"]
        assert after > before and f"#define LIFT_BVH_STACK_SIZE {after}" in r.trace.source.text
        image = r.render(spp=2)
        fresh = Renderer(bigger, size=(32, 32), integrator="pt", seed=1)
        try:
            np.testing.assert_array_equal(image, fresh.render(spp=2))
        finally:
            fresh.release()
    finally:
        r.release()


def test_stack_defines():
    """A stack of children as deep as the tree's stack bound, of node groups as its levels (the
    top GROUP_SHARED_DEPTH in shared memory); which one a device and tree get: tests/test_options.py."""
    groups = {"LIFT_BVH_GROUP_STACK": True, "LIFT_BVH_STACK_SIZE": 24, "LIFT_BVH_SHARED_DEPTH": GROUP_SHARED_DEPTH}
    assert stack_defines(54, 18, "groups") == groups                          # Lift's dining room
    assert stack_defines(54, 18, "children") == {"LIFT_BVH_STACK_SIZE": 56}
    assert stack_defines(11, 4, "children") == {"LIFT_BVH_STACK_SIZE": 16}    # the cornell-box
    assert stack_defines(11, 4, "groups") == dict(groups, LIFT_BVH_STACK_SIZE=8)
    with pytest.raises(ValueError, match="stack entries"):
        stack_defines(54, 18, "pairs")


def test_collapse_counts_levels():
    """WideBVH.levels, the group stack's depth: the wide nodes on the longest root path,
    counted here by walking the child entries (and kept by quantize)."""
    tris = soup(3000, seed=2, size=0.05)
    wide = collapse_sah(build_bvh(tris).nodes)
    entries = _entries(wide)[0]
    depth = np.zeros(wide.num_nodes, np.int64)
    for node in range(wide.num_nodes):   # breadth first: a parent comes before its children
        inner = [e for e in entries[node] if e != EMPTY and not e & LEAF_BIT]
        depth[inner] = depth[node] + 1
    assert wide.levels == depth.max() + 1 and 1 < wide.levels < wide.stack_bound
    assert quantize(wide).levels == wide.levels


def test_plugins_with_splats_keep_the_stack_of_children_on_gpus(as_if_gpu):
    """On a GPU (emulated here) a deep tree gets node groups, but a plugin with splats (bdpt: 3x
    slower with them on an H100) keeps child entries; the option decides where set."""
    from lift_gl.renderer import Renderer

    scene = _cornell_with_a_cloud()   # a stack of children would need 40 entries
    cases = {("pt", "auto"): "groups", ("pt", "children"): "children", ("bdpt", "groups"): "groups",
             ("bdpt", "auto"): "children"}
    for (integrator, asked), expect in cases.items():
        r = Renderer(scene, size=(8, 8), integrator=integrator, options=Options(bvh_stack_entries=asked))
        try:
            assert r.packed.bvh_stack > 32 and r.choices["bvh_stack_entries"] == expect, (integrator, asked)
            assert ("#define LIFT_BVH_GROUP_STACK" in r.trace.source.text) == (expect == "groups")
        finally:
            r.release()


@pytest.mark.parametrize("scene_name", ["cornell.toml", "showcase.toml"])   # area light; spheres, textures, sky
@pytest.mark.parametrize("entries", ["children", "groups"])
def test_pt_with_the_pair_in_one_loop_renders_the_same_image(scene_name, entries):
    """pt's vertex traces its shadow ray and next ray with trace_shadow_and_next: the image with
    them in one loop (trace_paired on, GPUs' default on deep trees) is the one traced apart, bit
    for bit."""
    from lift_gl.renderer import Renderer

    scene = load_scene(REPO / "scenes" / scene_name)
    images = {}
    for paired in ("off", "on"):
        r = Renderer(scene, size=(40, 32), integrator="pt", seed=5,
                     options=Options(bvh_stack="shared", bvh_stack_entries=entries, bvh_width="4", trace_paired=paired))
        try:
            assert ("LIFT_TRACE_PAIRED" in r.defines) == (paired == "on")
            assert ("LIFT_BVH_GROUP_STACK" in r.defines) == (entries == "groups")
            images[paired] = r.render(spp=4)
        finally:
            r.release()
    assert np.isfinite(images["on"]).all() and images["on"].max() > 0
    np.testing.assert_array_equal(images["on"], images["off"])


def test_large_trees_wide_layout_is_cached(tmp_path, monkeypatch):
    """A large tree's wide layout is written beside its BVH once and read back the same, keyed
    on every setting that shapes it; a damaged file is collapsed again; small trees are not
    cached."""
    from lift_gl.accel import cache

    b = build_bvh(soup(2000, seed=9))
    calls = []
    real = cache.wide_layout
    monkeypatch.setattr(cache, "wide_layout", lambda *a, **k: calls.append(a[1:]) or real(*a, **k))
    cache.wide_layout_cached(b.nodes, "4", cache_dir=tmp_path)
    assert len(calls) == 1 and not list(tmp_path.iterdir())            # small: not cached
    monkeypatch.setattr(cache, "WIDE_CACHE_MIN_NODES", 1)
    first = cache.wide_layout_cached(b.nodes, "4", cache_dir=tmp_path)
    [path] = tmp_path.iterdir()
    again = cache.wide_layout_cached(b.nodes, "4", cache_dir=tmp_path)
    assert len(calls) == 2                                               # the second read from disk
    np.testing.assert_array_equal(again.rows, first.rows)
    assert (again.width, again.stack_bound, again.levels, again.quantized) == \
           (first.width, first.stack_bound, first.levels, first.quantized)
    other = cache.wide_layout_cached(b.nodes, "4", cache_dir=tmp_path, slot_order="build")
    assert not np.array_equal(other.rows, first.rows)
    q = cache.wide_layout_cached(b.nodes, "4q", cache_dir=tmp_path)
    assert q.quantized and cache.wide_layout_cached(b.nodes, "4q", cache_dir=tmp_path).quantized
    assert len(list(tmp_path.iterdir())) == 3 and len(calls) == 4
    path.write_bytes(b"not a zip")
    np.testing.assert_array_equal(cache.wide_layout_cached(b.nodes, "4", cache_dir=tmp_path).rows, first.rows)
    assert len(calls) == 5
