"""A tree over the emissive primitives, so that next event estimation picks a light by its
importance at the shading point (shaders/lift/light_tree.glsl), after Conty Estevez and
Kulla 2018, "Importance sampling of many lights with adaptive tree splitting".

Each node bounds its lights by a box (where they are), a cone of normals (where they face:
axis, spread theta_o; every emitter here radiates over a hemisphere about its normal, so the
emission spread theta_e is pi/2 for all) and an intensity: the sum of L A over its
triangles and of L pi r^2 over its spheres (luminance times the area the light shows face
on), so that intensity cos / d^2 is the light's irradiance scale at distance d. Sampling
walks from the root, choosing each child in proportion to that bound's importance at the
point; the probability of the light is the product of the choices, and light_pdf retraces
the same walk (the light's bits, below) to get the same product, float for float.

The build splits a node where Conty and Kulla's surface-area-orientation cost (intensity x
orientation measure x box area of both sides) is least, over 12 buckets of the centroids on
each axis; the tree stays within 31 levels (the bit trail's width) by splitting at the
median where the depth left would not hold a balanced subtree.

Layout: appended to the `lights` buffer after its L entries (scene_data.glsl), 2L - 1 nodes
of three vec4 each, depth first (a node's first child follows it):
  (box min xyz, intensity), (box max xyz, uint bits: second child, or LEAF | light index),
  (cone axis xyz, cos theta_o);
then L rows (uint bits of primitive id, bit trail: bit d set where the walk goes to the
second child at depth d, depth, 0), sorted by primitive, for light_pdf's binary search.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LEAF = 0x80000000
MAX_DEPTH = 31
BUCKETS = 12
NODE_ROWS = 3


@dataclass
class LightBounds:
    """Per light: box (lo, hi: (L, 3)), intensity (L,), cone axis (L, 3), theta_o (L,)."""
    lo: np.ndarray
    hi: np.ndarray
    intensity: np.ndarray
    axis: np.ndarray
    theta_o: np.ndarray


def orientation_measure(theta_o: np.ndarray) -> np.ndarray:
    """Conty and Kulla's M_Omega for a cone of spread theta_o and emission spread pi/2: the
    cosine-weighted solid angle it can light (pi for a single face, 4 pi for a sphere)."""
    theta_o = np.asarray(theta_o, dtype=np.float64)
    theta_w = np.minimum(theta_o + 0.5 * math.pi, math.pi)
    return (2.0 * math.pi * (1.0 - np.cos(theta_o))
            + 0.5 * math.pi * (2.0 * theta_w * np.sin(theta_o) - np.cos(theta_o - 2.0 * theta_w)
                               - 2.0 * theta_o * np.sin(theta_o) + np.cos(theta_o)))


def bounding_cone(axes: np.ndarray, theta_o: np.ndarray) -> tuple[np.ndarray, float]:
    """A cone holding every cone (axes[i], theta_o[i]): about their mean axis, wide enough for
    the farthest (conservative, not the tightest)."""
    total = axes.sum(axis=0)
    norm = float(np.linalg.norm(total))
    if norm < 1e-6 * len(axes):
        return np.array([0.0, 0.0, 1.0]), math.pi
    axis = total / norm
    spread = np.arccos(np.clip(axes @ axis, -1.0, 1.0)) + theta_o
    return axis, float(min(spread.max(), math.pi))


def _box_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi - lo, 0.0)
    return 2.0 * (e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0])


def _side_cones(axes: np.ndarray, theta_o: np.ndarray, members: np.ndarray) -> np.ndarray:
    """bounding_cone's spread for each column of members ((n, k) booleans: the lights of k sets)."""
    total = axes.T @ members  # (3, k)
    norm = np.linalg.norm(total, axis=0)
    axis = total / np.maximum(norm, 1e-300)
    spread = np.arccos(np.clip(axes @ axis, -1.0, 1.0)) + theta_o[:, None]
    spread = np.where(members, spread, -np.inf).max(axis=0)
    return np.where(norm < 1e-6 * members.sum(axis=0), math.pi, np.minimum(spread, math.pi))


def _split_cost(b: LightBounds, idx: np.ndarray, centroid: np.ndarray, axis: int) -> tuple[float, np.ndarray] | None:
    """The least cost over the bucket boundaries on `axis`, and the lights left of it: for
    each boundary at once, both sides' intensity x orientation measure x box area."""
    c = centroid[idx, axis]
    c0, c1 = c.min(), c.max()
    if not c1 > c0:
        return None
    bucket = np.minimum(((c - c0) / (c1 - c0) * BUCKETS).astype(int), BUCKETS - 1)
    left = bucket[:, None] <= np.arange(BUCKETS - 1)[None, :]  # (n, boundaries)
    counts = left.sum(axis=0)
    valid = (counts > 0) & (counts < len(idx))
    if not valid.any():
        return None
    left = left[:, valid]
    cost = np.zeros(left.shape[1])
    lo, hi, intensity = b.lo[idx], b.hi[idx], b.intensity[idx]
    for side in (left, ~left):
        box_lo = np.where(side[:, :, None], lo[:, None, :], np.inf).min(axis=0)
        box_hi = np.where(side[:, :, None], hi[:, None, :], -np.inf).max(axis=0)
        cost += (intensity @ side) * orientation_measure(_side_cones(b.axis[idx], b.theta_o[idx], side)) \
            * _box_area(box_lo, box_hi)
    best = int(np.argmin(cost))
    return float(cost[best]), left[:, best]


def _split(b: LightBounds, idx: np.ndarray, centroid: np.ndarray, depth: int) -> tuple[np.ndarray, np.ndarray]:
    n = len(idx)
    extent = centroid[idx].max(axis=0) - centroid[idx].min(axis=0)
    if depth + math.ceil(math.log2(n)) < MAX_DEPTH:
        best = None
        for axis in range(3):
            found = _split_cost(b, idx, centroid, axis)
            if found is not None and (best is None or found[0] < best[0]):
                best = found
        if best is not None:
            return idx[best[1]], idx[~best[1]]
    # The median on the widest axis: balanced (and where all centroids coincide, by index).
    order = idx[np.argsort(centroid[idx, int(np.argmax(extent))], kind="stable")]
    return order[: n // 2], order[n // 2:]


def build_light_tree(b: LightBounds, prims: np.ndarray) -> np.ndarray:
    """The tree's rows (float32 (3 (2L - 1) + L, 4)) for lights 0 .. L-1 of primitives `prims`."""
    count = len(b.intensity)
    if count == 0:
        return np.zeros((0, 4), np.float32)
    centroid = 0.5 * (b.lo + b.hi)
    nodes = np.zeros((2 * count - 1, NODE_ROWS, 4), np.float32)
    bits = nodes.view(np.uint32)
    trails = np.zeros(count, np.uint32)
    depths = np.zeros(count, np.uint32)
    next_node = 0

    def build(idx: np.ndarray, depth: int, trail: int) -> int:
        nonlocal next_node
        node = next_node
        next_node += 1
        axis, theta = bounding_cone(b.axis[idx], b.theta_o[idx])
        nodes[node, 0, :3] = b.lo[idx].min(axis=0)
        nodes[node, 0, 3] = b.intensity[idx].sum()
        nodes[node, 1, :3] = b.hi[idx].max(axis=0)
        nodes[node, 2, :3] = axis
        nodes[node, 2, 3] = math.cos(theta)
        if len(idx) == 1:
            bits[node, 1, 3] = LEAF | int(idx[0])
            trails[idx[0]], depths[idx[0]] = trail, depth
            return node
        first, second = _split(b, idx, centroid, depth)
        build(first, depth + 1, trail)
        bits[node, 1, 3] = build(second, depth + 1, trail | (1 << depth))
        return node

    build(np.arange(count), 0, 0)
    table = np.zeros((count, 4), np.uint32)
    by_prim = np.argsort(prims, kind="stable")
    table[:, 0] = np.asarray(prims, np.uint32)[by_prim]
    table[:, 1] = trails[by_prim]
    table[:, 2] = depths[by_prim]
    return np.concatenate([nodes.reshape(-1, 4), table.view(np.float32)])


def triangle_bounds(corners: np.ndarray, move: np.ndarray | None, radiance: np.ndarray) -> LightBounds:
    """Emissive triangles (corners (L, 3, 3), GPU space; move: their shutter displacement or
    None) radiating radiance (L,) from the side their winding faces."""
    corners = np.asarray(corners, np.float64)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    if move is not None:
        lo, hi = np.minimum(lo, lo + move), np.maximum(hi, hi + move)
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(n, axis=1)
    area = 0.5 * length
    axis = n / np.maximum(length, 1e-300)[:, None]
    return LightBounds(lo, hi, radiance * area, axis, np.zeros(len(area)))


def sphere_bounds(centers: np.ndarray, radii: np.ndarray, move: np.ndarray | None, radiance: np.ndarray) -> LightBounds:
    """Emissive spheres: every direction, showing pi r^2 to any point outside."""
    centers, radii = np.asarray(centers, np.float64).reshape(-1, 3), np.asarray(radii, np.float64)
    lo, hi = centers - radii[:, None], centers + radii[:, None]
    if move is not None:
        lo, hi = np.minimum(lo, lo + move), np.maximum(hi, hi + move)
    axis = np.tile([0.0, 0.0, 1.0], (len(radii), 1))
    return LightBounds(lo, hi, radiance * math.pi * radii ** 2, axis, np.full(len(radii), math.pi))


def concat_bounds(parts: list[LightBounds]) -> LightBounds:
    return LightBounds(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                         ("lo", "hi", "intensity", "axis", "theta_o")))


# ---- the walk, in numpy: what light_tree.glsl computes (tests compare the two) ----

def node_importance(rows: np.ndarray, node: int, p: np.ndarray) -> float:
    """A node's importance at point p (light_tree.glsl: light_node_importance), from the angles
    themselves rather than their cosines and sines."""
    r0, r1, r2 = (rows[NODE_ROWS * node + k].astype(np.float64) for k in range(NODE_ROWS))
    lo, hi, intensity, axis, theta_o = r0[:3], r1[:3], r0[3], r2[:3], math.acos(min(max(r2[3], -1.0), 1.0))
    centre, radius2 = 0.5 * (lo + hi), 0.25 * float(np.dot(hi - lo, hi - lo))
    d = np.asarray(p, np.float64) - centre
    dist2 = float(np.dot(d, d))
    falloff = intensity / max(dist2, radius2, 1e-30)
    if not dist2 > radius2:
        return falloff
    theta_w = math.acos(min(max(float(np.dot(axis, d)) / math.sqrt(dist2), -1.0), 1.0))
    theta = max(0.0, theta_w - theta_o - math.asin(math.sqrt(radius2 / dist2)))
    return falloff * math.cos(theta) if theta < 0.5 * math.pi else 0.0


def light_probabilities(rows: np.ndarray, count: int, p: np.ndarray) -> np.ndarray:
    """The probability of each light (0 .. count - 1) that the walk from p picks it."""
    out = np.zeros(count)
    bits = rows.view(np.uint32)

    def walk(node: int, prob: float) -> None:
        second = int(bits[NODE_ROWS * node + 1, 3])
        if second & LEAF:
            out[second & ~LEAF] = prob
            return
        a, b = node_importance(rows, node + 1, p), node_importance(rows, second, p)
        if a + b > 0:
            first = a / (a + b)
            walk(node + 1, prob * first)
            walk(second, prob * (1.0 - first))

    walk(0, 1.0)
    return out
