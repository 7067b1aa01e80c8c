"""validate_scene: the one check between any loader (or a scene built in Python) and the GPU.

Every loader hands its Scene here (load_scene), and so does Renderer, so a value is judged by
the same rule whatever format it came from (docs/robustness.md has the table):

- refused, a SceneError naming the file and line the item came from (where the loader
  recorded it): non-finite values anywhere; negative emission, irradiance, colours or
  complex IOR; an IOR <= 0; a camera whose basis is degenerate (up along the view, target at
  the position) or whose field of view is outside (0, 180); a bad film size or depth; an
  environment map with no finite texel; objects that float32 cannot hold beside the rest of
  the scene (precision.py);
- repaired with a warning: negative roughness (0: smooth); NaN/Inf and negative texels of an
  environment map (0); triangles with NaN/Inf vertices or a repeated corner (dropped); a
  scene with no geometry renders its environment only (warned, not refused).

A value that is fine in float64 can be infinite in float32 (1e39), and one infinity in a
vertex or a colour turns whole images into NaN: "finite" here means at most float32's max.
The loaders may call the shared checks themselves (camera_problem) where they know a better
line; they never apply rules of their own to these values.
"""
from __future__ import annotations

import warnings

import numpy as np

from .. import limits
from ..errors import SceneError
from . import precision
from .instances import check_instances
from .loader import SceneWarning
from .mesh_io import clean_triangles
from .model import MATERIAL_TYPES, Scene

FLOAT32_MAX = float(np.finfo(np.float32).max)
# Vertices beyond this (in world coordinates) are dropped as if they were Inf.
MAX_COORDINATE = precision.MAX_COORDINATE
MAX_DEPTH = 1_000_000
# Emitted radiance and irradiance: a pixel's samples are summed in float32, and two samples
# of 3e38 already overflow (an environment of 3e38 gave NaN pixels).
MAX_RADIANCE = 1e30
# The camera's up may not be closer to its view direction than this (the sine of the angle).
MIN_UP_SINE = 1e-9


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


def camera_problem(position, target, up, fov_deg=None) -> str | None:
    """What is wrong with this camera (None: nothing). Shared by every loader and by camera
    paths (lift_gl/camera_path.py): a camera that any of them accepts renders."""
    for name, v in (("position", position), ("target", target), ("up", up)):
        if not (np.shape(v) == (3,) and _finite(v, MAX_COORDINATE)):
            return f"camera {name} must be 3 finite numbers (|x| <= {MAX_COORDINATE:g}), got {np.asarray(v).tolist()}"
    forward = np.asarray(target, dtype=np.float64) - np.asarray(position, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    length, up_length = float(np.linalg.norm(forward)), float(np.linalg.norm(up))
    if not length > 0:
        return "camera target equals its position"
    if not up_length > 0 or not np.linalg.norm(np.cross(forward / length, up / up_length)) > MIN_UP_SINE:
        return f"camera up {up.tolist()} is parallel to the viewing direction {forward.tolist()} (or zero)"
    if fov_deg is not None and not (np.isfinite(fov_deg) and 0 < fov_deg < 180):
        return f"camera field of view must be in (0, 180) degrees, got {fov_deg}"
    return None


def affine_problem(m) -> str | None:
    """What keeps a 4x4 transform from being an affine map of finite numbers (None: nothing).
    Loaders bake transforms into vertices, so they check them where they read them; a
    projective one (a last row other than 0 0 0 1) is refused: it is not a rigid placement and
    cannot be applied to normals, spheres or instances."""
    m = np.asarray(m, dtype=np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        return "the transform must be a 4x4 matrix of finite numbers"
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]):
        return (f"projective transforms are not supported: the matrix's last row must be [0, 0, 0, 1] (an affine "
                f"map), got {m[3].tolist()}")
    return None


def colour_problem(value, what: str, limit: float = FLOAT32_MAX) -> str | None:
    """Colours, emission, irradiance, radiance and complex IOR: 3 finite values >= 0 (light:
    at most MAX_RADIANCE)."""
    v = np.asarray(value, dtype=np.float64)
    if v.shape != (3,) or not _finite(v, limit):
        return f"{what} must be 3 finite values (at most {limit:.3g}), got {v.tolist()}"
    if (v < 0).any():
        return f"{what} must not be negative, got {v.tolist()}"
    return None


def validate_scene(scene: Scene) -> Scene:
    """Check (and repair) `scene` in place; returns it. Idempotent."""
    fallback = str(scene.path) if scene.path is not None else None

    def fail(message, source=""):
        raise SceneError(message, *_where(source, fallback))

    def warn(message, source=""):
        path, line = _where(source, fallback)
        where = f"{path}:{line}: " if line is not None else f"{path}: " if path else ""
        # stacklevel 2: one place in this module, so that a scene validated twice (load_scene,
        # then Renderer) shows each message once
        warnings.warn(where + message, SceneWarning, stacklevel=2)

    cam = scene.camera
    problem = camera_problem(cam.position, cam.target, cam.up, cam.fov_deg)
    if problem:
        fail(problem, cam.source)
    if not (_finite(cam.aperture_radius, MAX_COORDINATE) and cam.aperture_radius >= 0):
        fail(f"camera aperture must be finite and >= 0, got {cam.aperture_radius}", cam.source)
    if cam.focus_distance is not None and not (_finite(cam.focus_distance, MAX_COORDINATE)
                                               and cam.focus_distance > 0):
        fail(f"camera focus distance must be finite and > 0, got {cam.focus_distance}", cam.source)

    w, h = scene.film_size
    if not (isinstance(w, (int, np.integer)) and isinstance(h, (int, np.integer)) and w > 0 and h > 0):
        fail(f"film size must be two positive integers, got {scene.film_size}")
    if not (isinstance(scene.max_depth, (int, np.integer)) and 0 <= scene.max_depth <= MAX_DEPTH):
        fail(f"max_depth must be an integer in [0, {MAX_DEPTH}], got {scene.max_depth}")

    _check_lights(scene, fail, warn)
    _check_materials(scene, fail, warn)
    _check_geometry(scene, fail, warn)
    check_instances(scene)
    _check_precision(scene, fail, warn)
    return scene


def _check_lights(scene: Scene, fail, warn) -> None:
    env = scene.environment
    if env is not None:
        problem = colour_problem(env.radiance, "environment radiance", MAX_RADIANCE)
        if problem:
            fail(problem, env.source)
        if env.image is not None:
            _repair_environment_image(env, fail, warn)
    for i, light in enumerate(scene.distant_lights):
        what = f"distant light #{i + 1}"
        if not (np.shape(light.direction) == (3,) and _finite(light.direction)):
            fail(f"{what}: the direction must be 3 finite numbers, not zero, got {np.asarray(light.direction).tolist()}",
                 light.source)
        problem = colour_problem(light.irradiance, f"{what}: irradiance", MAX_RADIANCE)
        if problem:
            fail(problem, light.source)


def _repair_environment_image(env, fail, warn) -> None:
    """NaN/Inf and negative texels become 0, with a warning naming the map; a map with no
    finite texel is refused (it would render as a black sky that looks deliberate)."""
    image = env.image
    name = f"environment map {env.image_file}" if env.image_file else "environment map"
    if image.ndim != 3 or image.shape[2] != 3 or not image.size:
        fail(f"{name}: must be an H x W x 3 image, got shape {image.shape}", env.source)
    if max(image.shape[:2]) > limits.MAX_ENVIRONMENT_SIDE:  # the sampler's guides are 16-bit cell numbers
        fail(f"{name}: {image.shape[1]:,}x{image.shape[0]:,} texels, over the limit "
             f"lift_gl.limits.MAX_ENVIRONMENT_SIDE = {limits.MAX_ENVIRONMENT_SIDE:,} a side", env.source)
    finite = np.isfinite(image)
    if not finite.any():
        fail(f"{name}: no texel is a finite number (all NaN or Inf)", env.source)
    bad_texels = int((~finite).any(axis=2).sum())
    negative_texels = int((finite & (image < 0)).any(axis=2).sum())
    if bad_texels or negative_texels:
        parts = [f"{bad_texels:,} texels with NaN/Inf"] if bad_texels else []
        parts += [f"{negative_texels:,} with negative values"] if negative_texels else []
        warn(f"{name}: {' and '.join(parts)} of {image.shape[0] * image.shape[1]:,}; those values are set to 0",
             env.source)
        env.image = np.where(finite & (image > 0), image, 0.0).astype(np.float32)
    with np.errstate(over="ignore"):
        brightest = float(env.image.max()) * float(np.max(env.radiance))
    if not brightest <= MAX_RADIANCE:
        fail(f"{name}: its brightest texel times the radiance scale is {brightest:.3g}, more than {MAX_RADIANCE:g}",
             env.source)


def _check_materials(scene: Scene, fail, warn) -> None:
    for m in scene.materials:
        what = f"material '{m.name}'"
        if m.type not in MATERIAL_TYPES:
            fail(f"{what}: unknown type '{m.type}'", m.source)
        for field in ("base_color", "emission", "specular"):
            problem = colour_problem(getattr(m, field), f"{what}: {field}", MAX_RADIANCE if field == "emission" else FLOAT32_MAX)
            if problem:
                fail(problem, m.source)
        if m.texture is None and max(m.base_color.max(), m.specular.max()) > 1:  # a texture may be scaled by it
            warn(f"{what}: a reflectance above 1 ({max(m.base_color.max(), m.specular.max()):g}) reflects more light "
                 "than it receives; kept, but paths through it gain energy", m.source)
        for field in ("eta", "k"):
            v = getattr(m, field)
            problem = None if v is None else colour_problem(v, f"{what}: {field}")
            if problem:
                fail(problem, m.source)
        if not _finite(m.alpha):
            fail(f"{what}: roughness (alpha) must be finite, got {m.alpha}", m.source)
        if m.alpha < 0:
            warn(f"{what}: negative roughness (alpha {m.alpha:g}); using 0, a smooth surface", m.source)
            m.alpha = 0.0
        if not (_finite(m.ior) and m.ior > 0):
            fail(f"{what}: ior must be finite and > 0, got {m.ior}", m.source)


def _check_geometry(scene: Scene, fail, warn) -> None:
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
        if mesh.velocity is not None and not _finite(mesh.velocity, MAX_COORDINATE):
            fail(f"mesh '{mesh.name}': its velocity must be finite, got {mesh.velocity.tolist()}", mesh.source)
        positions = mesh.positions
        with np.errstate(invalid="ignore"):  # NaN compares False: caught below
            within = np.abs(positions) <= MAX_COORDINATE
        if not within.all():
            positions = np.where(within, positions, np.nan)
        # NaN/Inf (and beyond MAX_COORDINATE) vertices, repeated corners, NaN normals: dropped
        # or flattened with a warning, as mesh files' are; zero-area triangles are kept (no ray hits them).
        mesh.positions, mesh.indices, mesh.normals, mesh.uvs = clean_triangles(
            positions, mesh.indices, mesh.normals, mesh.uvs, f"{where} (mesh '{mesh.name}')")
        if mesh.uvs is not None and not np.isfinite(mesh.uvs).all():
            warn(f"mesh '{mesh.name}': NaN/Inf texture coordinates; it is drawn without them (its texture's "
                 "corner texel)", mesh.source)
            mesh.uvs = None
    if scene.spheres and _spheres_sound(scene.spheres, count):
        return
    for s in scene.spheres:   # the first unsound one, with its message
        if not 0 <= s.material < count:
            fail(f"sphere uses material #{s.material}, but there are {count}", s.source)
        if not _finite(s.center, MAX_COORDINATE) or not (_finite(s.radius, MAX_COORDINATE) and s.radius > 0):
            fail(f"sphere needs a finite centre and a finite radius > 0, got {s.center}, {s.radius}", s.source)
        if s.velocity is not None and not _finite(s.velocity, MAX_COORDINATE):
            fail(f"sphere: its velocity must be finite, got {s.velocity.tolist()}", s.source)


def _spheres_sound(spheres, count: int) -> bool:
    """Whether every sphere passes the checks below, all at once (a scene of 40,000 instanced
    spheres took seconds one by one)."""
    try:
        material = np.fromiter((s.material for s in spheres), dtype=np.int64, count=len(spheres))
        numbers = np.array([(*s.center, s.radius) for s in spheres], dtype=np.float64).reshape(len(spheres), 4)
        moving = [s.velocity for s in spheres if s.velocity is not None]
    except (TypeError, ValueError, OverflowError):   # a value of the wrong kind or shape: the loop says which
        return False
    return bool(((material >= 0) & (material < count)).all() and _finite(numbers, MAX_COORDINATE)
                and (numbers[:, 3] > 0).all() and (not moving or _finite(np.array(moving, dtype=np.float64),
                                                                        MAX_COORDINATE)))


def _check_precision(scene: Scene, fail, warn) -> None:
    """The GPU's origin, huge triangles split, objects float32 cannot hold refused
    (precision.py); an empty scene warned about."""
    extents = precision.object_extents(scene)
    if not extents:
        warn("the scene has no geometry (no mesh, sphere or instance with a triangle): the image shows only "
             "the environment and distant lights reach nothing")
        scene.gpu_origin = None
        return
    span = precision.span(extents)
    if span < precision.MIN_EXTENT:
        fail(f"the scene is only {span:.3g} across: lift-gl needs at least {precision.MIN_EXTENT:.3g} "
             "(the squares of squared lengths must stay within float32's range); scale it up")
    origin, unheld = precision.choose_origin(scene, extents)
    if unheld:
        worst = unheld[0]
        fail(worst.message(span), worst.extent.source)
    scene.gpu_origin = origin
    centre = precision.bounds_centre(extents) if origin is None else origin
    problem = precision.sphere_problem(scene, extents, centre)
    if problem:
        fail(*problem)
    detail = precision.DETAIL_SPAN * precision.smallest_size(extents)
    added = 0
    for e in extents:
        if e.mesh is None:
            continue
        mesh = e.mesh
        added += precision.split_large_triangles(mesh, centre, detail, precision.MAX_SPLIT_TRIANGLES - added,
                                                 float(np.linalg.norm(e.hi - e.lo)))
        if added > precision.MAX_SPLIT_TRIANGLES:
            fail(f"mesh '{mesh.name}': its triangles are too large for the rest of the scene (float32 would lose "
                 f"the hits near the smaller objects) and splitting them would take more than "
                 f"{precision.MAX_SPLIT_TRIANGLES:,} triangles (lift_gl.scene.precision.MAX_SPLIT_TRIANGLES)",
                 mesh.source)
