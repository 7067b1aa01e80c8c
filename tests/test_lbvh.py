"""The OpenCL LBVH builder (lift_gl/accel/lbvh.py): the same invariants as the SAH build,
closest hits equal to a brute-force test of every triangle, the depth limit, and builder
selection in the cache."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.accel import cache as cache_mod
from lift_gl.accel.bvh import MAX_LEAF, build_bvh, check_invariants, intersect_numpy, moller_trumbore

from lift_gl.testing import require_opencl
from test_bvh import random_rays, soup

require_opencl(module=True)
from lift_gl.accel.lbvh import build_lbvh  # noqa: E402


def _device_or_skip():
    from lift_gl.opencl import OpenCLError, device

    try:
        device()
    except OpenCLError as exc:
        pytest.skip(f"no OpenCL device: {exc}")


@pytest.fixture(autouse=True)
def opencl_device():
    _device_or_skip()


def brute_force(tris: np.ndarray, o: np.ndarray, d: np.ndarray):
    """Closest hit of every ray against every triangle: (t, tri), inf / -1 for a miss."""
    t_best = np.full(len(o), np.inf)
    tri_best = np.full(len(o), -1, np.int64)
    p = tris.astype(np.float64)
    for i in range(len(p)):   # one triangle against all rays at a time
        t, _, _, ok = moller_trumbore(np.broadcast_to(p[i, 0], o.shape), np.broadcast_to(p[i, 1], o.shape),
                                      np.broadcast_to(p[i, 2], o.shape), o, d)
        better = ok & (t > 0) & (t < t_best)
        t_best[better] = t[better]
        tri_best[better] = i
    return t_best, tri_best


@pytest.mark.parametrize("n", [1, 2, 3, 5, 17, 1000, 20000])
def test_invariants(n):
    tris = soup(n, seed=n, degenerate=n >= 17)
    b = build_lbvh(tris)
    check_invariants(b, tris[b.order])
    assert b.count.max() <= MAX_LEAF
    assert b.nodes[0, 0:3].tolist() == tris.reshape(-1, 3).min(axis=0).tolist()
    assert b.nodes[0, 4:7].tolist() == tris.reshape(-1, 3).max(axis=0).tolist()


def test_closest_hits_equal_brute_force():
    """Every ray's closest hit through the LBVH is the one a test of all triangles finds: the
    same distance and, where no other triangle is as near, the same triangle."""
    tris = soup(1500, seed=7)
    o, d = random_rays(800, seed=8)
    b = build_lbvh(tris)
    t, tri = intersect_numpy(b, tris[b.order], o, d)
    t_ref, tri_ref = brute_force(tris, o, d)
    hit = np.isfinite(t_ref)
    assert hit.sum() > 200 and (~hit).sum() > 50   # both cases are exercised
    np.testing.assert_array_equal(np.isfinite(t), hit)
    np.testing.assert_allclose(t[hit], t_ref[hit], rtol=1e-12)
    # the triangle (as an input index) may differ only where two triangles tie
    got = b.order.astype(np.int64)[tri[hit]]
    differ = got != tri_ref[hit]
    assert differ.sum() <= 3


def test_depth_limit_rebuilds_deep_subtrees():
    """A tree deeper than max_depth has its deep parts rebuilt: still a valid tree, the same
    hits, and within the limit."""
    tris = soup(20000, seed=3)
    free = build_lbvh(tris)
    assert free.depth > 12
    b = build_lbvh(tris, max_depth=12)
    check_invariants(b, tris[b.order])   # includes depth <= MAX_DEPTH
    assert b.depth <= 12
    o, d = random_rays(1000, seed=4)
    t, _ = intersect_numpy(b, tris[b.order], o, d)
    t_free, _ = intersect_numpy(free, tris[free.order], o, d)
    np.testing.assert_array_equal(t, t_free)


def test_points_in_one_morton_cell():
    """Thousands of triangles in one cell: the keys differ only by index, and the tree still
    splits them (it cannot use the Morton bits)."""
    rng = np.random.default_rng(0)
    tris = (0.5 + 1e-6 * rng.random((3000, 3, 3))).astype(np.float32)
    tris[0] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]   # widens the scene box: all else is one cell
    b = build_lbvh(tris)
    check_invariants(b, tris[b.order])


def test_builder_selection_and_cache(tmp_path):
    tris = soup(500, seed=2)
    assert cache_mod.resolve_builder("lbvh", 10) == "lbvh"
    b = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path, builder="lbvh")
    np.testing.assert_array_equal(b.nodes, build_lbvh(tris).nodes)
    assert cache_mod.cache_path(tris, tmp_path, "lbvh").is_file()
    assert not cache_mod.cache_path(tris, tmp_path, "sah").exists()   # builders keep their own files
    again = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path, builder="lbvh")
    np.testing.assert_array_equal(again.nodes, b.nodes)
    with pytest.raises(ValueError, match="octree"):
        cache_mod.resolve_builder("octree", 10)
    assert cache_mod.resolve_builder(None, 10) == "sah"
    assert cache_mod.resolve_builder(None, cache_mod.AUTO_LBVH_TRIANGLES) == "lbvh"


def test_gl_traversal_of_an_lbvh_renders_what_the_sah_tree_renders(monkeypatch, tmp_path):
    """The shaders traverse an LBVH like any other tree: the same closest hits, so the same
    image, but for the rare ray that hits two triangles at the same distance (shared edges)."""
    trimesh = pytest.importorskip("trimesh")
    from lift_gl.renderer import Renderer
    from lift_gl.scene.model import Camera, Environment, Material, Mesh, Scene

    torus = trimesh.creation.torus(1.0, 0.35, major_sections=96, minor_sections=48)
    torus.apply_transform(trimesh.transformations.rotation_matrix(0.9, [1, 0.3, 0]))
    scene = Scene(camera=Camera(np.array([0.0, 1.5, 3.5]), np.zeros(3)),
                  materials=[Material("m", base_color=np.array([0.7, 0.6, 0.5]))],
                  meshes=[Mesh("torus", np.asarray(torus.vertices, np.float64), np.asarray(torus.faces, np.int32), 0)],
                  environment=Environment(radiance=np.array([1.0, 1.0, 1.0])), max_depth=4)
    from lift_gl.options import Options

    monkeypatch.setenv(cache_mod.ENV_VAR, str(tmp_path))
    images = {}
    for builder in ("sah", "lbvh"):
        r = Renderer(scene, size=(40, 32), integrator="pt", seed=5, options=Options(bvh_builder=builder))
        assert r.packed.bvh_builder == builder
        images[builder] = r.render(spp=4)
        r.release()
    assert images["sah"].max() > 0
    differ = (images["sah"] != images["lbvh"]).any(axis=2)
    assert differ.mean() <= 0.01, f"{differ.sum()} of {differ.size} pixels differ"


def test_moving_triangles_get_the_box_they_sweep():
    """Motion blur builds over (T, 6, 3): corners at shutter open and close. Every leaf box
    must hold both (check_invariants tests all K points)."""
    tris = soup(3000, seed=21, degenerate=False)
    moved = tris + np.random.default_rng(22).normal(0, 0.05, (3000, 1, 3)).astype(np.float32)
    swept = np.concatenate([tris, moved], axis=1)
    b = build_lbvh(swept)
    check_invariants(b, swept[b.order])
