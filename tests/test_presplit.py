"""Pre-split BVH references (accel/presplit.py): the split boxes cover their triangles, trees
over them keep the layout rules and give the closest hits trimesh gives, the SAH cost falls on
long thin triangles, `auto` leaves scenes without large triangles alone, the cache keys on the
settings, and a renderer draws the same image with and without splits (the light table, the
copies' light pdfs and the G-buffer's ids stay consistent)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl.accel import cache as cache_mod
from lift_gl.accel import presplit as ps
from lift_gl.accel.bvh import build_bvh, check_invariants, intersect_numpy, sah_cost
from test_bvh import MISMATCH_BOUND, disagreements, random_rays, soup, trimesh_closest
from lift_gl.testing import require_opencl


def _renderers_split_with(monkeypatch, splits) -> None:
    """Renderers made from here on pack their scene with these split settings (pack_scene's
    bvh_splits; the renderer's own choice is auto)."""
    import functools

    import lift_gl.renderer as renderer_mod
    import lift_gl.scene_update as scene_update_mod
    from lift_gl.scene.pack import pack_scene

    for module in (renderer_mod, scene_update_mod):   # a new renderer's packing, and an edit's
        monkeypatch.setattr(module, "pack_scene", functools.partial(pack_scene, bvh_splits=splits))

FORCED = ps.SplitSettings(budget=1.0, max_extent=np.inf, min_triangles=0, min_over_median=0.0, min_splits=0.0)


def slivers(n_small: int = 3000, n_long: int = 150, seed: int = 5, length: float | None = None) -> np.ndarray:
    """Small random triangles in the unit cube and long thin ones (beams, blades) between
    random points, or of `length` from random points."""
    rng = np.random.default_rng(seed)
    small = soup(n_small, seed=seed, size=0.004, degenerate=False)
    a = rng.random((n_long, 3))
    b = rng.random((n_long, 3))
    if length is not None:
        d = rng.standard_normal((n_long, 3))
        b = a + length * d / np.linalg.norm(d, axis=1, keepdims=True)
    side = 0.01 * rng.standard_normal((n_long, 3))
    long_ = np.stack([a, b, a + side + 0.1 * (b - a)], axis=1)
    return np.concatenate([small, long_.astype(np.float32)])


def test_split_boxes_cover_their_triangles():
    tris = slivers()
    ref_tri, lo, hi = ps.presplit(tris, FORCED)
    assert ref_tri.size > len(tris) * 1.5 and np.array_equal(np.unique(ref_tri), np.arange(len(tris)))
    assert (lo <= hi).all()
    # every reference inside its triangle's box, and every point of a triangle in one of its boxes
    np.testing.assert_array_equal(np.minimum(lo, tris[ref_tri].min(1)), tris[ref_tri].min(1))
    np.testing.assert_array_equal(np.maximum(hi, tris[ref_tri].max(1)), tris[ref_tri].max(1))
    rng = np.random.default_rng(1)
    split = np.flatnonzero(np.bincount(ref_tri) > 1)
    u = rng.random((len(split), 64, 2))
    u = np.where(u.sum(-1, keepdims=True) > 1, 1 - u, u)
    t = tris[split].astype(np.float64)
    pts = (t[:, None, 0] + u[..., :1] * (t[:, None, 1] - t[:, None, 0])
           + u[..., 1:] * (t[:, None, 2] - t[:, None, 0])).astype(np.float32)          # (S, 64, 3)
    pts = np.concatenate([pts, tris[split]], axis=1)                                   # and the corners
    covered = np.zeros(pts.shape[:2], bool)
    start = np.searchsorted(ref_tri, split)
    for k in range(np.bincount(ref_tri).max()):
        r = start + k
        ok = (r < ref_tri.size)
        ok[ok] &= ref_tri[r[ok]] == split[ok]
        rr = np.where(ok, r, 0)
        inside = ((pts >= lo[rr][:, None]) & (pts <= hi[rr][:, None])).all(-1)
        covered |= inside & ok[:, None]
    assert covered.all()
    # the long triangles' pieces are much tighter than their whole boxes
    long_ = np.arange(len(tris) - 150, len(tris))
    pieces = np.isin(ref_tri, long_)
    whole = ps._half_area(tris[long_].min(1).astype(np.float64), tris[long_].max(1).astype(np.float64)).sum()
    assert ps._half_area(lo[pieces].astype(np.float64), hi[pieces].astype(np.float64)).sum() < 0.3 * whole


@pytest.mark.parametrize("builder", ["sah", "lbvh"])
def test_split_tree_closest_hits_match_trimesh(builder):
    if builder == "lbvh":
        require_opencl()
    tris = slivers()
    b = cache_mod.build_with(tris, builder, FORCED)
    assert b.order.size > len(tris)                       # triangles are repeated
    check_invariants(b, tris[b.order])
    o, d = random_rays(4000, seed=3)
    t, row = intersect_numpy(b, tris[b.order], o, d)
    t_ref, tri_ref = trimesh_closest(tris, o, d)
    assert disagreements(t, t_ref).mean() < MISMATCH_BOUND
    same = np.isfinite(t) & np.isclose(t, t_ref, rtol=1e-6)
    assert (b.order[row[same]] == tri_ref[same]).mean() > 0.97
    # the tree without splits gives the same hits
    t_plain, _ = intersect_numpy(plain := build_bvh(tris), tris[plain.order], o, d)
    assert disagreements(t, t_plain, rtol=1e-6).mean() == 0
    assert sah_cost(b) < 0.8 * sah_cost(plain)


def test_auto_keeps_scenes_without_large_triangles_and_splits_slivers():
    small = soup(3000, seed=2, size=0.004, degenerate=False)   # nothing spans 1% of the cube
    b = cache_mod.build_with(small, "sah", ps.AUTO)
    assert b.order.size == len(small)
    # the plain SAH build (as build_with makes it)
    np.testing.assert_array_equal(b.nodes.view(np.uint32), cache_mod.build_with(small, "sah").nodes.view(np.uint32))
    tris = slivers(length=0.4)   # 15-25% of the scene's diagonal
    auto = cache_mod.build_with(tris, "sah", ps.AUTO)
    assert auto.order.size > len(tris)
    assert sah_cost(auto) <= (1 - ps.AUTO_MIN_GAIN) * sah_cost(cache_mod.build_with(tris, "sah"))
    # moving triangles (boxes swept over the shutter) are never split
    swept = np.concatenate([tris, tris + 0.01], axis=1)
    assert cache_mod.build_with(swept, "sah", ps.AUTO).order.size == len(tris)


def test_cache_keys_on_split_settings(tmp_path):
    tris = slivers(length=0.4)
    auto = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path, builder="sah", splits="auto")
    off = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path, builder="sah", splits="off")
    assert len(list(tmp_path.glob("*.npz"))) == 2 and off.order.size == len(tris) < auto.order.size
    again = cache_mod.build_bvh_cached(tris, cache_dir=tmp_path, builder="sah", splits="auto")
    np.testing.assert_array_equal(again.order, auto.order)
    np.testing.assert_array_equal(again.nodes.view(np.uint32), auto.nodes.view(np.uint32))
    assert cache_mod._load(cache_mod.cache_path(tris, tmp_path, "sah", ps.AUTO), len(tris)) is not None
    assert cache_mod._load(cache_mod.cache_path(tris, tmp_path, "sah", ps.AUTO), len(tris) + 1) is None


def test_resolve_splits():
    assert ps.resolve_splits(None) == ps.AUTO == ps.resolve_splits("auto")
    assert ps.resolve_splits("off") == ps.OFF
    assert ps.resolve_splits("0.5") == ps.SplitSettings(budget=0.5, max_extent=np.inf, min_triangles=0,
                                                        min_over_median=0.0, min_splits=0.0, sliver_budget=0.0)
    assert ps.resolve_splits("budget=1:sliver_ratio=16:min_triangles=10") == \
        ps.SplitSettings(budget=1.0, sliver_ratio=16.0, min_triangles=10)
    assert ps.resolve_splits("auto-no-slivers") == ps.AUTO_NO_SLIVERS and ps.AUTO_NO_SLIVERS.key() != ps.AUTO.key()
    assert ps.AUTO.slivers and not ps.AUTO_NO_SLIVERS.slivers
    for bad in ("lots", "budget=x", "budgte=1", "budget=-1", "auto=1", "budget=1:", "slivers=1"):
        with pytest.raises(ValueError, match="bad BVH split setting"):
            ps.resolve_splits(bad)


def test_auto_keeps_the_sliver_split_within_its_tolerance(monkeypatch):
    """auto's slivers-only candidate (docs/gpu.md "Twelfth session"): where no candidate lowers
    the SAH cost by AUTO_MIN_GAIN, it is kept if its cost is within SLIVER_TOLERANCE of the tree
    without splits, and not otherwise; auto-no-slivers never takes it, nor does auto from
    AUTO_LBVH_TRIANGLES. The SAH cost is replaced by one that grows with the extra references,
    so that every split costs."""
    tris = slivers(length=0.4)
    n = len(tris)

    def cost_of(per_extra):
        return lambda bvh: 10.0 * (1.0 + per_extra * (bvh.order.size - n) / n)

    sliver_refs = ps.presplit(tris.astype(np.float32), ps.SLIVER_CANDIDATE)[0].size
    assert sliver_refs > n   # the candidate splits these slivers
    per_ref = (sliver_refs - n) / n
    # a cost rise of half the tolerance: kept by auto only (not auto-no-slivers)
    monkeypatch.setattr(cache_mod, "sah_cost", cost_of(0.5 * ps.SLIVER_TOLERANCE / per_ref))
    assert cache_mod.build_with(tris, "sah", ps.AUTO_NO_SLIVERS).order.size == n
    kept = cache_mod.build_with(tris, "sah", ps.AUTO)
    assert kept.order.size == sliver_refs
    monkeypatch.setattr(cache_mod, "AUTO_LBVH_TRIANGLES", n)
    assert cache_mod.build_with(tris, "sah", ps.AUTO).order.size == n
    monkeypatch.setattr(cache_mod, "AUTO_LBVH_TRIANGLES", n + 1)
    # twice the tolerance: the tree without splits
    monkeypatch.setattr(cache_mod, "sah_cost", cost_of(2.0 * ps.SLIVER_TOLERANCE / per_ref))
    assert cache_mod.build_with(tris, "sah", ps.AUTO).order.size == n
    # the kept tree finds the hits of the tree without splits
    o, d = random_rays(2000, seed=3)
    t_split, _ = intersect_numpy(kept, tris[kept.order], o, d)
    t_plain, _ = intersect_numpy(plain := build_bvh(tris), tris[plain.order], o, d)
    assert disagreements(t_split, t_plain, rtol=1e-6).mean() == 0


def _sliver(start, direction, length: float, width: float, across) -> np.ndarray:
    """A long thin triangle from `start` along `direction`, `width` wide along `across`."""
    a = np.asarray(start, np.float64)
    d = np.asarray(direction, np.float64) / np.linalg.norm(direction)
    return np.stack([a, a + length * d, a + 0.5 * length * d + width * np.asarray(across, np.float64)])


def test_slivers_across_the_axes_get_splits_by_their_box_waste():
    """A sliver lying across the axes (its box far larger than itself) gets about half-area /
    area / sliver_ratio pieces, one along an axis (a tight, flat box) no more than its budget
    share; the extra references stay within sliver_budget x T."""
    small = soup(3000, seed=4, size=0.004, degenerate=False).astype(np.float64)
    slant = _sliver((0.2, 0.2, 0.2), (1, 1, 1), 0.43, 0.004, (1, -1, 0))
    flat = _sliver((0.2, 0.6, 0.6), (1, 0, 0), 0.43, 0.004, (0, 1, 0))
    line = _sliver((0.6, 0.2, 0.2), (1, 1, 1), 0.43, 0.0, (1, -1, 0))    # no area: never hit
    tris = np.concatenate([small, line[None], slant[None], flat[None]]).astype(np.float32)
    lo, hi = tris.min(1), tris.max(1)
    budget = 12 / len(tris)   # a share of a few splits each, below what the slanted sliver wants
    share = ps._split_counts(tris, lo, hi, ps.SplitSettings(budget=budget, min_splits=0.0, sliver_budget=0.0))
    counts = ps._split_counts(tris, lo, hi, ps.SplitSettings(budget=budget, min_splits=0.0))
    t = tris.astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    ratio = ps._half_area(lo.astype(np.float64), hi.astype(np.float64)) / area
    assert ratio[-2] > 10 * ps.SplitSettings().sliver_ratio and ratio[-1] < 4      # the case this tests
    want = min(np.ceil(ratio[-2] / ps.SplitSettings().sliver_ratio) - 1, ps.MAX_SPLITS_PER_TRIANGLE)
    assert 0 < share[-2] < want and counts[-2] == want
    assert 0 < counts[-1] == share[-1]
    np.testing.assert_array_equal(counts[:-2], share[:-2])          # the line too: no sliver splits
    # its pieces' boxes: about 1/pieces of the whole box's half-area each
    ref_tri, r_lo, r_hi = ps.presplit(tris, ps.SplitSettings(budget=budget, min_splits=0.0))
    pieces = ref_tri == len(tris) - 2
    assert pieces.sum() > 0.5 * (want + 1)
    whole = ps._half_area(lo[-2].astype(np.float64), hi[-2].astype(np.float64))
    assert ps._half_area(r_lo[pieces].astype(np.float64), r_hi[pieces].astype(np.float64)).sum() < 4 * whole / pieces.sum()
    # the extra references are capped at sliver_budget x T (here fewer than the sliver wants)
    tight = ps.SplitSettings(budget=budget, min_splits=0.0, sliver_budget=10 / len(tris))
    extra = ps._split_counts(tris, lo, hi, tight) - share
    assert 0 < extra.sum() <= 10


def test_packed_copies_keep_ids_and_lights():
    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    plain = pack_scene(scene, bvh_splits="off")
    split = pack_scene(scene, bvh_splits="2")
    assert plain.raster_rows is None and split.raster_rows is not None
    n = plain.num_triangles
    assert split.num_source_triangles == n < split.num_triangles
    # every row is a copy of its triangle (tri_order: the input triangle), first copies rasterized
    inv = np.argsort(plain.tri_order)
    rows = inv[split.tri_order]
    for name in ("tri_pos", "tri_normal", "tri_uv", "tri_info"):
        np.testing.assert_array_equal(getattr(split, name)[: split.num_triangles], getattr(plain, name)[rows])
    assert np.array_equal(np.sort(split.tri_order[split.raster_rows]), np.arange(n))
    # the same lights, in the same order, each named by a copy of the same triangle
    def lights(p):
        ids = p.lights[: p.num_lights, 0].view(np.uint32).astype(np.int64)
        tri = np.where(ids < p.num_triangles, p.tri_order[np.minimum(ids, p.num_triangles - 1)], -1)
        return tri, p.lights[: p.num_lights, 1:]
    (tri_a, rest_a), (tri_b, rest_b) = lights(plain), lights(split)
    assert plain.num_lights == split.num_lights > 0
    np.testing.assert_array_equal(tri_a, tri_b)
    np.testing.assert_array_equal(rest_a, rest_b)


@pytest.mark.parametrize("integrator, aov, gbuffer", [
    ("pt", None, "raster"),     # the raster G-buffer draws first copies only (index buffer)
    ("pt", None, "traced"),     # the ray-cast G-buffer's ids are whichever copy it hits
    ("drt", None, "raster"),    # camera rays
    ("bdpt", None, "raster"),   # light subpaths start on emissive triangles
    ("pt", "normal", "raster"),
])
def test_renders_the_same_image_with_and_without_splits(monkeypatch, integrator, aov, gbuffer):
    from lift_gl.options import Options
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    scene = load_scene(REPO / "scenes" / "cornell.toml")

    def render(splits):
        _renderers_split_with(monkeypatch, splits)
        r = Renderer(scene, size=(40, 32), integrator=integrator, seed=3, options=Options(gbuffer=gbuffer))
        try:
            assert (r.packed.raster_rows is not None) == (splits != "off")
            return r.aov(aov) if aov else r.render(spp=4)
        finally:
            r.release()

    plain, split = render("off"), render("3")
    assert np.isfinite(plain).all() and plain.max() > 0
    # the same hits through another tree: equal but where a ray meets two triangles at one
    # t (a quad's diagonal), which one wins depends on the order of the visit
    differ = np.abs(split - plain).max(axis=-1) > 1e-5 * max(float(plain.max()), 1.0)
    assert differ.mean() <= 0.01, differ.mean()


def _slanted_tubes(n_sides: int = 8, radius: float = 0.015) -> tuple[np.ndarray, np.ndarray]:
    """Thin tubes across the Cornell box at a slant (a chair's wire base): long faces whose boxes
    are far larger than they are. (positions (V, 3), indices (T, 3))."""
    ends = [((-0.8, 0.05, -0.6), (0.2, 1.3, 0.4)), ((0.7, 0.05, -0.7), (-0.3, 1.1, 0.5)),
            ((-0.6, 1.6, 0.3), (0.6, 0.2, -0.5))]
    positions, indices = [], []
    for a, b in ends:
        a, b = np.asarray(a), np.asarray(b)
        axis = (b - a) / np.linalg.norm(b - a)
        u = np.cross(axis, (0.0, 0.0, 1.0))
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        ring = [radius * (np.cos(k * 2 * np.pi / n_sides) * u + np.sin(k * 2 * np.pi / n_sides) * v)
                for k in range(n_sides)]
        base = sum(len(p) for p in positions)
        positions.append(np.array([a + r for r in ring] + [b + r for r in ring]))
        for k in range(n_sides):
            k1 = (k + 1) % n_sides
            indices += [(base + k, base + k1, base + n_sides + k), (base + k1, base + n_sides + k1, base + n_sides + k)]
    return np.concatenate(positions), np.array(indices, np.int32)


def test_sliver_splits_render_the_same_image(monkeypatch):
    """Slanted thin tubes split into many pieces each (the sliver rule) render the image the
    unsplit tree renders (the copies carry their triangle's data)."""
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.model import Mesh

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    positions, indices = _slanted_tubes()
    scene.meshes.append(Mesh(name="tubes", positions=positions, indices=indices, material=scene.meshes[-1].material))
    # the sliver rule alone: a token budget, every size a candidate
    slivers = "budget=0.02:min_extent=0:max_extent=1:min_over_median=0:min_triangles=0:min_splits=0:sliver_budget=40"

    def render(splits):
        _renderers_split_with(monkeypatch, splits)
        r = Renderer(scene, size=(40, 32), integrator="pt", seed=3)
        try:
            return r.render(spp=4), r.packed
        finally:
            r.release()

    (plain, _), (split, packed) = render("off"), render(slivers)
    tubes = len(indices)
    assert packed.num_triangles > packed.num_source_triangles + 8 * tubes   # many pieces a tube face
    assert np.isfinite(plain).all() and plain.max() > 0
    differ = np.abs(split - plain).max(axis=-1) > 1e-5 * max(float(plain.max()), 1.0)
    assert differ.mean() <= 0.01, differ.mean()


def test_scene_edit_with_splits_matches_a_fresh_renderer(monkeypatch):
    """A geometry edit re-packs the scene; the new tree stores other copies, and the raster
    G-buffer draws the new first copies (GBufferPass.set_triangles)."""
    import dataclasses

    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    _renderers_split_with(monkeypatch, "3")
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    extra = [dataclasses.replace(m, positions=m.positions * 0.3 + [0.1, 0.2, 0.1]) for m in scene.meshes[:4]]
    bigger = dataclasses.replace(scene, meshes=[*scene.meshes, *extra])
    r = Renderer(scene, size=(32, 32), seed=1)
    rows_before = r.packed.num_triangles
    r.update_scene(bigger)
    assert r.packed.raster_rows is not None and r.packed.num_triangles != rows_before
    assert r.gbuffer.num_vertices == 3 * r.packed.num_source_triangles
    image = r.render(spp=2)
    fresh = Renderer(bigger, size=(32, 32), seed=1)
    np.testing.assert_array_equal(image, fresh.render(spp=2))
    r.release()
    fresh.release()
