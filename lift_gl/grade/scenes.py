"""The scenes a submission is graded on, and the analytic answer where one exists.

Built-in names (`--scenes furnace,cornell,glass`, the default):
- furnace: scenes/furnace.toml, a diffuse sphere of albedo 0.8 under a sky of radiance 1. A
  convex object under uniform light: every pixel that sees only the sphere is exactly 0.8
  (times the sky), every pixel that sees only the sky is exactly the sky. Light lost or gained
  anywhere in a path shows.
- cornell: scenes/cornell_diffuse.toml, the diffuse Cornell box: direct light, colour
  bleeding, soft shadows.
- glass: scenes/cornell.toml, the Cornell box with a glass sphere and a rough gold box:
  refraction, caustics, a glossy conductor.
Any other entry is a scene file's path.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SCENES_DIR = Path(__file__).resolve().parent.parent.parent / "scenes"
BUILTIN = {"furnace": "furnace.toml", "cornell": "cornell_diffuse.toml", "glass": "cornell.toml"}
DEFAULT_SCENES = ("furnace", "cornell", "glass")


@dataclass(frozen=True)
class GradeScene:
    name: str   # as the report names it
    path: Path


def resolve_scene(entry: str, base: Path | None = None) -> GradeScene:
    """A built-in name, or a path (relative to `base` when given, e.g. a lab's folder)."""
    from ..errors import LiftError

    if entry in BUILTIN:
        return GradeScene(entry, SCENES_DIR / BUILTIN[entry])
    path = Path(entry)
    if base is not None and not path.is_absolute():
        path = base / path
    if not path.is_file():
        raise LiftError(f"grading scene {entry!r} is neither a built-in ({', '.join(BUILTIN)}) nor a file")
    return GradeScene(path.stem, path)


def analytic_image(scene, size: tuple[int, int]) -> np.ndarray | None:
    """The exact expected image of a white furnace (diffuse spheres of one albedo under a
    constant sky, nothing else), NaN at pixels whose footprint sees both the sphere and the
    sky (their value depends on the pixel filter's integral over the edge); None for any other
    scene."""
    if not _is_furnace(scene):
        return None
    sky = np.asarray(scene.environment.radiance, np.float64)
    albedo = np.asarray(scene.materials[scene.spheres[0].material].base_color, np.float64)
    width, height = size
    radius = (0.5, 0.5) if scene.pixel_filter is None else tuple(scene.pixel_filter.radius)
    # A pixel sees what the rays through its filter's footprint see: pixel x spans positions
    # [x + 0.5 - r, x + 0.5 + r] (camera.glsl: position / resolution * 2 - 1 is the ndc).
    inside = np.ones((height, width), bool)
    outside = np.ones((height, width), bool)
    steps = 8  # points along each footprint edge; the gap between them bounds what they miss
    u = np.linspace(-1.0, 1.0, steps + 1)
    edge = np.concatenate([np.stack([u, np.full_like(u, s)], 1) for s in (-1.0, 1.0)]
                          + [np.stack([np.full_like(u, s), u], 1) for s in (-1.0, 1.0)])
    y, x = np.mgrid[0:height, 0:width]
    for sphere in scene.spheres:
        margins = []
        for offset in edge:
            px = x + 0.5 + offset[0] * radius[0]
            py = (height - 1 - y) + 0.5 + offset[1] * radius[1]  # row 0 is the top; position y is up
            margins.append(_angle_margin(scene.camera, size, px, py, sphere))
        margins = np.stack(margins)
        gap = _max_angle_between(scene.camera, size, radius, steps)
        corners_in = margins[[0, steps, steps + 1, 2 * steps + 1]]  # the four corners
        inside &= (corners_in < 0).all(axis=0)                      # disc is convex: corners suffice
        outside &= (margins > gap).all(axis=0)                      # the whole edge clear of it
    image = np.full((height, width, 3), np.nan)
    image[outside] = sky
    image[inside] = albedo * sky
    return image


def _is_furnace(scene) -> bool:
    env = scene.environment
    if env is None or env.image is not None:
        return False
    if scene.meshes or scene.prototypes or scene.instances or scene.distant_lights or not scene.spheres:
        return False
    materials = {s.material for s in scene.spheres}
    if len(materials) != 1:
        return False
    m = scene.materials[materials.pop()]
    if m.type != "diffuse" or getattr(m, "texture", None) is not None:
        return False
    if np.any(np.asarray(m.emission, np.float64) != 0):
        return False
    if scene.camera.aperture_radius > 0 or scene.has_motion:
        return False
    # Spheres must not see each other (light leaving one would reach another).
    return len(scene.spheres) == 1


def _directions(camera, size, px, py) -> np.ndarray:
    right, up, forward = camera.basis()
    t = math.tan(math.radians(camera.fov_deg) / 2)
    aspect = size[0] / size[1]
    nx, ny = px / size[0] * 2 - 1, py / size[1] * 2 - 1
    d = forward + (nx * t * aspect)[..., None] * right + (ny * t)[..., None] * up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _angle_margin(camera, size, px, py, sphere) -> np.ndarray:
    """Angle between each ray and the sphere's silhouette cone: < 0 inside it (the ray hits)."""
    to_center = sphere.center - np.asarray(camera.position, np.float64)
    distance = float(np.linalg.norm(to_center))
    half_angle = math.asin(min(1.0, sphere.radius / distance))
    cos = np.clip(_directions(camera, size, px, py) @ (to_center / distance), -1.0, 1.0)
    return np.arccos(cos) - half_angle


def _max_angle_between(camera, size, radius, steps) -> float:
    """An upper bound on the angle between neighbouring points of a footprint's edge, anywhere
    in the image (the widest at the image's centre), with a safety factor of 2."""
    cx, cy = np.array([size[0] / 2.0]), np.array([size[1] / 2.0])
    a = _directions(camera, size, cx, cy)[0]
    b = _directions(camera, size, cx + 2 * radius[0] / steps, cy + 2 * radius[1] / steps)[0]
    return 2.0 * float(np.arccos(np.clip(a @ b, -1.0, 1.0)))
