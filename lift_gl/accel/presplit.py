"""Triangle pre-splitting: large triangles enter the BVH build as several tighter boxes.

Why: a triangle that spans a good part of the scene (a floor, a wall, a long beam drawn
as two triangles) has a box that overlaps most of the tree's nodes, so every ray near it
walks deep into the tree. Splitting its box into pieces that each bound only the part of
the triangle inside them lets the SAH builder put the pieces in different subtrees (Ernst &
Greiner 2007, "Early split clipping"; the split-budget and grid-aligned planes are Karras &
Aila 2013, "Fast parallel construction of high-quality bounding volume hierarchies").

What a build then sees is a list of *references* (triangle id, box); a triangle may have
several, and the leaves that hold them repeat the triangle (accel/bvh.py: `BVH.order` maps
each leaf row to its triangle, with repeats). Closest-hit and any-hit traversals need no
change: the same triangle found twice gives the same t, and the later copy never wins.

How, vectorised over all references at once:
  1. candidates are triangles whose box diagonal lies between `min_extent` and `max_extent`
     of the scene's (the largest stay whole: see AUTO_CANDIDATES); a
     budget of `budget` x T extra references is shared among them in proportion to the cube
     root of the area their box wastes (box half-area minus triangle area); slivers lying
     across the axes get more, up to about (box half-area / area) / `sliver_ratio` pieces;
  2. each round splits every reference that has splits left at the coarsest plane of a
     dyadic grid over the scene bounds that crosses its box (the planes the top of the tree
     is likely to split at), on the axis where that plane is coarsest; each side's box is the
     box of the triangle's corners on that side and the edge crossings, cut to the parent box
     (exact for the first split, conservative after: never smaller than the piece it bounds);
  3. the remaining splits are shared between the two sides by their boxes' half-areas.
Boxes are rounded outwards by one float32 ulp so that no crossing point, rounded, falls
outside both sides.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bvh import bounds_of

MAX_SPLITS_PER_TRIANGLE = 64   # one triangle never becomes more than 65 references
_GRID_BITS = 30


@dataclass(frozen=True)
class SplitSettings:
    """budget: extra references allowed, as a fraction of the triangle count (0: off).
    min_extent, max_extent: only triangles whose box diagonal lies in this range, as fractions
    of the scene's, and exceeds min_over_median times the median triangle's, are split (a mesh
    of even triangles, like a scanned statue, has none: splitting its larger ones did not
    lower its SAH cost).
    min_triangles: scenes with fewer triangles are not split (tiny trees, nothing to gain).
    min_splits: nor are scenes whose candidates would take fewer splits than this fraction of
    the triangle count (a few outliers: the split build would cost more than it could gain).
    sliver_ratio, sliver_budget: a candidate whose box's half-area is more than sliver_ratio
    times its area (a sliver lying across the axes, like the faces of a thin tube at a
    slant) gets enough splits for its pieces to come near that ratio (about ratio /
    sliver_ratio pieces, at most MAX_SPLITS_PER_TRIANGLE + 1), when that is more than its share
    of `budget`; these extra references are at most sliver_budget x T (scaled down to fit).
    Why: such pieces' boxes shrink with every split, and the rays that pass near a thicket of
    them set the pace of their warp on a GPU; the SAH cost, a mean over rays, does not show it
    (docs/bvh.md, "Slivers").
    auto: build the tree without splits and with each of AUTO_CANDIDATES, and keep the one
    of least SAH cost (accel/cache.py build_with).
    slivers (with auto, the default; resolve_splits("auto-no-slivers") leaves it out): where
    no candidate lowers the SAH cost enough, also try SLIVER_CANDIDATE (slivers split, nearly
    nothing else) and keep it where its SAH cost is within SLIVER_TOLERANCE of the tree without
    splits: its gain is in the warps' longest rays, which the SAH cost does not see (docs/gpu.md
    "Twelfth session": of ten scenes it changes only the classroom's tree, whose trace it made
    0.980x on an H100). Tried below AUTO_LBVH_TRIANGLES only (accel/cache.py)."""
    budget: float = 0.3
    min_extent: float = 0.01
    max_extent: float = 0.3
    min_triangles: int = 1000
    min_over_median: float = 8.0
    min_splits: float = 0.01
    sliver_ratio: float = 8.0
    sliver_budget: float = 2.0
    auto: bool = False
    slivers: bool = False

    @property
    def enabled(self) -> bool:
        return self.auto or self.budget > 0

    def key(self) -> str:
        """What the on-disk cache keys on (accel/cache.py)."""
        if self.auto:
            slivers = f";slivers:{SLIVER_CANDIDATE.key()};tolerance={SLIVER_TOLERANCE:g}" if self.slivers else ""
            return "presplit:auto:" + ";".join(c.key() for c in AUTO_CANDIDATES) + f";min_gain={AUTO_MIN_GAIN:g}" + slivers
        sliver = f",sliver={self.sliver_ratio:g}x{self.sliver_budget:g}" if self.sliver_ratio > 0 and self.sliver_budget > 0 else ""
        return (f"presplit:budget={self.budget:g},extent={self.min_extent:g}..{self.max_extent:g},"
                f"over_median={self.min_over_median:g},min_tris={self.min_triangles},min_splits={self.min_splits:g}"
                + sliver)


OFF = SplitSettings(budget=0.0)
# Triangles larger than max_extent are left whole: the greedy top-down SAH build does worse
# with the pieces of walls the size of the room than with the walls whole (it peels them off
# near the root): in Lift's dining room splitting every triangle over 1% of the scene raises
# the SAH cost from 49.0 to 59.6, splitting those between 1% and 30% lowers it to 39.1;
# classroom 16.3 -> 17.4 and 14.5 (docs/bvh.md has the measurements). A scene whose SAH cost
# the splits do not lower by AUTO_MIN_GAIN keeps the tree without them.
AUTO_CANDIDATES = (SplitSettings(),)
AUTO_MIN_GAIN = 0.03
AUTO = SplitSettings(auto=True, slivers=True)
AUTO_NO_SLIVERS = SplitSettings(auto=True)
# auto's extra candidate where no other is kept: slivers across the axes split down to 0.05%
# of the scene's diagonal (the classroom's far geometry makes 1% 3.1 m, larger than anything in
# the room), a sliver ratio of 4 (8 changed nothing there), and a budget for the rest too small
# to matter.
SLIVER_CANDIDATE = SplitSettings(budget=0.01, min_extent=0.0005, sliver_ratio=4.0)
SLIVER_TOLERANCE = 0.01


def resolve_splits(splits) -> SplitSettings:
    """SplitSettings from None (auto), a SplitSettings, a bool, or a string: 'auto' (the default), 'off'/'0', a budget fraction ('0.3': split every triangle
    over 1% of the scene, however large and whatever the scene's size, with that many extra
    references, and keep the result: for tests and experiments), or SplitSettings fields as
    'name=value' joined by ':' ('budget=1:min_extent=0.005': the default candidates with
    those changes, kept whatever the SAH cost: for experiments)."""
    if isinstance(splits, SplitSettings):
        return splits
    if isinstance(splits, bool):
        return AUTO if splits else OFF
    source = "the caller"
    if splits is None:
        splits = "auto"
    text = str(splits).strip().lower()
    if text in ("on", "auto"):
        return AUTO
    if text == "auto-no-slivers":
        return AUTO_NO_SLIVERS
    if text in ("off", "none"):
        return OFF
    if "=" in text:
        return _settings_from_fields(text, splits, source)
    try:
        budget = float(text)
    except ValueError:
        budget = -1.0
    if not (0.0 <= budget <= 8.0):
        raise ValueError(f"bad BVH split setting {splits!r} (from {source}): use auto, auto-no-slivers, off or a budget "
                         "fraction of extra references between 0 and 8 (e.g. 0.3)")
    return SplitSettings(budget=budget, max_extent=float("inf"), min_triangles=0, min_over_median=0.0, min_splits=0.0,
                         sliver_budget=0.0) \
        if budget > 0 else OFF


def _settings_from_fields(text: str, splits, source: str) -> SplitSettings:
    """SplitSettings from 'name=value:name=value' (resolve_splits)."""
    names = {f for f in SplitSettings.__dataclass_fields__ if f not in ("auto", "slivers")}
    fields = {}
    for part in text.split(":"):
        name, _, value = part.partition("=")
        name = name.strip()
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if name not in names or not number >= 0:
            raise ValueError(f"bad BVH split setting {splits!r} (from {source}): {part!r} is not name=value with "
                             f"a number >= 0 and a name among {', '.join(sorted(names))}")
        fields[name] = int(number) if name == "min_triangles" else number
    return SplitSettings(**fields)


def _half_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def _split_counts(tris: np.ndarray, lo: np.ndarray, hi: np.ndarray, settings: SplitSettings) -> np.ndarray:
    """How many times each triangle is split (int64 (T,)), the budget shared out by priority."""
    n = tris.shape[0]
    counts = np.zeros(n, np.int64)
    if settings.budget <= 0 or n < settings.min_triangles:
        return counts
    scene_diag = float(np.linalg.norm(hi.max(0).astype(np.float64) - lo.min(0)))
    diag = np.linalg.norm(hi.astype(np.float64) - lo, axis=1)
    least = max(settings.min_extent * scene_diag, settings.min_over_median * float(np.median(diag)))
    cand = np.flatnonzero((diag > least) & (diag <= settings.max_extent * scene_diag))
    budget = int(settings.budget * n)
    if cand.size == 0 or budget <= 0:
        return counts
    t = tris[cand].astype(np.float64)
    tri_area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    box_half_area = _half_area(lo[cand].astype(np.float64), hi[cand].astype(np.float64))
    waste = np.maximum(box_half_area - tri_area, 0.0)
    prio = np.cbrt(waste)
    if not (prio > 0).any():
        return counts
    # the scale D with sum(min(floor(D * prio), cap)) <= budget, by bisection
    def total(d):
        return int(np.minimum(np.floor(d * prio), MAX_SPLITS_PER_TRIANGLE).sum())
    lo_d, hi_d = 0.0, (budget + cand.size) / prio.sum()
    while total(hi_d) < budget and hi_d < 1e30 and total(hi_d) < MAX_SPLITS_PER_TRIANGLE * cand.size:
        hi_d *= 2.0
    for _ in range(50):
        mid = 0.5 * (lo_d + hi_d)
        lo_d, hi_d = (mid, hi_d) if total(mid) <= budget else (lo_d, mid)
    counts[cand] = np.minimum(np.floor(lo_d * prio), MAX_SPLITS_PER_TRIANGLE).astype(np.int64)
    counts[cand] += _sliver_splits(tri_area, box_half_area, counts[cand], settings, n)
    if counts.sum() < settings.min_splits * n:
        counts[:] = 0
    return counts


def _sliver_splits(area: np.ndarray, half_area: np.ndarray, share: np.ndarray, settings: SplitSettings,
                   n: int) -> np.ndarray:
    """Splits to add to each candidate's budget share (`share`): slivers across the axes get
    up to about ratio / sliver_ratio - 1 splits (SplitSettings), all of them together at most
    sliver_budget x n."""
    if settings.sliver_ratio <= 0 or settings.sliver_budget <= 0:
        return np.zeros_like(share)
    ratio = half_area / np.maximum(area, 1e-300)
    # a triangle whose corners lie on a line (to float precision: an area under a millionth of
    # its box's) is as good as never hit: no pieces for it
    want = np.where(ratio < 1e6, np.minimum(np.ceil(ratio / settings.sliver_ratio) - 1.0, MAX_SPLITS_PER_TRIANGLE), 0.0)
    extra = np.maximum(want - share, 0.0)
    allowed = settings.sliver_budget * n
    if extra.sum() > allowed:
        extra = np.floor(extra * (allowed / extra.sum()))
    return extra.astype(np.int64)


def _split_planes(lo: np.ndarray, hi: np.ndarray, s_lo: np.ndarray, s_scale: np.ndarray):
    """(axis, plane) of each box: the coarsest dyadic grid plane strictly inside it (grid over
    the scene bounds); on ties the longest axis. Boxes without such a plane well inside them
    get their longest axis's midpoint."""
    a = np.floor((lo - s_lo) * s_scale).astype(np.int64)
    b = np.ceil((hi - s_lo) * s_scale).astype(np.int64) - 1
    np.clip(a, 0, (1 << _GRID_BITS) - 1, out=a)
    np.clip(b, 0, (1 << _GRID_BITS) - 1, out=b)
    diff = a ^ b
    # the highest differing bit of a and b: the plane (b with the bits below it cleared)
    # lies in (a, b], i.e. strictly inside the box
    extent = hi - lo
    # axes that are thin next to the box's longest (a flat triangle's normal axis, or a piece
    # cut to a sliver of ulps at an earlier plane) are not worth a split
    worth = (b > a) & (extent > 1e-3 * extent.max(axis=1, keepdims=True))
    level = np.where(worth & (diff > 0), np.floor(np.log2(np.maximum(diff, 1))).astype(np.int64), -1)
    score = level * 4.0 + extent / np.maximum(extent.max(axis=1, keepdims=True), 1e-300)  # level first
    axis = np.argmax(score, axis=1)
    rows = np.arange(lo.shape[0])
    lv = level[rows, axis]
    cell = (b[rows, axis] >> np.maximum(lv, 0)) << np.maximum(lv, 0)
    plane = s_lo[axis] + cell / s_scale[axis]
    # not within a sliver of the box's faces (a plane met before, rounded into the box)
    margin = 1e-3 * extent[rows, axis]
    inside = (lv >= 0) & (plane > lo[rows, axis] + margin) & (plane < hi[rows, axis] - margin)
    longest = np.argmax(extent, axis=1)
    return (np.where(inside, axis, longest),
            np.where(inside, plane, 0.5 * (lo[rows, longest] + hi[rows, longest])))


def _clip_sides(tri: np.ndarray, axis: np.ndarray, plane: np.ndarray):
    """Boxes of the parts of triangles (R, 3, 3) float64 on each side of the plane
    x[axis] = plane: (left_lo, left_hi, right_lo, right_hi); empty sides have lo > hi."""
    rows = np.arange(tri.shape[0])
    x = tri[rows, :, axis]                              # (R, 3)
    left_pts = np.where((x <= plane[:, None])[..., None], tri, np.nan)
    right_pts = np.where((x >= plane[:, None])[..., None], tri, np.nan)
    cross = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        xi, xj = x[:, i], x[:, j]
        straddle = (xi - plane) * (xj - plane) < 0
        denom = np.where(straddle, xj - xi, 1.0)
        f = np.clip((plane - xi) / denom, 0.0, 1.0)
        p = tri[:, i] + f[:, None] * (tri[:, j] - tri[:, i])
        p[rows, axis] = plane
        cross.append(np.where(straddle[:, None], p, np.nan))
    cross = np.stack(cross, axis=1)                      # (R, 3, 3)
    left = np.concatenate([left_pts, cross], axis=1)
    right = np.concatenate([right_pts, cross], axis=1)
    with np.errstate(invalid="ignore"):
        out = (np.nanmin(left, axis=1), np.nanmax(left, axis=1), np.nanmin(right, axis=1), np.nanmax(right, axis=1))
    # all-NaN rows (a side with nothing on it) become empty boxes
    return tuple(np.where(np.isnan(v), np.inf if k % 2 == 0 else -np.inf, v) for k, v in enumerate(out))


def presplit(tris: np.ndarray, settings: SplitSettings):
    """References for a float32 (T, 3, 3) triangle array: (ref_tri int64 (R,), lo float32
    (R, 3), hi float32 (R, 3)), R >= T, every triangle referenced at least once and covered by
    the union of its references' boxes. Without splits R == T and ref_tri == arange(T)."""
    pos = np.asarray(tris, np.float32)
    lo = pos.min(axis=1)
    hi = pos.max(axis=1)
    n = pos.shape[0]
    counts = _split_counts(pos, lo, hi, settings)
    ref_tri = np.arange(n, dtype=np.int64)
    if not counts.any():
        return ref_tri, lo, hi
    s_lo = bounds_of(lo)[0].astype(np.float64)
    s_ext = bounds_of(hi)[1].astype(np.float64) - s_lo
    s_scale = np.where(s_ext > 0, (1 << _GRID_BITS) / np.where(s_ext > 0, s_ext, 1.0), 0.0)

    # finished references, and the pieces still to split: (triangle, box, splits left)
    done_tri, done_lo, done_hi = [ref_tri[counts == 0]], [lo[counts == 0]], [hi[counts == 0]]
    act = np.flatnonzero(counts > 0)
    a_tri, a_lo, a_hi, a_n = act, lo[act].astype(np.float64), hi[act].astype(np.float64), counts[act]
    while a_tri.size:
        axis, plane = _split_planes(a_lo, a_hi, s_lo, s_scale)
        l_lo, l_hi, r_lo, r_hi = _clip_sides(pos[a_tri].astype(np.float64), axis, plane)
        # conservative float32 boxes, each inside its parent box
        l_lo = np.maximum(np.nextafter(l_lo.astype(np.float32), np.float32(-np.inf)), a_lo)
        l_hi = np.minimum(np.nextafter(l_hi.astype(np.float32), np.float32(np.inf)), a_hi)
        r_lo = np.maximum(np.nextafter(r_lo.astype(np.float32), np.float32(-np.inf)), a_lo)
        r_hi = np.minimum(np.nextafter(r_hi.astype(np.float32), np.float32(np.inf)), a_hi)
        # No split where a side is empty (the other one then bounds the whole piece) or as big
        # as the parent (the plane missed the piece: the parent bounds both sides): one
        # reference goes on, with that box and the splits left.
        l_empty = (l_lo > l_hi).any(axis=1)
        r_empty = (r_lo > r_hi).any(axis=1)
        l_whole = ~l_empty & (l_lo <= a_lo).all(axis=1) & (l_hi >= a_hi).all(axis=1)
        r_whole = ~r_empty & (r_lo <= a_lo).all(axis=1) & (r_hi >= a_hi).all(axis=1)
        one = l_empty | r_empty | l_whole | r_whole
        keep_lo = np.where((r_empty & ~l_empty)[:, None], l_lo, np.where((l_empty & ~r_empty)[:, None], r_lo, a_lo))
        keep_hi = np.where((r_empty & ~l_empty)[:, None], l_hi, np.where((l_empty & ~r_empty)[:, None], r_hi, a_hi))
        a_l = np.where(one, 0, a_n - 1)
        al, ar = _half_area(l_lo, l_hi), _half_area(r_lo, r_hi)
        share = np.divide(al, al + ar, out=np.full_like(al, 0.5), where=(al + ar) > 0)
        n_l = np.where(one, a_n - 1, np.rint(a_l * share).astype(np.int64))
        n_r = np.where(one, 0, a_n - 1 - n_l)
        new_tri = np.concatenate([a_tri, a_tri[~one]])
        new_lo = np.concatenate([np.where(one[:, None], keep_lo, l_lo), r_lo[~one]])
        new_hi = np.concatenate([np.where(one[:, None], keep_hi, l_hi), r_hi[~one]])
        new_n = np.concatenate([n_l, n_r[~one]])
        fin = new_n <= 0
        done_tri.append(new_tri[fin])
        done_lo.append(new_lo[fin].astype(np.float32))
        done_hi.append(new_hi[fin].astype(np.float32))
        a_tri, a_lo, a_hi, a_n = new_tri[~fin], new_lo[~fin], new_hi[~fin], new_n[~fin]
    ref_tri = np.concatenate(done_tri)
    lo = np.concatenate(done_lo)
    hi = np.concatenate(done_hi)
    # references of one triangle next to each other, triangles in input order (a stable
    # order: the build's result does not depend on how the rounds went)
    s = np.argsort(ref_tri, kind="stable")
    return ref_tri[s], lo[s], hi[s]
