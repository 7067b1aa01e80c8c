"""validate_scene: the last check between any loader (or a scene built in Python) and the GPU.

Whatever a file said, what reaches the shaders must be finite and representable: a value
that is fine in float64 can be infinite in float32 (1e39), and one infinity in a vertex or a
colour turns whole images into NaN. Triangles with non-finite vertices are dropped with a
warning (as mesh_io does for mesh files); everything else that cannot be rendered is a
SceneError naming the file and line the item came from, where the loader recorded it.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import SceneError
from .instances import check_instances
from .mesh_io import clean_triangles
from .model import MATERIAL_TYPES, Scene

FLOAT32_MAX = float(np.finfo(np.float32).max)
# Coordinates, relative to the scene's centre: squared distances and areas (products of two
# lengths) must stay far from float32's 3.4e38.
MAX_COORDINATE = 1e18
MAX_DEPTH = 1_000_000


def _where(source: str, fallback):
    """(path, line) from a 'file:line' source string."""
    if source:
        path, _, line = source.rpartition(":")
        if path and line.isdigit():
            return path, int(line)
        return source, None
    return fallback, None


def _finite(values, limit=FLOAT32_MAX) -> bool:
    a = np.asarray(values, dtype=np.float64)
    return bool(np.isfinite(a).all() and (np.abs(a) <= limit).all())


def validate_scene(scene: Scene) -> Scene:
    """Check (and clean) `scene` in place; returns it. Idempotent."""
    fallback = str(scene.path) if scene.path is not None else None

    def fail(message, source=""):
        raise SceneError(message, *_where(source, fallback))

    cam = scene.camera
    for name in ("position", "target", "up"):
        if not _finite(getattr(cam, name), MAX_COORDINATE):
            fail(f"camera {name} must be finite (|x| <= {MAX_COORDINATE:g}), got {getattr(cam, name)}")
    forward = cam.target - cam.position
    if not np.linalg.norm(forward) > 0:
        fail("camera target equals its position")
    if not np.linalg.norm(np.cross(forward, cam.up)) > 1e-12 * np.linalg.norm(forward) * np.linalg.norm(cam.up):
        fail("camera up is parallel to the viewing direction (or zero)")
    if not 0 < cam.fov_deg < 180:
        fail(f"camera field of view must be in (0, 180) degrees, got {cam.fov_deg}")
    if not (_finite(cam.aperture_radius, MAX_COORDINATE) and cam.aperture_radius >= 0):
        fail(f"camera aperture must be finite and >= 0, got {cam.aperture_radius}")
    if cam.focus_distance is not None and not (_finite(cam.focus_distance, MAX_COORDINATE)
                                               and cam.focus_distance > 0):
        fail(f"camera focus distance must be finite and > 0, got {cam.focus_distance}")

    w, h = scene.film_size
    if not (isinstance(w, (int, np.integer)) and isinstance(h, (int, np.integer)) and w > 0 and h > 0):
        fail(f"film size must be two positive integers, got {scene.film_size}")
    if not (isinstance(scene.max_depth, (int, np.integer)) and 0 <= scene.max_depth <= MAX_DEPTH):
        fail(f"max_depth must be an integer in [0, {MAX_DEPTH}], got {scene.max_depth}")
    if scene.environment is not None:
        r = scene.environment.radiance
        if r.shape != (3,) or not _finite(r) or (r < 0).any():
            fail(f"environment radiance must be 3 finite values >= 0 (at most {FLOAT32_MAX:.3g}), got {r}")

    for m in scene.materials:
        what = f"material '{m.name}'"
        if m.type not in MATERIAL_TYPES:
            fail(f"{what}: unknown type '{m.type}'", m.source)
        for field in ("base_color", "emission"):
            v = getattr(m, field)
            if v.shape != (3,) or not _finite(v) or (v < 0).any():
                fail(f"{what}: {field} must be 3 finite values >= 0 (at most {FLOAT32_MAX:.3g}), got {v}",
                     m.source)
        if not (_finite(m.alpha) and m.alpha >= 0):
            fail(f"{what}: roughness alpha must be finite and >= 0, got {m.alpha}", m.source)
        if not (_finite(m.ior) and m.ior > 0):
            fail(f"{what}: ior must be finite and > 0, got {m.ior}", m.source)
        for field in ("eta", "k"):
            v = getattr(m, field)
            if v is not None and (v.shape != (3,) or not _finite(v) or (v < 0).any()):
                fail(f"{what}: {field} must be 3 finite values >= 0, got {v}", m.source)

    count = len(scene.materials)
    for mesh in (*scene.meshes, *scene.prototypes):
        where = mesh.source or mesh.name
        if not 0 <= mesh.material < count:
            fail(f"mesh '{mesh.name}' uses material #{mesh.material}, but there are {count}", mesh.source)
        if len(mesh.indices) and (mesh.indices.min() < 0 or mesh.indices.max() >= len(mesh.positions)):
            fail(f"mesh '{mesh.name}' has vertex indices outside 0..{len(mesh.positions) - 1}", mesh.source)
        for name, arr, width in (("normals", mesh.normals, 3), ("uvs", mesh.uvs, 2)):
            if arr is not None and arr.shape != (len(mesh.positions), width):
                fail(f"mesh '{mesh.name}' has {len(arr)} {name} for {len(mesh.positions)} vertices", mesh.source)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # overflow of huge coordinates: caught below
            positions = np.where(np.abs(mesh.positions) <= MAX_COORDINATE, mesh.positions, np.nan)
        if not np.isfinite(positions).all() or (mesh.normals is not None and not np.isfinite(mesh.normals).all()):
            # Dropped with a warning, as mesh files are (beyond MAX_COORDINATE counts as Inf).
            mesh.positions, mesh.indices, mesh.normals, mesh.uvs = clean_triangles(
                positions, mesh.indices, mesh.normals, mesh.uvs, f"{where} (mesh '{mesh.name}')")
        if mesh.uvs is not None and not np.isfinite(mesh.uvs).all():
            mesh.uvs = None
    for s in scene.spheres:
        if not 0 <= s.material < count:
            fail(f"sphere uses material #{s.material}, but there are {count}", s.source)
        if not _finite(s.center, MAX_COORDINATE) or not (_finite(s.radius, MAX_COORDINATE) and s.radius > 0):
            fail(f"sphere needs a finite centre and a finite radius > 0, got {s.center}, {s.radius}", s.source)
    check_instances(scene)
    return scene
