"""Live scene edits (the viewer's Edit panel): lights' radiance, colour, size and position;
materials' colour and roughness. Plain numpy on the Scene model, no GL.

Every edit returns what it changed, so the Renderer updates only that much on the GPU
(`Renderer.update_scene`): MATERIALS (rewrite the materials buffer), LIGHTS (emission: the
emitter table too) or GEOMETRY (re-pack, rebuild the BVH).

Objects that came from a .toml table (`authored`) are edited through that table (its
`translate` and `scale`) and rebuilt by the loader's own code, so what the viewer shows is
exactly what `save_toml` writes and a later load reads. Other objects (pbrt, mesh files)
have their vertices transformed.
"""
from __future__ import annotations

import copy
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LiftError
from .loader import SceneWarning
from .model import Material, Mesh, Scene, Sphere

MATERIALS, LIGHTS, GEOMETRY = "materials", "lights", "geometry"
MIN_SCALE = 1e-3  # an object scaled below this (relative to its size) would vanish


@dataclass(frozen=True)
class ObjectRef:
    """One object of a scene: a mesh or a sphere, by its index in that list."""

    kind: str  # "mesh" or "sphere"
    index: int


def object_of(scene: Scene, ref: ObjectRef) -> Mesh | Sphere:
    return (scene.meshes if ref.kind == "mesh" else scene.spheres)[ref.index]


def all_objects(scene: Scene) -> list[ObjectRef]:
    return ([ObjectRef("mesh", i) for i in range(len(scene.meshes))]
            + [ObjectRef("sphere", i) for i in range(len(scene.spheres))])


def object_name(scene: Scene, ref: ObjectRef) -> str:
    obj = object_of(scene, ref)
    if obj.authored and obj.authored.get("name"):
        return str(obj.authored["name"])
    if isinstance(obj, Mesh) and obj.name:
        return obj.name
    return f"{ref.kind} {ref.index + 1}"


def emitters(scene: Scene) -> list[ObjectRef]:
    """Objects whose material emits light."""
    return [ref for ref in all_objects(scene) if scene.materials[object_of(scene, ref).material].is_emissive]


def object_bounds(scene: Scene, ref: ObjectRef) -> tuple[np.ndarray, np.ndarray]:
    obj = object_of(scene, ref)
    if isinstance(obj, Sphere):
        return obj.center - obj.radius, obj.center + obj.radius
    p = obj.positions.astype(np.float64)
    return p.min(axis=0), p.max(axis=0)


def object_center(scene: Scene, ref: ObjectRef) -> np.ndarray:
    lo, hi = object_bounds(scene, ref)
    return 0.5 * (lo + hi)


def facing(scene: Scene, ref: ObjectRef) -> np.ndarray | None:
    """The direction a flat object faces (a quad light), or None for a solid one: the mouse
    moves a flat light in its own plane."""
    obj = object_of(scene, ref)
    if isinstance(obj, Sphere) or not len(obj.indices):
        return None
    p = obj.positions.astype(np.float64)[obj.indices]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    total = n.sum(axis=0)
    length = np.linalg.norm(total)
    if length == 0 or length < 0.999 * np.linalg.norm(n, axis=1).sum():  # not one plane facing one way
        return None
    return total / length


# ---- geometry ----------------------------------------------------------------------------------
def _rebuild(scene: Scene, ref: ObjectRef, table: dict) -> None:
    """Replace the object by what `table` describes (as the .toml loader builds it)."""
    from .toml_loader import build_object

    obj = object_of(scene, ref)
    table["material"] = scene.materials[obj.material].name
    with warnings.catch_warnings():  # the table's warnings (unknown keys) were given at load time
        warnings.simplefilter("ignore", SceneWarning)
        built = build_object(table, scene, scene.path or Path("edited.toml"))
    built.material = obj.material  # by index: material names need not be unique in memory
    (scene.meshes if ref.kind == "mesh" else scene.spheres)[ref.index] = built


def _as_vec3(v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return np.full(3, float(a)) if a.ndim == 0 else a.reshape(3)


def move_object(scene: Scene, ref: ObjectRef, delta) -> str:
    """Translate by `delta` (world units)."""
    delta = np.asarray(delta, dtype=np.float64).reshape(3)
    obj = object_of(scene, ref)
    if obj.authored is not None:
        table = copy.deepcopy(obj.authored)
        table["translate"] = (_as_vec3(table.get("translate", 0.0)) + delta).tolist()
        _rebuild(scene, ref, table)
    elif isinstance(obj, Sphere):
        obj.center = obj.center + delta
    else:
        obj.positions = (obj.positions.astype(np.float64) + delta).astype(np.float32)
    return GEOMETRY


def scale_object(scene: Scene, ref: ObjectRef, factor: float) -> str:
    """Scale by `factor` about the object's centre (a light's size; its radiance stays, so
    its power grows with its area)."""
    factor = float(factor)
    if not factor > 0 or not np.isfinite(factor):
        raise LiftError(f"a scale factor must be positive, not {factor}")
    center = object_center(scene, ref)
    obj = object_of(scene, ref)
    if obj.authored is not None:
        # new = c + f (T R S p - c) = T' R S' p with S' = f S, T' = f t + (1 - f) c
        table = copy.deepcopy(obj.authored)
        scale = table.get("scale", 1.0)
        table["scale"] = (float(scale) * factor if np.ndim(scale) == 0 else (_as_vec3(scale) * factor).tolist())
        table["translate"] = (factor * _as_vec3(table.get("translate", 0.0)) + (1.0 - factor) * center).tolist()
        _rebuild(scene, ref, table)
    elif isinstance(obj, Sphere):
        obj.radius = obj.radius * factor
    else:
        p = obj.positions.astype(np.float64)
        obj.positions = (center + factor * (p - center)).astype(np.float32)
    return GEOMETRY


# ---- materials ---------------------------------------------------------------------------------
def _users(scene: Scene, material: int) -> list[ObjectRef]:
    return [ref for ref in all_objects(scene) if object_of(scene, ref).material == material]


def own_material(scene: Scene, ref: ObjectRef) -> int:
    """The object's material index, first copied for it alone if other objects share it
    (editing one lamp must not change every lamp); the copy is named after the object."""
    obj = object_of(scene, ref)
    if len(_users(scene, obj.material)) == 1:
        return obj.material
    original = scene.materials[obj.material]
    names = {m.name for m in scene.materials}
    base = f"{original.name}_{object_name(scene, ref)}".replace(" ", "_")
    name, n = base, 1
    while name in names:
        n += 1
        name = f"{base}_{n}"
    scene.materials.append(copy.deepcopy(original))
    scene.materials[-1].name = name
    obj.material = len(scene.materials) - 1
    if obj.authored is not None:
        obj.authored["material"] = name
    return obj.material


def light_of(scene: Scene, ref: ObjectRef) -> tuple[float, np.ndarray]:
    """(radiance, colour) of an emitter: emission = radiance * colour, colour's largest
    component 1."""
    emission = scene.materials[object_of(scene, ref).material].emission
    radiance = float(emission.max())
    return radiance, (emission / radiance if radiance > 0 else np.ones(3))


def set_light(scene: Scene, ref: ObjectRef, radiance: float, colour) -> str:
    """Set an emitter's emission to radiance * colour (its own material: see own_material)."""
    colour = np.clip(np.asarray(colour, dtype=np.float64).reshape(3), 0.0, None)
    if not (np.isfinite(radiance) and radiance >= 0 and np.isfinite(colour).all()):
        raise LiftError(f"a light's radiance must be finite and non-negative, not {radiance}")
    material = scene.materials[own_material(scene, ref)]
    material.emission = float(radiance) * colour
    return LIGHTS


def set_material_colour(scene: Scene, index: int, colour) -> str:
    colour = np.asarray(colour, dtype=np.float64).reshape(3)
    if not (np.isfinite(colour).all() and (colour >= 0).all()):
        raise LiftError(f"a colour must be finite and non-negative, not {colour.tolist()}")
    scene.materials[index].base_color = colour
    return MATERIALS


def roughness_of(material: Material) -> float:
    """Perceptual roughness, as scene files write it (alpha = roughness^2)."""
    return float(np.sqrt(material.alpha))


def set_material_roughness(scene: Scene, index: int, roughness: float) -> str:
    material = scene.materials[index]
    if material.type == "diffuse":
        raise LiftError(f"material {material.name!r} is diffuse: it has no roughness")
    if not (np.isfinite(roughness) and 0 <= roughness <= 1):
        raise LiftError(f"roughness must be in [0, 1], not {roughness}")
    material.alpha = float(roughness) ** 2
    return MATERIALS
