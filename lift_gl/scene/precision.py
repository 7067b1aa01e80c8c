"""Where float32 can hold a scene: the GPU's origin, triangles too large for the rays that
meet them (split), and objects that float32 cannot hold beside the rest (refused).

The GPU sees world positions minus an origin, rounded to float32: a coordinate of magnitude D
moves by up to D 2^-24, a hit on a triangle whose corners are D from the ray's origin is
found to within about D 2^-22 along the ray, and rays leave a surface D 2^-15 away so as not
to hit it again (shaders/lift/surface.glsl, offset_ray_origin_scaled). Hence:

- An object more than MAX_DISTANCE_PER_SIZE (2^14) times its own size from the origin has its
  rays leave it half its size away, and further out its corners merge: it is refused, naming
  it (validate.py). Two unit boxes 1e8 apart cannot both be held, wherever the origin is.
- The origin is the centre of the scene's bounds; where that cannot hold every object but the
  camera's position can (a small scene near the camera, huge geometry far away), the camera's
  position (Scene.gpu_origin), which the GPU coordinates then keep for the scene's life.
- A triangle much larger than its distance from the origin (a ground quad 2e9 wide under a
  unit ball) makes those errors large where the rest of the scene is: edges longer than
  4 times their distance from the origin and than DETAIL_SPAN (4096) times the smallest
  object are split at their midpoints (split_large_triangles); so are edges longer than
  MAX_EDGE (2^30), whose cross products' squares overflow float32 (3.4e38) in every shader
  that normalises a triangle's normal. Edges are split, not triangles, so both triangles of a
  shared edge get the same new vertex and the surface stays watertight; its shape, normals and
  texture coordinates are unchanged (interpolated linearly, as the GPU does).
- A sphere cannot be split: one whose surface passes near an object 2^14 times smaller than
  its coordinates is refused (sphere_problem; a unit box on a sphere of radius 1e6 cast no shadow).
- A scene smaller than MIN_EXTENT (2^-20) across is refused: the fourth powers of its lengths
  (squared normals) fall below float32's smallest normal number.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DISTANCE_PER_SIZE = 2.0 ** 14
# Coordinates beyond this from the GPU's origin are refused outright: squared distances and
# areas (products of two lengths) must stay far from float32's 3.4e38.
MAX_COORDINATE = 1e18
DETAIL_SPAN = 4096.0
MAX_EDGE = 2.0 ** 30
MIN_EXTENT = 2.0 ** -20
# Triangles that splitting may add to one scene; beyond it the scene is refused (a hostile
# file of a million huge triangles would otherwise grow without bound).
MAX_SPLIT_TRIANGLES = 1_000_000


@dataclass
class Extent:
    """One object's axis-aligned box (float64, world space) and what to call it in messages."""

    lo: np.ndarray
    hi: np.ndarray
    what: str
    source: str
    mesh: object = None  # the Mesh it bounds, for meshes

    @property
    def size(self) -> float:
        return float((self.hi - self.lo).max())

    def distance(self, origin: np.ndarray) -> float:
        """Largest |coordinate| of the box in GPU coordinates: what float32 rounds."""
        return float(np.maximum(np.abs(self.lo - origin), np.abs(self.hi - origin)).max())


@dataclass
class Unheld:
    """An object float32 cannot hold at `origin_name`: `ratio` = distance / size."""

    extent: Extent
    distance: float
    ratio: float
    origin_name: str

    def message(self, scene_span: float) -> str:
        size, d = self.extent.size, self.distance
        if not d <= MAX_COORDINATE:
            return (f"{self.extent.what}: it lies {d:.3g} from {self.origin_name}, beyond the {MAX_COORDINATE:g} that "
                    "the GPU's float32 coordinates can hold (their squares must stay finite)")
        step = float(np.spacing(np.float32(d)))
        return (f"{self.extent.what}: {size:.3g} across and {d:.3g} from {self.origin_name}, where float32 (the "
                f"GPU's precision) rounds positions to steps of {step:.3g} and rays leave surfaces {d / 32768:.3g} "
                f"away; it cannot be drawn beside the rest of the scene, which spans {scene_span:.3g} (an object may "
                f"be at most {MAX_DISTANCE_PER_SIZE:,.0f} times its size from the GPU's origin): scale the scene, "
                "move the object nearer, or leave it out")


def object_extents(scene) -> list[Extent]:
    """The box of every mesh, sphere and instance (instances from their prototypes' boxes)."""
    out = []
    for m in scene.meshes:
        if len(m.indices):
            used = _used(m)
            out.append(Extent(used.min(axis=0), used.max(axis=0), f"mesh '{m.name}'", m.source, m))
    for i, s in enumerate(scene.spheres):
        out.append(Extent(s.center - s.radius, s.center + s.radius, f"sphere #{i + 1}", s.source))
    for i, inst in enumerate(scene.instances):
        proto = scene.prototypes[inst.mesh] if 0 <= inst.mesh < len(scene.prototypes) else None
        if proto is None or not len(proto.indices):
            continue
        used = _used(proto)
        lo, hi = used.min(axis=0), used.max(axis=0)
        corners = np.array([[(hi if (k >> a) & 1 else lo)[a] for a in range(3)] for k in range(8)])
        with np.errstate(all="ignore"):  # a transform near float64's range: refused as beyond MAX_COORDINATE
            world = corners @ inst.transform[:3, :3].T + inst.transform[:3, 3]
        out.append(Extent(world.min(axis=0), world.max(axis=0), f"instance '{inst.name or i + 1}'", inst.source))
    return out


def _used(mesh) -> np.ndarray:
    """The vertices a triangle uses (a file may hold others, anywhere)."""
    used = np.zeros(len(mesh.positions), bool)
    used[mesh.indices.ravel()] = True
    return mesh.positions if used.all() else mesh.positions[used]


def bounds_centre(extents: list[Extent]) -> np.ndarray:
    if not extents:
        return np.zeros(3)
    return 0.5 * (np.min([e.lo for e in extents], axis=0) + np.max([e.hi for e in extents], axis=0))


def span(extents: list[Extent]) -> float:
    """The largest side of the box around every object (0 for an empty scene)."""
    if not extents:
        return 0.0
    return float((np.max([e.hi for e in extents], axis=0) - np.min([e.lo for e in extents], axis=0)).max())


def unheld(extents: list[Extent], origin: np.ndarray, origin_name: str) -> list[Unheld]:
    """The objects float32 cannot hold with the GPU's zero at `origin`, worst first."""
    out = []
    for e in extents:
        size, d = e.size, e.distance(origin)
        if not d <= MAX_COORDINATE or (size > 0 and d > MAX_DISTANCE_PER_SIZE * size):
            out.append(Unheld(e, d, d / size if size > 0 else np.inf, origin_name))
    return sorted(out, key=lambda u: -u.ratio)


def choose_origin(scene, extents: list[Extent]) -> tuple[np.ndarray | None, list[Unheld]]:
    """(the GPU origin, the objects it cannot hold): None (the centre of the bounds, which
    pack_scene computes) where that holds every object, else the camera's position where that
    does; where neither does, the one that holds more, and what it cannot hold."""
    centre = unheld(extents, bounds_centre(extents), "the scene's centre")
    if not centre:
        return None, []
    camera = unheld(extents, scene.camera.position, "the camera")
    if not camera:
        return np.array(scene.camera.position, dtype=np.float64), []
    return (None, centre) if len(centre) < len(camera) else (np.array(scene.camera.position, dtype=np.float64), camera)


def sphere_problem(scene, extents: list[Extent], origin: np.ndarray) -> tuple[str, str] | None:
    """(message, source) for a sphere too large for an object lying near its surface (a box on a
    'planet'), or None. A sphere cannot be split as triangles are: rays leave it (|centre| +
    radius) 2^-18 away, which must stay below 1/16 of the sizes of what touches it (a unit
    box on a sphere of radius 1e6 casts no shadow: rays leave the sphere 7.6 away)."""
    if not scene.spheres or len(extents) < 2:
        return None
    lo = np.array([e.lo for e in extents])
    hi = np.array([e.hi for e in extents])
    sizes = (hi - lo).max(axis=1)
    centres = np.array([s.center for s in scene.spheres], dtype=np.float64)
    scales = np.abs(centres - origin).max(axis=1) + np.array([s.radius for s in scene.spheres])
    for i in np.flatnonzero(scales > sizes.min() * MAX_DISTANCE_PER_SIZE):   # only these can be too large
        s, scale = scene.spheres[i], float(scales[i])
        small = sizes * MAX_DISTANCE_PER_SIZE < scale
        if not small.any():
            continue
        nearest = np.linalg.norm(np.maximum(0.0, np.maximum(lo - s.center, s.center - hi)), axis=1)
        farthest = np.linalg.norm(np.maximum(np.abs(lo - s.center), np.abs(hi - s.center)), axis=1)
        near = small & (nearest <= s.radius + sizes) & (farthest >= s.radius - sizes)
        near &= [e.what != f"sphere #{i + 1}" for e in extents]
        if near.any():
            k = int(np.flatnonzero(near)[np.argmin(sizes[near])])
            return (f"sphere #{i + 1}: radius {s.radius:.3g}, too large for {extents[k].what} ({sizes[k]:.3g} across) "
                    f"near its surface: rays leave the sphere {scale / 262144:.3g} away there; model the large "
                    "surface as a mesh (lift-gl splits large triangles) or make it smaller", s.source)
    return None


def smallest_size(extents: list[Extent]) -> float:
    sizes = [e.size for e in extents if e.size > 0]
    return min(sizes) if sizes else 0.0


def edges_to_split(positions: np.ndarray, edges: np.ndarray, origin: np.ndarray, detail: float) -> np.ndarray:
    """Which edges (E, 2 vertex indices) are too long for their place: see the module docstring.
    Symmetric in the two ends, so two triangles sharing an edge agree."""
    a, b = positions[edges[:, 0]], positions[edges[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    lo, hi = np.minimum(a, b) - origin, np.maximum(a, b) - origin
    distance = np.linalg.norm(np.maximum(0.0, np.maximum(lo, -hi)), axis=1)  # origin to the edge's box
    return (length > np.maximum(4.0 * distance, detail)) | (length > MAX_EDGE)


# Sub-triangles of a triangle (corners 0, 1, 2; midpoints 3 = m01, 4 = m12, 5 = m20) for each
# set of split edges (bit 0: edge 01, bit 1: edge 12, bit 2: edge 20), in the same winding.
_PATTERNS = {
    0b001: [(0, 3, 2), (3, 1, 2)],
    0b010: [(0, 1, 4), (0, 4, 2)],
    0b100: [(0, 1, 5), (5, 1, 2)],
    0b011: [(0, 3, 2), (3, 4, 2), (3, 1, 4)],
    0b110: [(0, 1, 5), (5, 1, 4), (5, 4, 2)],
    0b101: [(0, 3, 5), (3, 1, 5), (5, 1, 2)],
    0b111: [(0, 3, 5), (3, 1, 4), (5, 4, 2), (3, 4, 5)],
}

_ADDED_BY_PATTERN = np.array([0] + [len(_PATTERNS[p]) - 1 for p in range(1, 8)], np.int64)


def split_large_triangles(mesh, origin: np.ndarray, detail: float, budget: int, diagonal: float = np.inf) -> int:
    """Split `mesh`'s too-long edges (in place) until none is left; returns the triangles added.
    Stops (returning what it added so far plus one) once more than `budget` would be added.
    `diagonal`: of the mesh's box, where known (no edge is longer)."""
    positions, indices = mesh.positions, mesh.indices.astype(np.int64)
    normals, uvs = mesh.normals, mesh.uvs
    if not len(indices) or diagonal <= min(detail, MAX_EDGE):
        return 0  # the common case, known from the mesh's box
    if not edges_to_split(positions, indices[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), origin,
                                              detail).any():
        return 0  # the common case, without sorting the edges
    added = 0
    for _ in range(200):  # each pass halves every edge it splits: lengths fall below any limit
        edges = indices[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 3, 2)
        keys = np.sort(edges, axis=2).reshape(-1, 2)
        # an edge as one integer: np.unique on rows sorts them far slower (seconds at a million)
        n = np.int64(len(positions))
        unique_keys, inverse = np.unique(keys[:, 0] * n + keys[:, 1], return_inverse=True)
        unique = np.stack([unique_keys // n, unique_keys % n], axis=1)
        split = edges_to_split(positions, unique, origin, detail)
        if not split.any():
            break
        mask = split[inverse.reshape(-1)].reshape(-1, 3)
        pattern = mask[:, 0] * 1 + mask[:, 1] * 2 + mask[:, 2] * 4
        new_count = int(_ADDED_BY_PATTERN[pattern].sum())
        if added + new_count > budget:
            added += new_count
            break
        # one new vertex per split edge, shared by the triangles on both sides
        first_new = len(positions)
        midpoint_of = np.full(len(unique), -1, np.int64)
        midpoint_of[split] = first_new + np.arange(int(split.sum()))
        ends = unique[split]
        positions = np.concatenate([positions, 0.5 * (positions[ends[:, 0]] + positions[ends[:, 1]])])
        if normals is not None:
            n = normals[ends[:, 0]].astype(np.float64) + normals[ends[:, 1]]
            length = np.linalg.norm(n, axis=1, keepdims=True)
            n = np.where(length > 0, n / np.where(length > 0, length, 1.0), normals[ends[:, 0]])
            normals = np.concatenate([normals, n.astype(np.float32)])
        if uvs is not None:
            uvs = np.concatenate([uvs, (0.5 * (uvs[ends[:, 0]].astype(np.float64) + uvs[ends[:, 1]])).astype(np.float32)])
        corners = np.concatenate([indices, midpoint_of[inverse.reshape(-1, 3)]], axis=1)  # (T, 6)
        pieces = [indices[pattern == 0]]
        for p, subs in _PATTERNS.items():
            rows = corners[pattern == p]
            pieces += [rows[:, list(sub)] for sub in subs]
        indices = np.concatenate(pieces)
        added += new_count
    mesh.positions, mesh.indices, mesh.normals, mesh.uvs = positions, indices.astype(np.int32), normals, uvs
    return added
