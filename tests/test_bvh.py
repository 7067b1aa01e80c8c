"""BVH build (structure), traversal (numpy and GLSL) against trimesh's ray queries, spheres
against the analytic answer, and the on-disk cache."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.accel import bvh as bvh_mod
from lift_gl.accel import cache as cache_mod
from lift_gl.accel.bvh import MAX_DEPTH, MAX_LEAF, build_bvh, check_invariants, intersect_numpy

N_RAYS = 3000
MISMATCH_BOUND = 0.005   # fraction of rays allowed to disagree (rays grazing shared edges)


def soup(n: int, seed: int, size: float = 0.08, degenerate: bool = True) -> np.ndarray:
    """Random triangles in the unit cube, plus every kind of degenerate one."""
    rng = np.random.default_rng(seed)
    c = rng.random((n, 1, 3))
    tris = c + size * rng.standard_normal((n, 3, 3))
    if degenerate:
        k = max(n // 20, 4)
        idx = rng.choice(n, 4 * k, replace=False).reshape(4, k)
        tris[idx[0]] = tris[idx[0], :1]                       # zero area: one point thrice
        tris[idx[1], 1] = tris[idx[1], 0]                     # duplicated vertex
        tris[idx[2], 2] = tris[idx[2], 0] + 0.37 * (tris[idx[2], 1] - tris[idx[2], 0])  # collinear
        tris[idx[3]] = tris[idx[3] - 1]                       # exact duplicates of a neighbour
    return tris.astype(np.float32)


def random_rays(n: int, seed: int):
    """Rays from around (and some inside) the unit cube, mostly towards points inside it."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-0.6, 1.6, (n, 3))
    o[: n // 4] = rng.random((n // 4, 3))            # a quarter start inside the soup
    d = rng.random((n, 3)) - o
    d[-n // 4:] = rng.standard_normal((n // 4, 3))   # and a quarter in any direction: misses
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o.astype(np.float32).astype(np.float64), d.astype(np.float32).astype(np.float64)


def trimesh_closest(tris: np.ndarray, o: np.ndarray, d: np.ndarray):
    """(t, tri) of the closest hit per ray from trimesh (inf, -1 for a miss)."""
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("rtree")
    from trimesh.ray.ray_triangle import RayMeshIntersector

    mesh = trimesh.Trimesh(vertices=tris.reshape(-1, 3).astype(np.float64),
                           faces=np.arange(3 * len(tris)).reshape(-1, 3), process=False)
    tri, ray, loc = RayMeshIntersector(mesh).intersects_id(o, d, multiple_hits=False,
                                                           return_locations=True)
    t = np.full(len(o), np.inf)
    out_tri = np.full(len(o), -1, np.int64)
    t[ray] = np.einsum("ij,ij->i", loc - o[ray], d[ray])
    out_tri[ray] = tri
    return t, out_tri


def disagreements(t_a, t_b, rtol=1e-4):
    hit_a, hit_b = np.isfinite(t_a), np.isfinite(t_b)
    bad = hit_a != hit_b
    both = hit_a & hit_b
    bad[both] |= ~np.isclose(t_a[both], t_b[both], rtol=rtol, atol=1e-6)
    return bad


# --- build ---------------------------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 2, 3, 5, 17, 1000, 20000])
def test_structure_random_soup(n):
    tris = soup(n, seed=n, degenerate=n >= 17)
    b = build_bvh(tris)
    check_invariants(b, tris[b.order])
    assert b.count.max() <= MAX_LEAF
    assert b.nodes[0, 0:3].tolist() == tris.reshape(-1, 3).min(axis=0).tolist()
    assert b.nodes[0, 4:7].tolist() == tris.reshape(-1, 3).max(axis=0).tolist()


def test_empty_input():
    b = build_bvh(np.zeros((0, 3, 3), np.float32))
    assert b.nodes.shape == (1, 8) and b.order.shape == (0,) and b.depth == 1
    assert (b.nodes[0, 0:3] == 1).all() and (b.nodes[0, 4:7] == -1).all()
    check_invariants(b, np.zeros((0, 3, 3), np.float32))
    t, tri = intersect_numpy(b, np.zeros((0, 3, 3)), np.zeros((2, 3)), np.ones((2, 3)))
    assert np.isinf(t).all() and (tri == -1).all()


@pytest.mark.parametrize("kind", ["identical", "point", "line", "plane"])
def test_degenerate_inputs(kind):
    rng = np.random.default_rng(1)
    n = 3000
    if kind == "identical":      # no plane separates equal centroids: cut by count
        tris = np.repeat(rng.random((1, 3, 3)), n, axis=0)
    elif kind == "point":        # every triangle is the same point
        tris = np.full((n, 3, 3), 0.25)
    elif kind == "line":         # all on one line: zero-area boxes
        tris = np.zeros((n, 3, 3))
        tris[..., 0] = rng.random((n, 3))
    else:                        # a flat scene
        tris = rng.random((n, 3, 3))
        tris[..., 2] = 0.5
    tris = tris.astype(np.float32)
    b = build_bvh(tris)
    check_invariants(b, tris[b.order])
    assert b.count.max() <= MAX_LEAF


def test_nan_vertices_do_not_hang():
    tris = soup(500, seed=3)
    tris[::7, 1, 0] = np.nan
    tris[::11, 2] = np.inf
    b = build_bvh(tris)
    assert b.depth <= MAX_DEPTH
    check_invariants(b, tris[b.order])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bounds_of_is_numpys_axis_0_min_and_max(dtype):
    """bvh.bounds_of reduces each column on its own (numpy's axis-0 reduction of an (N, 3)
    array is 13x slower): the same values and dtype, a NaN included."""
    rng = np.random.default_rng(5)
    pts = (rng.standard_normal((1001, 3)) * 1e3).astype(dtype)
    lo, hi = bvh_mod.bounds_of(pts)
    assert lo.dtype == dtype and hi.dtype == dtype
    np.testing.assert_array_equal(lo, pts.min(axis=0))
    np.testing.assert_array_equal(hi, pts.max(axis=0))
    pts[17, 1] = np.nan
    lo, hi = bvh_mod.bounds_of(pts)
    np.testing.assert_array_equal(lo, pts.min(axis=0))   # NaN in column 1 only, as numpy's
    np.testing.assert_array_equal(hi, pts.max(axis=0))


def test_depth_limit_forces_leaves():
    tris = soup(2000, seed=4, degenerate=False)
    b = build_bvh(tris, max_depth=5)
    check_invariants(b, tris[b.order])
    assert b.depth == 5 and b.count.max() > MAX_LEAF   # deep nodes became big leaves
    # ...and the forced leaves still give the right answers
    o, d = random_rays(300, seed=5)
    full = build_bvh(tris)
    t_a, _ = intersect_numpy(b, tris[b.order], o, d)
    t_b, _ = intersect_numpy(full, tris[full.order], o, d)
    assert not disagreements(t_a, t_b, rtol=1e-9).any()


def test_layout_is_bit_exact_uint():
    tris = soup(100, seed=6)
    b = build_bvh(tris)
    assert b.nodes.dtype == np.float32 and b.nodes.shape[1] == 8 and b.order.dtype == np.uint32
    u = b.nodes.view(np.uint32)
    interior = u[:, 7] == 0
    assert (u[interior, 3] < len(b.nodes) - 1).all()
    assert (u[~interior, 3] + u[~interior, 7]).max() == 100
    # bit patterns, not float conversions: small ints as floats would be denormals
    assert (b.nodes[~interior, 7] < 1e-30).all()


def test_sah_beats_median_on_clustered_scene():
    """Two far-apart clusters: the root must separate them (a sanity check that SAH, not a
    count split, picks the planes)."""
    a = soup(500, seed=7, size=0.01, degenerate=False) * 0.1
    b_ = a + np.float32(100.0)
    tris = np.concatenate([a, b_[:50]])
    b = build_bvh(tris)
    first = int(b.first[0])
    sizes = b.nodes[[first, first + 1], 4:7] - b.nodes[[first, first + 1], 0:3]
    assert (sizes.max(axis=1) < 50).all()


def test_split_planes_on_every_axis_separate_the_layers():
    """Two thin layers of triangles strewn along x (40 long), 5 apart in y: the longest
    centroid axis is x until the nodes are shorter than 5, and every x plane leaves both
    halves spanning both layers; binning on every axis splits the layers at the root. The tree
    is valid and gives trimesh's closest hits."""
    rng = np.random.default_rng(21)
    n = 2000
    base = np.stack([rng.random(n) * 40, np.where(rng.random(n) < 0.5, 0.0, 5.0), rng.random(n)], axis=1)
    tris = (base[:, None, :] + rng.normal(0, 0.03, (n, 3, 3))).astype(np.float32)
    every = build_bvh(tris)
    check_invariants(every, tris[every.order])
    first = int(every.first[0])
    heights = every.nodes[[first, first + 1], 5] - every.nodes[[first, first + 1], 1]
    assert (heights < 1.0).all()                       # the root splits the layers apart
    # rays at 500 triangles' centroids from 2 below or above, a little aslant
    aim = tris[rng.choice(n, 500, replace=False)].mean(axis=1).astype(np.float64)
    o = aim + np.stack([rng.normal(0, 0.2, 500), np.where(rng.random(500) < 0.5, -2.0, 2.0), rng.normal(0, 0.2, 500)], 1)
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    t_ref, _ = trimesh_closest(tris, o, d)
    t, _ = intersect_numpy(every, tris[every.order], o, d)
    assert np.isfinite(t).mean() > 0.9 and disagreements(t, t_ref).mean() < MISMATCH_BOUND


def test_larger_leaves_and_dearer_splits_make_fewer_fuller_leaves():
    """build_bvh's max_leaf and traversal_cost (a split's cost relative to one triangle test):
    fewer, fuller leaves, each within its bound."""
    tris = soup(2000, seed=29)
    big = build_bvh(tris, max_leaf=8, traversal_cost=3.0)
    check_invariants(big, tris[big.order])
    small = build_bvh(tris)
    leaves_big, leaves_small = big.count[big.count > 0], small.count[small.count > 0]
    assert leaves_big.max() <= 8 and leaves_small.max() <= MAX_LEAF < leaves_big.max()
    assert leaves_big.size < leaves_small.size


def test_finer_bins_at_the_top(monkeypatch):
    """bins auto (the default) keeps whichever of the 32-bin tree and the tree with
    LARGE_BINS bins for its nodes of LARGE_NODE triangles or more has the lower SAH cost; both
    keep the layout rules and trimesh's closest hits; a number gives that many bins everywhere,
    and the cache keeps the settings apart."""
    from lift_gl.accel.bvh import LARGE_BINS, LARGE_NODE, sah_cost

    # rows of small triangles whose gaps fall between 32 bins' planes (desks in a classroom)
    rng = np.random.default_rng(31)
    rows = np.repeat(np.arange(37) / 37.0 + 0.003, 80)
    base = np.stack([rows + 0.015 * rng.random(rows.size), rng.random(rows.size), rng.random(rows.size)], axis=1)
    tris = (base[:, None, :] + 0.004 * rng.standard_normal((rows.size, 3, 3))).astype(np.float32)
    assert len(tris) >= 2 * LARGE_NODE
    coarse = build_bvh(tris)
    fine = build_bvh(tris, large_bins=LARGE_BINS)
    assert not np.array_equal(coarse.nodes.view(np.uint32), fine.nodes.view(np.uint32))
    best = min((coarse, fine), key=sah_cost)
    assert sah_cost(fine) < sah_cost(coarse)          # what this scene is built to show
    o, d = random_rays(3000, seed=7)
    t_ref, _ = trimesh_closest(tris, o, d)
    for tree in (coarse, fine):
        check_invariants(tree, tris[tree.order])
        t, _ = intersect_numpy(tree, tris[tree.order], o, d)
        assert disagreements(t, t_ref).mean() < MISMATCH_BOUND
    assert cache_mod.resolve_bins() == "auto"
    built = cache_mod.build_with(tris, "sah")
    assert np.array_equal(built.nodes.view(np.uint32), best.nodes.view(np.uint32))
    # from the size where the LBVH takes over (1M) the SAH build is made once
    monkeypatch.setattr(cache_mod, "AUTO_LBVH_TRIANGLES", len(tris))
    assert np.array_equal(cache_mod.build_with(tris, "sah").nodes.view(np.uint32), coarse.nodes.view(np.uint32))
    monkeypatch.undo()
    auto_key = cache_mod.cache_key(tris)
    assert np.array_equal(cache_mod.build_with(tris, "sah", bins="32").nodes.view(np.uint32),
                          coarse.nodes.view(np.uint32))
    assert cache_mod.cache_key(tris, bins=32) != auto_key == cache_mod.cache_key(tris, bins="auto")
    # a tree whose finer build costs more keeps the coarse one
    monkeypatch.setattr(cache_mod, "sah_cost", lambda b: 0.0 if b.nodes.shape == coarse.nodes.shape and
                        np.array_equal(b.nodes.view(np.uint32), coarse.nodes.view(np.uint32)) else 1.0)
    assert np.array_equal(cache_mod.build_with(tris, "sah").nodes.view(np.uint32), coarse.nodes.view(np.uint32))
    for bad in ("7", "300", "many"):
        with pytest.raises(ValueError, match="bad BVH bins"):
            cache_mod.resolve_bins(bad)


# --- numpy traversal against trimesh ------------------------------------------------------

@pytest.fixture(scope="module")
def scene():
    tris = soup(4000, seed=11)
    b = build_bvh(tris)
    o, d = random_rays(N_RAYS, seed=12)
    t_ref, tri_ref = trimesh_closest(tris, o, d)
    return tris, b, o, d, t_ref, tri_ref


def test_numpy_traversal_matches_trimesh(scene):
    tris, b, o, d, t_ref, tri_ref = scene
    assert np.isfinite(t_ref).mean() > 0.5          # the test is about hits, mostly
    t, tri = intersect_numpy(b, tris[b.order], o, d)
    bad = disagreements(t, t_ref)
    assert bad.mean() < MISMATCH_BOUND, f"{bad.sum()} of {len(bad)} rays disagree"
    same_t = ~bad & np.isfinite(t)
    # same triangle, except where two triangles are hit at the same distance (duplicates)
    assert (b.order[tri[same_t]] == tri_ref[same_t]).mean() > 0.97


def test_numpy_traversal_tmin_tmax(scene):
    tris, b, o, d, t_ref, _ = scene
    hit = np.isfinite(t_ref)
    # nothing before the closest hit, and the hit itself just inside tmax
    t_short, _ = intersect_numpy(b, tris[b.order], o[hit], d[hit], tmax=0.999)
    t_all, _ = intersect_numpy(b, tris[b.order], o[hit], d[hit])
    assert ((t_short < 0.999) == (t_all < 0.999)).all()
    # with tmin > 0 the nearest hit beyond tmin is found: brute force over all triangles
    oh, dh = o[hit][:200], d[hit][:200]
    t_next, _ = intersect_numpy(b, tris[b.order], oh, dh, tmin=0.7)
    r = np.repeat(np.arange(len(oh)), len(tris))
    p = np.tile(tris.astype(np.float64), (len(oh), 1, 1))
    t_bf, _, _, ok = bvh_mod.moller_trumbore(p[:, 0], p[:, 1], p[:, 2], oh[r], dh[r])
    t_bf = np.where(ok & (t_bf > 0.7), t_bf, np.inf).reshape(len(oh), len(tris)).min(axis=1)
    assert (t_next[np.isfinite(t_next)] > 0.7).all()
    assert disagreements(t_next, t_bf).sum() <= 1


# --- GLSL ----------------------------------------------------------------------------------

TEST_SHADER = """
#include "lift/bvh.glsl"
layout(local_size_x = 64) in;
// two vec4 per ray: (origin, tmin), (dir, tmax)
layout(std430, binding = 10) readonly buffer Rays { vec4 rays[]; };
// two vec4 per ray: (t, prim bits, occluded, hit), (bary, 0, 0)
layout(std430, binding = 11) writeonly buffer Results { vec4 results[]; };
uniform uint u_num_rays;
uniform int u_mode;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_num_rays) return;
    vec4 a = rays[2u * i];
    vec4 b = rays[2u * i + 1u];
    Ray ray = Ray(a.xyz, b.xyz, a.w, b.w);
    Hit hit;
    bool found, occluded = false;
    if (u_mode == 0) {   // through the BVH
        found = trace_closest(ray, hit);
        occluded = trace_occluded(ray);
    } else if (u_mode == 2) {   // trace_shadow_and_next: ray i as the shadow ray, ray (7i + 3) % n as the next
        uint j = (7u * i + 3u) % u_num_rays;
        vec4 c = rays[2u * j], e = rays[2u * j + 1u];
        bool shadow_wanted = i % 3u != 1u, next_wanted = i % 3u != 2u;   // both, the next only, the shadow only
        occluded = trace_shadow_and_next(shadow_wanted, ray, next_wanted, Ray(c.xyz, e.xyz, c.w, e.w), hit);
        found = hit.prim != NO_HIT;
    } else {             // ray i against triangle i alone (the single-triangle entry point)
        hit.t = ray.tmax;
        hit.prim = NO_HIT;
        hit.bary = vec2(0.0);
        found = intersect_triangle(ray, i, hit.t, hit.bary);
        if (found) hit.prim = i;
    }
    results[2u * i] = vec4(hit.t, uintBitsToFloat(hit.prim), occluded ? 1.0 : 0.0, found ? 1.0 : 0.0);
    results[2u * i + 1u] = vec4(hit.bary, 0.0, 0.0);
}
"""


@pytest.fixture(scope="module")
def gl():
    from lift_gl.gl.context import create_context
    try:
        return create_context()
    except Exception as exc:  # no headless GL on this machine
        pytest.skip(f"no OpenGL context: {exc}")


def run_glsl(ctx, nodes, tris_reordered, o, d, tmin=0.0, tmax=np.inf, spheres=None, defines=None,
             single_triangles=False, paired=False):
    """Trace rays with lift/bvh.glsl; returns (t, prim, occluded, found, bary). `defines`: more
    (the 4-wide tree's LIFT_BVH_WIDTH, a shared stack: tests/test_wide_bvh.py).
    `single_triangles`: ray i against triangle i alone, no BVH (tests/test_watertight.py).
    `paired`: trace_shadow_and_next with ray i as the shadow ray and ray (7i + 3) % n as the
    next one, both wanted where i % 3 == 0, the next only at 1, the shadow only at 2."""
    from lift_gl.shaders import assemble, compile_compute

    defines = dict({"HAS_SPHERES": True} if spheres is not None else {}, **(defines or {}))
    prog = compile_compute(ctx, assemble(TEST_SHADER, defines=defines, main_name="test_bvh.comp"))
    n = len(o)
    rays = np.zeros((n, 2, 4), np.float32)
    rays[:, 0, :3], rays[:, 0, 3] = o, tmin
    rays[:, 1, :3], rays[:, 1, 3] = d, tmax
    tri_buf = np.zeros((max(len(tris_reordered), 1), 3, 4), np.float32)
    tri_buf[: len(tris_reordered), :, :3] = tris_reordered
    sph = np.zeros((max(len(spheres) if spheres is not None else 0, 1), 2, 4), np.float32)
    if spheres is not None and len(spheres):
        sph[: len(spheres), 0] = spheres
    dummy = np.zeros(16, np.float32)
    data = {0: nodes, 1: tri_buf, 7: sph, 10: rays}
    buffers = []
    for binding in list(range(9)) + [10]:
        buf = ctx.buffer(np.ascontiguousarray(data.get(binding, dummy)).tobytes())
        buf.bind_to_storage_buffer(binding)
        buffers.append(buf)
    out = ctx.buffer(reserve=n * 32)
    out.bind_to_storage_buffer(11)
    buffers.append(out)
    values = {"u_num_triangles": len(tris_reordered), "u_num_spheres": 0 if spheres is None else len(spheres),
              "u_num_rays": n, "u_mode": 1 if single_triangles else 2 if paired else 0}
    for name, value in values.items():
        if prog.get(name, None) is not None:
            prog[name].value = value
    prog.run(group_x=(n + 63) // 64)
    res = np.frombuffer(out.read(), np.float32).reshape(n, 2, 4).copy()
    for buf in buffers:
        buf.release()
    prog.release()
    prim = res[:, 0, 1].view(np.uint32)
    return res[:, 0, 0], prim, res[:, 0, 2] > 0.5, res[:, 0, 3] > 0.5, res[:, 1, :2]


NO_HIT = 0xFFFFFFFF


def test_glsl_closest_matches_trimesh(gl, scene):
    tris, b, o, d, t_ref, tri_ref = scene
    t, prim, occluded, found, bary = run_glsl(gl, b.nodes, tris[b.order], o, d)
    assert (found == (prim != NO_HIT)).all()
    t = np.where(found, t, np.inf).astype(np.float64)
    bad = disagreements(t, t_ref)
    assert bad.mean() < MISMATCH_BOUND, f"{bad.sum()} of {len(bad)} rays disagree"
    # trace_occluded with an unbounded interval: occluded exactly when something was hit
    assert (occluded == found).mean() > 1 - MISMATCH_BOUND
    # barycentrics rebuild the hit point
    h = np.flatnonzero(found)
    p = tris[b.order][prim[h]].astype(np.float64)
    b1, b2 = bary[h, 0:1], bary[h, 1:2]
    q = (1 - b1 - b2) * p[:, 0] + b1 * p[:, 1] + b2 * p[:, 2]
    np.testing.assert_allclose(q, o[h] + t[h, None] * d[h], atol=1e-4)
    assert (bary[h] >= 0).all() and (bary[h].sum(axis=1) <= 1 + 1e-6).all()


def test_glsl_occluded_respects_interval(gl, scene):
    tris, b, o, d, t_ref, _ = scene
    hit = np.isfinite(t_ref)
    oh, dh, th = o[hit], d[hit], t_ref[hit]
    _, _, occ_short, found_short, _ = run_glsl(gl, b.nodes, tris[b.order], oh, dh, tmax=th * 0.999)
    _, _, occ_long, _, _ = run_glsl(gl, b.nodes, tris[b.order], oh, dh, tmax=th * 1.001)
    assert (~occ_short).mean() > 1 - MISMATCH_BOUND
    assert (occ_short == found_short).all()          # both queries agree on the same interval
    assert occ_long.mean() > 1 - MISMATCH_BOUND
    # tmin beyond the whole scene: nothing
    _, prim, occ, _, _ = run_glsl(gl, b.nodes, tris[b.order], oh, dh, tmin=10.0)
    assert (prim == NO_HIT).all() and not occ.any()


def test_glsl_empty_scene(gl):
    b = build_bvh(np.zeros((0, 3, 3), np.float32))
    o, d = random_rays(100, seed=13)
    _, prim, occ, found, _ = run_glsl(gl, b.nodes, np.zeros((0, 3, 3), np.float32), o, d)
    assert (prim == NO_HIT).all() and not occ.any() and not found.any()


def sphere_reference(centers, radii, o, d, tmin=0.0):
    """Nearest root in (tmin, inf) per ray and sphere index, in float64."""
    oc = o[:, None, :] - centers[None]
    b = np.einsum("rsk,rk->rs", oc, d)
    c = np.einsum("rsk,rsk->rs", oc, oc) - radii[None] ** 2
    disc = b * b - c
    sq = np.sqrt(np.maximum(disc, 0))
    t0, t1 = -b - sq, -b + sq
    t = np.where(t0 > tmin, t0, np.where(t1 > tmin, t1, np.inf))
    t[disc < 0] = np.inf
    s = np.argmin(t, axis=1)
    return t[np.arange(len(o)), s], s


def test_glsl_spheres_analytic(gl):
    rng = np.random.default_rng(14)
    spheres = np.array([[0, 0, 0, 1.0], [3, 0, 0, 0.5], [0, 3, 1, 0.25], [0.5, 0.2, 0.1, 0.3]], np.float32)
    n = 2000
    o = rng.uniform(-4, 5, (n, 3))
    o[:100] = rng.uniform(-0.4, 0.4, (100, 3))     # inside sphere 0 (and maybe 3): far roots
    target = spheres[rng.integers(0, 4, n), :3] + rng.uniform(-0.8, 0.8, (n, 3))
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o, d = o.astype(np.float32).astype(np.float64), d.astype(np.float32).astype(np.float64)
    t_ref, s_ref = sphere_reference(spheres[:, :3].astype(np.float64), spheres[:, 3].astype(np.float64), o, d)
    assert 0.3 < np.isfinite(t_ref).mean() < 0.95

    empty = build_bvh(np.zeros((0, 3, 3), np.float32))
    t, prim, occ, found, _ = run_glsl(gl, empty.nodes, np.zeros((0, 3, 3), np.float32), o, d, spheres=spheres)
    hit = np.isfinite(t_ref)
    # grazing rays (discriminant ~ 0) may flip between hit and miss in float32
    assert (found == hit).mean() > 0.998
    both = found & hit
    np.testing.assert_allclose(t[both], t_ref[both], rtol=1e-3, atol=1e-4)
    assert (prim[both] == s_ref[both]).mean() > 0.998
    assert (occ == found).all()

    # spheres and triangles together: the nearer wins; sphere ids come after the triangles
    tris = soup(300, seed=15, size=0.3, degenerate=False) * 3 - 1
    b = build_bvh(tris)
    t, prim, occ, found, _ = run_glsl(gl, b.nodes, tris[b.order], o, d, spheres=spheres)
    t_tri, tri = intersect_numpy(b, tris[b.order], o, d)
    expect_t = np.minimum(t_tri, t_ref)
    expect_prim = np.where(t_ref < t_tri, len(tris) + s_ref, np.where(np.isfinite(t_tri), tri, NO_HIT))
    ok = found == np.isfinite(expect_t)
    assert ok.mean() > 0.995
    both = found & np.isfinite(expect_t)
    assert np.isclose(t[both], expect_t[both], rtol=1e-3, atol=1e-4).mean() > 0.995
    assert (prim[both] == expect_prim[both]).mean() > 0.99
    assert (occ == found).all()


# --- cache ---------------------------------------------------------------------------------

def test_cache_roundtrip_and_corruption(tmp_path, monkeypatch):
    tris = soup(500, seed=16)
    first = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1

    def no_build(*a, **k):
        raise AssertionError("should have been loaded from the cache")

    monkeypatch.setattr(cache_mod, "build_bvh", no_build)
    second = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)
    assert np.array_equal(first.nodes.view(np.uint32), second.nodes.view(np.uint32))
    assert np.array_equal(first.order, second.order) and first.depth == second.depth
    monkeypatch.undo()

    calls = []

    def counting_build(p, **options):
        calls.append(1)
        return build_bvh(p, **options)

    monkeypatch.setattr(cache_mod, "build_bvh", counting_build)
    for garbage in (b"not a zip file", files[0].read_bytes()[:100], b""):
        files[0].write_bytes(garbage)
        third = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)
        assert np.array_equal(first.nodes.view(np.uint32), third.nodes.view(np.uint32))
    assert len(calls) == 3
    # the rebuilt file is good again
    cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)
    assert len(calls) == 3
    # different geometry, different entry
    tris2 = tris.copy()
    tris2[0, 0, 0] += 1
    cache_mod.build_bvh_cached(tris2, cache_dir=tmp_path)
    assert len(calls) == 4 and len(list(tmp_path.glob("*.npz"))) == 2
    assert not list(tmp_path.glob("*.tmp"))


def test_a_build_is_announced_on_a_terminal_only(tmp_path, monkeypatch, capsys):
    """A cache miss of a large scene says on a terminal that the BVH is being built and where
    it is cached; a cache hit, a small scene or output that is not a terminal say nothing."""
    import sys

    tris = soup(300, seed=19)
    monkeypatch.setattr(cache_mod, "BUILD_NOTICE_TRIANGLES", 200)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)
    err = capsys.readouterr().err
    assert "building the BVH of 300 triangles" in err and str(tmp_path) in err and "BVH built in" in err
    cache_mod.build_bvh_cached(tris, cache_dir=tmp_path)                      # read from the cache
    assert capsys.readouterr().err == ""
    cache_mod.build_bvh_cached(soup(100, seed=19), cache_dir=tmp_path)       # small
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    cache_mod.build_bvh_cached(soup(300, seed=20), cache_dir=tmp_path)       # not a terminal
    assert capsys.readouterr().err == ""


def test_cache_default_dir_env(tmp_path, monkeypatch):
    monkeypatch.setenv("LIFT_GL_CACHE_DIR", str(tmp_path))
    assert cache_mod.default_cache_dir() == tmp_path / "bvh"
    b = cache_mod.build_bvh_cached(soup(50, seed=17))
    assert len(list((tmp_path / "bvh").glob("*.npz"))) == 1
    empty = cache_mod.build_bvh_cached(np.zeros((0, 3, 3), np.float32))
    assert empty.nodes.shape == (1, 8) and b.nodes.shape[0] > 1


def test_cache_keeps_to_its_size_by_dropping_the_least_recently_used(tmp_path, monkeypatch):
    """Past `max_bytes` the oldest-used files go after a write, never the one just written; a
    file read from the cache counts as used."""
    import os

    trees = [soup(300, seed=30 + k) for k in range(3)]
    cache_mod.build_bvh_cached(trees[0], cache_dir=tmp_path)
    [one] = tmp_path.glob("*.npz")
    limit = int(2.5 * one.stat().st_size)
    cache_mod.build_bvh_cached(trees[1], cache_dir=tmp_path, max_bytes=limit)
    files = {f.name: f for f in tmp_path.glob("*.npz")}
    assert len(files) == 2
    for k, f in enumerate(sorted(files.values(), key=lambda f: f.name != one.name)):   # trees[0]'s oldest
        os.utime(f, (1000.0 + k, 1000.0 + k))
    cache_mod.build_bvh_cached(trees[0], cache_dir=tmp_path, max_bytes=limit)   # read: now the most recently used
    cache_mod.build_bvh_cached(trees[2], cache_dir=tmp_path, max_bytes=limit)   # a third file: over the limit
    left = {f.name for f in tmp_path.glob("*.npz")}
    assert len(left) == 2 and one.name in left and not (set(files) - {one.name}) & left
    cache_mod.build_bvh_cached(trees[1], cache_dir=tmp_path, max_bytes=0)   # nothing but the file just written
    assert len(list(tmp_path.glob("*.npz"))) == 1
    cache_mod.build_bvh_cached(trees[2], cache_dir=tmp_path)      # the default, 4 GiB: nothing goes
    assert len(list(tmp_path.glob("*.npz"))) == 2
