"""What differs between two scenes, in words: for round-trip tests of the scene writer and for
telling a user what an edit changed. Arrays are compared exactly (no tolerance): a scene
written and read back must be the same scene, bit for bit."""
from __future__ import annotations

import numpy as np

from .model import Scene


def _same(a, b, atol: float = 0.0) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return False
    return bool(np.array_equal(a, b)) if atol == 0 else bool(np.allclose(a, b, rtol=0.0, atol=atol))


def _fields(label: str, a, b, names, atol: dict | None = None) -> list[str]:
    out = []
    for name in names:
        x, y = getattr(a, name), getattr(b, name)
        if not _same(x, y, (atol or {}).get(name, 0.0)):
            detail = "" if isinstance(x, np.ndarray) and x.size > 6 else f" {x!r} != {y!r}"
            out.append(f"{label}: {name} differs{detail}")
    return out


def scene_differences(a: Scene, b: Scene, normals_atol: float = 0.0) -> list[str]:
    """Empty when the scenes render the same: camera, film, depth, environment, materials,
    meshes and spheres (names, file positions and authoring tables are not compared).
    `normals_atol`: shading normals may differ by this much (meshes that went through a
    mesh file, whose reader renormalises them)."""
    out = _fields("camera", a.camera, b.camera,
                  ("position", "target", "up", "fov_deg", "aperture_radius", "focus_distance", "shutter"))
    if tuple(a.film_size) != tuple(b.film_size):
        out.append(f"film size {a.film_size} != {b.film_size}")
    fa, fb = (None if f is None else (f.kind, tuple(f.radius), f.alpha) for f in (a.pixel_filter, b.pixel_filter))
    if fa != fb:
        out.append(f"pixel filter {fa} != {fb}")
    if a.max_depth != b.max_depth:
        out.append(f"max_depth {a.max_depth} != {b.max_depth}")
    if not _same(a.environment.radiance if a.environment else None,
                 b.environment.radiance if b.environment else None):
        out.append("environment differs")
    if len(a.materials) != len(b.materials):
        out.append(f"{len(a.materials)} materials != {len(b.materials)}")
    for i, (ma, mb) in enumerate(zip(a.materials, b.materials)):
        out += _fields(f"material {i} ({ma.name})", ma, mb, ("type", "base_color", "alpha", "eta", "k", "ior", "emission"))
    if len(a.meshes) != len(b.meshes):
        out.append(f"{len(a.meshes)} meshes != {len(b.meshes)}")
    for i, (ma, mb) in enumerate(zip(a.meshes, b.meshes)):
        out += _fields(f"mesh {i} ({ma.name})", ma, mb, ("positions", "indices", "material", "normals", "uvs", "velocity"),
                       {"normals": normals_atol})
    if len(a.spheres) != len(b.spheres):
        out.append(f"{len(a.spheres)} spheres != {len(b.spheres)}")
    for i, (sa, sb) in enumerate(zip(a.spheres, b.spheres)):
        out += _fields(f"sphere {i}", sa, sb, ("center", "radius", "material", "velocity"))
    return out
