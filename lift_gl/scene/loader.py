"""load_scene(path): pick the loader by file extension, and the helpers loaders share.

- .toml: the native format (toml_loader, documented in scenes/README.md)
- .pbrt: a pbrt-v3 subset (pbrt_loader)
- .xml: Mitsuba 3 (and 0.5/0.6) XML (mitsuba_loader)
- .gltf .glb: glTF 2.0 (gltf_loader): meshes, materials, base colour textures, camera,
  directional lights; a white sky where the file has no light
- .obj .ply: one mesh, wrapped in a scene with a camera framing it, a grey diffuse
  material and a constant white environment (radiance 1) to light it
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..accel.bvh import bounds_of
from ..errors import LiftError, SceneError
from .model import Camera, Environment, Material, Scene


class SceneWarning(UserWarning):
    """Something in a scene file was ignored or approximated; the message names file:line."""


def warn_at(path, line: int | None, message: str) -> None:
    where = f"{path}:{line}: " if line is not None else f"{path}: "
    warnings.warn(where + message, SceneWarning, stacklevel=3)


def load_scene(path) -> Scene:
    """The scene in `path`, validated (scene/validate.py). Every failure is one SceneError
    naming the file, and the line where the loader knows it."""
    path = Path(path)
    if not path.is_file():
        raise SceneError("scene file not found", path)
    try:
        # Arithmetic on hostile values (1e200 * 1e200) gives Inf or NaN silently: validation
        # refuses what is not finite, with file and line, instead of numpy's warnings: the
        # ufuncs', and the RuntimeWarnings numpy issues itself inside the libraries we call
        # (one reached the user from 17 of 10,000 fuzzed OBJ files).
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=RuntimeWarning)
            scene = _load(path, path.suffix.lower())
            from .validate import validate_scene
            return validate_scene(scene)
    except LiftError:
        raise
    except RecursionError:
        raise SceneError("nested too deeply to read", path) from None
    except MemoryError:
        raise SceneError("too large to read into memory", path) from None
    except Exception as exc:  # a case no loader foresaw: still one line, and marked as a bug
        raise internal_error(exc, path) from exc


def internal_error(exc: Exception, path, line=None) -> SceneError:
    text = " ".join(str(exc).split())[:200]
    err = SceneError(f"could not read this file (unexpected {type(exc).__name__}: {text}; "
                     "this is a lift-gl bug, please report it with the file)", path, line)
    err.internal = True
    return err


def _load(path: Path, ext: str) -> Scene:
    if ext == ".toml":
        from .toml_loader import load_toml
        scene = load_toml(path)
    elif ext == ".pbrt":
        from .pbrt_loader import load_pbrt
        scene = load_pbrt(path)
    elif ext in (".glb", ".gltf"):
        from .gltf_loader import load_gltf
        scene = load_gltf(path)
    elif ext in (".obj", ".ply"):
        scene = _load_single_mesh(path)
    elif ext == ".xml":
        from .mitsuba_loader import load_mitsuba
        scene = load_mitsuba(path)
    else:
        raise SceneError(f"unknown scene format '{ext}' (use .toml, .pbrt, .xml, .gltf, .glb, "
                         ".obj or .ply)", path)
    scene.path = path
    return scene


def _load_single_mesh(path: Path) -> Scene:
    from .mesh_io import load_mesh_file
    mesh = load_mesh_file(path, material=0)
    scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0]),
                  materials=[Material("default", "diffuse", source=str(path))],
                  meshes=[mesh],
                  # Mesh files carry no lights we read, so light them from everywhere.
                  environment=Environment([1.0, 1.0, 1.0]))
    scene.camera = framing_camera(scene)
    return scene


def geometry_boxes(scene: Scene) -> tuple[list, list]:
    """The (min, max) corners of each mesh and sphere, as two lists (instances not included)."""
    boxes = [bounds_of(m.positions) for m in scene.meshes if len(m.positions)]
    boxes += [(s.center - s.radius, s.center + s.radius) for s in scene.spheres]
    return [b[0] for b in boxes], [b[1] for b in boxes]


def scene_bounds(scene: Scene):
    """(min, max) corners of all geometry, or None for an empty scene."""
    lo, hi = geometry_boxes(scene)
    if scene.instances:
        from .instances import instance_world_bounds  # late: instances imports the loaders' model

        box = instance_world_bounds(scene, list(range(len(scene.instances))))
        if box is not None:
            lo.append(box[0])
            hi.append(box[1])
    if not lo:
        return None
    return np.min(lo, axis=0).astype(np.float64), np.max(hi, axis=0).astype(np.float64)


def framing_camera(scene: Scene, fov_deg: float = 40.0) -> Camera:
    """Look at the bounding box from the front (+z), a little above, so that its bounding
    sphere fills most of the vertical field of view."""
    bounds = scene_bounds(scene)
    if bounds is None:
        return Camera(position=[0, 0, 5], target=[0, 0, 0], fov_deg=fov_deg)
    lo, hi = bounds
    center = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6)
    distance = 1.1 * radius / np.sin(np.radians(fov_deg) / 2)
    direction = np.array([0.0, 0.25, 1.0])
    direction /= np.linalg.norm(direction)
    return Camera(position=center + distance * direction, target=center, fov_deg=fov_deg)
