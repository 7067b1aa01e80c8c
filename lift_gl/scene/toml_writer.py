"""Write a Scene in the native format (scenes/README.md), so that load_toml reads it back as
the same scene: `save_toml(load_scene(p), q)` then `load_scene(q)` gives equal cameras,
materials and geometry (tests/test_scene_writer.py checks it on every shipped scene).

- Objects built from a .toml table (`Mesh.authored`, `Sphere.authored`) are written as that
  table, so quads stay quads and the author's transform keys stay readable; a mesh file it
  names is re-pointed relative to the new file.
- Other meshes (pbrt, mesh files) are written as OBJ files in a folder `NAME.meshes/`
  beside the scene, and referenced: positions, uvs and triangles read back bit-exact, shading
  normals renormalised (within 1e-5) by trimesh, which reads them.
- Prototypes (meshes drawn only through instances) are written as objects with
  `prototype = true`, and each instance as an [[instances]] table with its 4x4 `transform`.
- Floats are written with Python's shortest round-trip repr, so every number reads back
  exactly.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..errors import SceneError
from .model import Mesh, Scene

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


# ---- TOML values ------------------------------------------------------------------------------
def _key(name: str) -> str:
    return name if _BARE_KEY.match(name) else '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if not np.isfinite(f):
            raise SceneError(f"cannot write the non-finite number {f} to a scene file")
        text = repr(f)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(v, np.ndarray):
        return _value(v.tolist())
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise SceneError(f"cannot write a {type(v).__name__} to a scene file")


def _table(lines: list, header: str, values: dict) -> None:
    lines.append("")
    lines.append(header)
    lines += [f"{_key(k)} = {_value(v)}" for k, v in values.items() if v is not None]


def _floats(a) -> list:
    return [float(x) for x in np.asarray(a, dtype=np.float64).ravel()]


# ---- the parts of a scene ---------------------------------------------------------------------
def _film(scene) -> dict:
    film = {"size": [int(v) for v in scene.film_size]}
    f = scene.pixel_filter
    if f is not None:
        rx, ry = (float(v) for v in f.radius)
        film.update(filter=f.kind, filter_radius=rx if rx == ry else [rx, ry])
        if f.kind == "gaussian":
            film["filter_alpha"] = float(f.alpha)
    return film


def _camera(scene: Scene) -> dict:
    c = scene.camera
    out = {"position": _floats(c.position), "target": _floats(c.target), "up": _floats(c.up),
           "fov": float(c.fov_deg)}
    if c.aperture_radius:
        out["aperture"] = float(c.aperture_radius)
    if c.focus_distance is not None:
        out["focus_distance"] = float(c.focus_distance)
    if tuple(c.shutter) != (0.0, 1.0):
        out["shutter"] = [float(t) for t in c.shutter]
    return out


def _material(m) -> dict:
    out = {"type": m.type, "color": _floats(m.base_color)}
    if m.is_emissive:
        out["emission"] = _floats(m.emission)
    if m.type != "diffuse":
        out["alpha"] = float(m.alpha)  # alpha, not roughness: it reads back bit-exact
    if m.type == "dielectric":
        out["ior"] = float(m.ior)
    if m.type == "conductor" and m.eta is not None and m.k is not None:
        out["eta"], out["k"] = _floats(m.eta), _floats(m.k)
    return out


def _unique_names(names: list[str]) -> list[str]:
    """Material names as table keys: made unique where a loader produced duplicates."""
    seen: dict[str, int] = {}
    out = []
    for name in names:
        name = name or "material"
        candidate, n = name, 1
        while candidate in seen:
            n += 1
            candidate = f"{name}_{n}"
        seen[candidate] = 1
        out.append(candidate)
    return out


def _authored_object(obj, material_name: str, source_dir: Path | None, out_dir: Path) -> dict:
    table = dict(obj.authored)
    table["material"] = material_name
    if table.get("type") == "mesh" and "file" in table:
        mesh_file = Path(table["file"])
        if not mesh_file.is_absolute():
            mesh_file = (source_dir or out_dir) / mesh_file
        table["file"] = _relative(mesh_file, out_dir)
    return table


def _relative(path: Path, start: Path) -> str:
    try:
        return Path(os.path.relpath(Path(path).resolve(), start.resolve())).as_posix()
    except ValueError:  # another drive (Windows): keep it absolute
        return Path(path).resolve().as_posix()


def write_obj(path: Path, mesh: Mesh) -> None:
    """OBJ with one position, normal and uv per vertex (the model's layout), every float in
    shortest round-trip form: positions, uvs and triangles read back bit-exact. Shading
    normals read back renormalised by trimesh (within 1e-5)."""
    def rows(tag, a):
        return [f"{tag} " + " ".join(repr(float(x)) for x in row) for row in np.asarray(a, np.float64)]

    lines = ["# written by lift-gl", *rows("v", mesh.positions)]
    if mesh.normals is not None:
        lines += rows("vn", mesh.normals)
    if mesh.uvs is not None:
        lines += rows("vt", mesh.uvs)
    corner = {(False, False): "{0}", (False, True): "{0}/{0}", (True, False): "{0}//{0}",
              (True, True): "{0}/{0}/{0}"}[(mesh.normals is not None, mesh.uvs is not None)]
    lines += ["f " + " ".join(corner.format(i) for i in tri) for tri in (mesh.indices + 1).tolist()]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def _mesh_file_name(index: int, name: str) -> str:
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name or "mesh").strip("_") or "mesh"
    return f"{index:03d}_{safe}.obj"


def save_toml(scene: Scene, path) -> Path:
    """Write `scene` to `path` (.toml); meshes that have no table go to `NAME.meshes/`."""
    path = Path(path)
    out_dir = path.parent
    out_dir.mkdir(parents=True, exist_ok=True)
    source_dir = Path(scene.path).parent if scene.path is not None else None
    origin = f" from {Path(scene.path).name}" if scene.path is not None else ""
    lines = [f"# Written by lift-gl{origin}; the format is described in scenes/README.md."]
    _table(lines, "[camera]", _camera(scene))
    _table(lines, "[film]", _film(scene))
    _table(lines, "[integrator]", {"max_depth": int(scene.max_depth)})
    if scene.environment is not None:
        _table(lines, "[environment]", {"radiance": _floats(scene.environment.radiance)})
    names = _unique_names([m.name for m in scene.materials])
    for name, material in zip(names, scene.materials):
        _table(lines, f"[materials.{_key(name)}]", _material(material))

    mesh_dir = path.with_name(path.stem + ".meshes")
    for i, mesh in enumerate(scene.meshes):
        if mesh.authored is not None:
            table = _authored_object(mesh, names[mesh.material], source_dir, out_dir)
        else:
            mesh_dir.mkdir(exist_ok=True)
            mesh_file = mesh_dir / _mesh_file_name(i, mesh.name)
            write_obj(mesh_file, mesh)
            table = {"type": "mesh", "name": mesh.name, "material": names[mesh.material],
                     "file": _relative(mesh_file, out_dir)}
            if mesh.velocity is not None:
                table["motion"] = {"translate": _floats(mesh.velocity)}
        _table(lines, "[[objects]]", table)
    for sphere in scene.spheres:
        if sphere.authored is not None:
            table = _authored_object(sphere, names[sphere.material], source_dir, out_dir)
        else:
            table = {"type": "sphere", "material": names[sphere.material],
                     "center": _floats(sphere.center), "radius": float(sphere.radius)}
            if sphere.velocity is not None:
                table["motion"] = {"translate": _floats(sphere.velocity)}
        _table(lines, "[[objects]]", table)
    drawn = {id(m) for m in scene.meshes}
    for k, mesh in enumerate(scene.prototypes):
        if id(mesh) in drawn:
            continue  # a drawn object that instances name: written above
        if mesh.authored is not None:
            table = _authored_object(mesh, names[mesh.material], source_dir, out_dir)
        else:
            mesh_dir.mkdir(exist_ok=True)
            mesh_file = mesh_dir / _mesh_file_name(len(scene.meshes) + k, mesh.name)
            write_obj(mesh_file, mesh)
            table = {"type": "mesh", "name": mesh.name, "material": names[mesh.material],
                     "file": _relative(mesh_file, out_dir)}
        table["prototype"] = True
        _table(lines, "[[objects]]", table)
    for inst in scene.instances:
        table = {"mesh": scene.prototypes[inst.mesh].name, "transform": [_floats(row) for row in inst.transform]}
        if inst.name:
            table["name"] = inst.name
        if inst.material is not None:
            table["material"] = names[inst.material]
        _table(lines, "[[instances]]", table)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
