"""The BVH records the GLSL traversal reads (lift_gl/accel/gpu_layout.py): the same tree as the
builder's, children's boxes in the parent, depth-first numbering; and traversal through them
on the GPU against trimesh for the small trees that take the special cases."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.accel.bvh import build_bvh, intersect_numpy
from lift_gl.accel.gpu_layout import RECORD_FLOATS, gpu_close_boxes, gpu_nodes
from test_bvh import NO_HIT, disagreements, gl, random_rays, run_glsl, soup, trimesh_closest  # noqa: F401


def walk_records(rec: np.ndarray):
    """Depth-first walk of the records from record 0: (record, parent record) in visiting
    order, and every leaf reached as (first, count)."""
    u = rec.view(np.uint32)
    order, leaves, stack = [], [], [(0, -1)]
    while stack:
        r, parent = stack.pop()
        order.append((r, parent))
        for c in (8, 0):   # push B first: A is visited next
            ref, count = int(u[r, c + 3]), int(u[r, c + 7])
            if count:
                leaves.append((ref, count))
            else:
                stack.append((ref, r))
    return order, leaves


@pytest.mark.parametrize("n", [3, 5, 17, 1000, 20000])
def test_records_hold_the_same_tree(n):
    tris = soup(n, seed=n, degenerate=n >= 20)
    b = build_bvh(tris)
    rec = gpu_nodes(b.nodes)
    assert rec.dtype == np.float32 and rec.shape == (int((b.count == 0).sum()), RECORD_FLOATS)
    order, leaves = walk_records(rec)
    # every record reached once, numbered depth first: a walk visits them as 0, 1, 2, ...
    assert [r for r, _ in order] == list(range(len(rec)))
    # the leaves are the builder's leaves, each once
    expect = sorted(zip(b.first[b.count > 0].tolist(), b.count[b.count > 0].tolist()))
    assert sorted(leaves) == expect
    # the boxes of a record's children are those the builder gave them, so they lie inside
    # the box the parent record gives the child (and the root's children inside the root)
    lo = np.concatenate([rec[:, 0:3], rec[:, 8:11]])
    hi = np.concatenate([rec[:, 4:7], rec[:, 12:15]])
    assert (lo >= b.nodes[0, 0:3]).all() and (hi <= b.nodes[0, 4:7]).all()
    u = rec.view(np.uint32)
    for c in (0, 8):
        inner = np.flatnonzero(u[:, c + 7] == 0)
        child = u[inner, c + 3]
        assert (rec[child, 0:3] >= rec[inner, c:c + 3]).all() and (rec[child, 8:11] >= rec[inner, c:c + 3]).all()
        assert (rec[child, 4:7] <= rec[inner, c + 4:c + 7]).all() and (rec[child, 12:15] <= rec[inner, c + 4:c + 7]).all()


def test_close_boxes_follow_the_records():
    """Motion blur: boxes at shutter close, laid out as the records' box columns."""
    tris = soup(500, seed=3, degenerate=False)
    b = build_bvh(tris)
    shift = np.array([0.5, -2.0, 0.25], np.float32)
    close = np.zeros((b.num_nodes, 2, 4), np.float32)
    close[:, 0, :3] = b.bmin + shift
    close[:, 1, :3] = b.bmax + shift
    rows = gpu_close_boxes(b.nodes, close.reshape(-1, 4)).reshape(-1, 4, 4)
    rec = gpu_nodes(b.nodes)
    for k, c in enumerate((0, 4, 8, 12)):
        np.testing.assert_allclose(rows[:, k, :3], rec[:, c:c + 3] + shift, atol=1e-6)


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_tiny_trees_trace_on_the_gpu(gl, n):
    """A tree that is one leaf (1 or 2 triangles) or empty has no interior node: its record
    holds the leaf twice, or boxes no ray reaches."""
    rng = np.random.default_rng(n)
    tris = (rng.random((n, 1, 3)) * 0.6 + 0.2 + 0.3 * rng.standard_normal((n, 3, 3))).astype(np.float32)
    b = build_bvh(tris)
    assert gpu_nodes(b.nodes).shape == (max(int((b.count == 0).sum()) if n else 1, 1), RECORD_FLOATS)
    o, d = random_rays(2000, seed=20 + n)
    t, prim, occluded, found, _ = run_glsl(gl, b.nodes, tris[b.order], o, d)
    if n == 0:
        assert not found.any() and not occluded.any()
        return
    t_ref, _ = intersect_numpy(b, tris[b.order], o, d)
    assert np.isfinite(t_ref).any()
    t = np.where(found, t, np.inf).astype(np.float64)
    assert disagreements(t, t_ref).mean() < 0.005
    assert (occluded == found).all()


def heightfield(n: int, seed: int) -> np.ndarray:
    """A surface patch without holes: an n x n grid of jittered, float32 points at random
    heights, two triangles per cell (the diagonal alternating), so every interior edge is
    shared. Jitter and heights are small enough that the cells stay convex and the surface
    is a graph over any direction within a few degrees of -z."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij"), -1).astype(np.float64)
    g += rng.uniform(-0.15, 0.15, g.shape) * ((g > 0) & (g < n))  # interior points jittered
    z = rng.uniform(0.0, 0.3 / n, g.shape[:2])
    p = np.concatenate([g / n, z[..., None]], -1).astype(np.float32)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = p[i, j], p[i + 1, j], p[i + 1, j + 1], p[i, j + 1]
            tris += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return np.array(tris, np.float32), p


def test_watertight_rays_through_vertices_and_edges_hit(gl):
    """Rays aimed exactly at the surface's interior vertices, and at points of its shared
    edges, from above: every one must hit (a non-watertight test lets some slip between the
    triangles that share the edge or vertex)."""
    tris, p = heightfield(24, seed=5)
    b = build_bvh(tris)
    rng = np.random.default_rng(6)
    verts = p[1:-1, 1:-1].reshape(-1, 3).astype(np.float64)
    e0, e1 = tris[:, 0].astype(np.float64), tris[:, 1].astype(np.float64)
    inner = (np.minimum(e0[:, :2], e1[:, :2]).min(axis=1) > 0) & (np.maximum(e0[:, :2], e1[:, :2]).max(axis=1) < 1)
    s = rng.random((int(inner.sum()), 1))
    on_edges = (e0[inner] + s * (e1[inner] - e0[inner])).astype(np.float32).astype(np.float64)
    targets = np.concatenate([np.repeat(verts, 8, axis=0), np.repeat(on_edges, 4, axis=0)])
    origins = targets + np.concatenate([rng.uniform(-0.05, 0.05, (len(targets), 2)),
                                        rng.uniform(1.0, 2.0, (len(targets), 1))], axis=1)
    origins = origins.astype(np.float32).astype(np.float64)
    d = targets - origins
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d.astype(np.float32).astype(np.float64)
    _, prim, occluded, found, _ = run_glsl(gl, b.nodes, tris[b.order], origins, d)
    assert found.all(), f"{(~found).sum()} of {len(found)} rays slipped through the surface"
    assert occluded.all()
