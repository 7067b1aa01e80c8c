"""The native scene format (TOML), documented with an example in scenes/README.md.

tomllib gives values without positions, so a SourceMap scans the text for table headers
and `key =` lines; every error and warning then names file:line.
"""
from __future__ import annotations

import copy
import math
import re
import tomllib
from pathlib import Path

import numpy as np

from ..errors import SceneError, read_utf8
from . import primitives as prim
from .loader import framing_camera, warn_at
from .mesh_io import load_mesh_file
from .instances import check_transform
from .model import Camera, DistantLight, Environment, Instance, Material, Scene, film_filter
from .texture_files import TextureLibrary, read_environment_image
from .validate import camera_problem

# RGB complex indices of refraction (eta, k) at roughly 650/550/450 nm.
METALS = {
    "gold": ((0.143119, 0.374957, 1.442479), (3.983160, 2.385721, 1.603215)),
    "silver": ((0.155265, 0.116723, 0.138342), (4.828350, 3.122250, 2.146960)),
    "copper": ((0.200438, 0.924033, 1.102212), (3.912949, 2.452848, 2.142188)),
    "aluminium": ((1.657460, 0.880369, 0.521229), (9.223869, 6.269523, 4.837001)),
    "chrome": ((4.369683, 2.916703, 1.654701), (5.206434, 4.231365, 3.754947)),
}
METALS["aluminum"] = METALS["aluminium"]

TOP_KEYS = {"camera", "film", "integrator", "environment", "materials", "objects", "lights", "instances"}
CAMERA_KEYS = {"position", "target", "up", "fov", "aperture", "focus_distance", "shutter"}
MATERIAL_KEYS = {
    "diffuse": {"type", "color", "emission", "texture"},
    "conductor": {"type", "color", "emission", "roughness", "alpha", "eta", "k", "metal", "texture"},
    "dielectric": {"type", "color", "emission", "roughness", "alpha", "ior"},
    "plastic": {"type", "color", "emission", "roughness", "alpha", "ior", "nonlinear", "texture"},
}
OBJECT_KEYS = {
    "mesh": {"file"},
    "quad": {"corner", "center", "u", "v"},
    "box": {"center", "size"},
    "sphere": {"center", "radius"},
}
OBJECT_COMMON = {"type", "material", "name", "translate", "rotate", "scale", "motion", "prototype"}
INSTANCE_KEYS = {"mesh", "name", "material", "translate", "rotate", "scale", "transform"}
MOTION_KEYS = {"translate"}


class SourceMap:
    """Line numbers of table headers and keys, found by scanning the TOML text."""

    _header = re.compile(r"^\s*(\[\[?)\s*(.+?)\s*\]\]?\s*(#.*)?$")
    _key = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_\-]+)\s*(\.|=)""")

    def __init__(self, text: str):
        self.tables = [{"name": (), "array": False, "line": 1, "keys": {}}]
        depth = 0  # open brackets of a multi-line array value: its lines are not headers
        for number, line in enumerate(text.splitlines(), start=1):
            code = _strip_comment(line)
            if depth == 0:
                h = self._header.match(line)
                if h:
                    name = tuple(_unquote(p) for p in _split_dotted(h.group(2)))
                    self.tables.append({"name": name, "array": h.group(1) == "[[",
                                        "line": number, "keys": {}})
                    continue
                k = self._key.match(line)
                if k:
                    self.tables[-1]["keys"].setdefault(_unquote(k.group(1)), number)
                    code = code.split("=", 1)[1] if "=" in code else ""
            depth = max(0, depth + code.count("[") - code.count("]"))

    def table(self, name: tuple, index: int | None = None):
        matches = [t for t in self.tables if t["name"] == name and t["array"] == (index is not None)]
        if index is not None:
            return matches[index] if index < len(matches) else None
        return matches[0] if matches else None

    def line(self, name: tuple, index: int | None = None, key: str | None = None):
        t = self.table(name, index)
        if t is None:
            # An inline table (`gold = { ... }`) inside its parent: use the parent's key line.
            if len(name) > 1 and index is None:
                return self.line(name[:-1], None, name[-1])
            return None
        if key is not None and key in t["keys"]:
            return t["keys"][key]
        if key is not None:  # a table written as a header ([key] or [key.sub]): the header's line
            header = next((u for u in self.tables if u["name"][:len(name) + 1] == (*name, key)), None)
            if header is not None:
                return header["line"]
        return t["line"]


def _strip_comment(line: str) -> str:
    out, quote = [], None
    for ch in line:
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            break
        else:
            out.append(ch)
    return "".join(out)


def _split_dotted(s: str):
    return [p.strip() for p in re.findall(r"""\s*("[^"]*"|'[^']*'|[^.]+)\s*(?:\.|$)""", s)]


def _unquote(s: str) -> str:
    s = s.strip()
    return s[1:-1] if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'" else s


class _Reader:
    """Typed access to one table's values; errors and warnings point at the key's line."""

    def __init__(self, ctx, data: dict, table: tuple, index: int | None, label: str):
        self.ctx, self.data, self.table, self.index, self.label = ctx, data, table, index, label

    def line(self, key=None):
        return self.ctx.smap.line(self.table, self.index, key)

    def error(self, key, msg):
        raise SceneError(msg, self.ctx.path, self.line(key))

    def has(self, key):
        return key in self.data

    def check_keys(self, allowed: set, elsewhere: set = frozenset(), kind: str = ""):
        for key in self.data:
            if key in allowed:
                continue
            if key in elsewhere:
                warn_at(self.ctx.path, self.line(key), f"'{key}' has no effect on {kind} in "
                        f"{self.label}; ignored")
            else:
                warn_at(self.ctx.path, self.line(key), f"unknown key '{key}' in {self.label}; "
                        f"ignored (expected one of: {', '.join(sorted(allowed))})")

    def number(self, key, default=None, minimum=None, positive=False):
        if key not in self.data:
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.error(key, f"'{key}' in {self.label} must be a number, not {_show(v)}")
        if positive and not v > 0:
            self.error(key, f"'{key}' in {self.label} must be positive, got {v}")
        if minimum is not None and v < minimum:
            self.error(key, f"'{key}' in {self.label} must be at least {minimum}, got {v}")
        return float(v)

    def integer(self, key, default=None, minimum=0):
        if key not in self.data:
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < minimum:
            self.error(key, f"'{key}' in {self.label} must be an integer >= {minimum}, "
                       f"not {_show(v)}")
        return v

    def boolean(self, key, default=False):
        if key not in self.data:
            return default
        v = self.data[key]
        if not isinstance(v, bool):
            self.error(key, f"'{key}' in {self.label} must be true or false, not {_show(v)}")
        return v

    def string(self, key, default=None):
        if key not in self.data:
            return default
        v = self.data[key]
        if not isinstance(v, str):
            self.error(key, f"'{key}' in {self.label} must be a string, not {_show(v)}")
        return v

    def vec3(self, key, default=None, scalar_ok=False):
        if key not in self.data:
            return None if default is None else np.asarray(default, dtype=np.float64)
        v = self.data[key]
        if scalar_ok and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v, v, v]
        ok = (isinstance(v, list) and len(v) == 3
              and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v))
        if not ok:
            shape = "a number or " if scalar_ok else ""
            self.error(key, f"'{key}' in {self.label} must be {shape}a list of 3 numbers, "
                       f"not {_show(v)}")
        a = np.asarray(v, dtype=np.float64)
        if not np.isfinite(a).all():
            self.error(key, f"'{key}' in {self.label} must be finite, got {v}")
        return a  # signs and ranges: validate_scene's rules, the same for every format


class _InlineReader(_Reader):
    """A table written inline as one key's value (`motion = { ... }`): its keys have no
    lines of their own, so messages point at the parent key's line."""

    def __init__(self, parent: _Reader, key: str, data: dict):
        super().__init__(parent.ctx, data, parent.table, parent.index, f"'{key}' of {parent.label}")
        self.parent, self.key = parent, key

    def line(self, key=None):
        return self.parent.line(self.key)


def _show(v) -> str:
    text = repr(v)
    return f"{type(v).__name__} {text if len(text) < 40 else text[:37] + '...'}"


class _Context:
    def __init__(self, path: Path, smap: SourceMap):
        self.path, self.smap = path, smap

    def reader(self, data, table, index=None, label=None):
        if not isinstance(data, dict):
            raise SceneError(f"'{'.'.join(table)}' must be a table", self.path,
                             self.smap.line(table[:-1], None, table[-1]) if len(table) > 1
                             else self.smap.line((), None, table[0]))
        return _Reader(self, data, table, index, label or f"[{'.'.join(table)}]")


def load_toml(path: Path) -> Scene:
    path = Path(path)
    text = read_utf8(path, SceneError)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(e))
        line = int(m.group(1)) if m else getattr(e, "lineno", None)
        if line is None and "end of document" in str(e):  # unclosed at the end: its last line
            line = max(len(text.splitlines()), 1)
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(e))
        if m:
            message += f" (column {m.group(2)})"
        raise SceneError(f"TOML syntax error: {message}", path, line) from None
    ctx = _Context(path, SourceMap(text))
    top = ctx.reader(doc, (), label="the scene file")
    top.check_keys(TOP_KEYS)

    scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0]))
    if "film" in doc:
        _read_film(ctx, doc["film"], scene)
    if "integrator" in doc:
        r = ctx.reader(doc["integrator"], ("integrator",))
        r.check_keys({"max_depth"})
        scene.max_depth = r.integer("max_depth", scene.max_depth)
    if "environment" in doc:
        scene.environment = _read_environment(ctx, doc["environment"])
    lights = doc.get("lights", [])
    if not isinstance(lights, list):
        raise SceneError("'lights' must be an array of tables: write [[lights]]", path,
                         ctx.smap.line((), None, "lights"))
    for i, light in enumerate(lights):
        scene.distant_lights.append(_read_light(ctx, i, light))
    materials = ctx.reader(doc.get("materials", {}), ("materials",))
    textures = TextureLibrary(scene)
    for name, table in materials.data.items():
        scene.materials.append(_read_material(ctx, name, table, textures))
    objects = doc.get("objects", [])
    if not isinstance(objects, list):
        raise SceneError("'objects' must be an array of tables: write [[objects]]", path,
                         ctx.smap.line((), None, "objects"))
    for i, obj in enumerate(objects):
        _read_object(ctx, i, obj, scene)
    instances = doc.get("instances", [])
    if not isinstance(instances, list):
        raise SceneError("'instances' must be an array of tables: write [[instances]]", path,
                         ctx.smap.line((), None, "instances"))
    for i, table in enumerate(instances):
        _read_instance(ctx, i, table, scene)
    if "camera" in doc:
        scene.camera = _read_camera(ctx, doc["camera"])
    else:
        scene.camera = framing_camera(scene)
    return scene


def _read_film(ctx, data, scene):
    r = ctx.reader(data, ("film",))
    r.check_keys({"size", "filter", "filter_radius", "filter_alpha"})
    _read_pixel_filter(r, scene)
    if r.has("size"):
        v = r.data["size"]
        if not (isinstance(v, list) and len(v) == 2 and all(
                isinstance(x, int) and not isinstance(x, bool) and x > 0 for x in v)):
            r.error("size", f"'size' in [film] must be [width, height] in pixels, not {_show(v)}")
        scene.film_size = (v[0], v[1])


FILTER_RADIUS = {"box": 0.5, "triangle": 1.0, "gaussian": 2.0}  # defaults, in the film's pixels


def _read_pixel_filter(r, scene):
    """[film] filter = "box" | "triangle" | "gaussian", filter_radius (film pixels), filter_alpha."""
    kind = r.string("filter", None)
    if kind is None:
        for key in ("filter_radius", "filter_alpha"):
            if r.has(key):
                r.error(key, f"'{key}' in [film] needs 'filter'")
        return
    if kind not in FILTER_RADIUS:
        r.error("filter", f"unknown pixel filter '{kind}' in [film] (expected one of: {', '.join(FILTER_RADIUS)})")
    value = r.data.get("filter_radius", FILTER_RADIUS[kind])
    radius = tuple(value) if isinstance(value, list) else (value, value)
    if not (len(radius) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                     and math.isfinite(v) and v > 0 for v in radius)):
        r.error("filter_radius", f"'filter_radius' in [film] must be a positive number or [x, y], not {_show(value)}")
    alpha = r.number("filter_alpha", 2.0, positive=True)
    scene.pixel_filter = film_filter(kind, radius, alpha, source=f"{r.ctx.path}:{r.line('filter')}")


def _read_camera(ctx, data) -> Camera:
    r = ctx.reader(data, ("camera",))
    r.check_keys(CAMERA_KEYS)
    for key in ("position", "target"):
        if not r.has(key):
            r.error(None, f"[camera] needs '{key}'")
    position, target = r.vec3("position"), r.vec3("target")
    up = r.vec3("up", [0, 1, 0])
    problem = camera_problem(position, target, up)
    if problem:
        r.error("up" if "parallel" in problem else "target", problem)
    fov = r.number("fov", 40.0, positive=True)
    if fov >= 180:
        r.error("fov", f"'fov' must be below 180 degrees, got {fov}")
    return Camera(position=position, target=target, up=up, fov_deg=fov,
                  aperture_radius=r.number("aperture", 0.0, minimum=0.0),
                  focus_distance=r.number("focus_distance", None, positive=True),
                  shutter=_read_shutter(r), source=f"{ctx.path}:{r.line()}")


def _read_shutter(r) -> tuple[float, float]:
    if not r.has("shutter"):
        return Camera.shutter
    v = r.data["shutter"]
    ok = (isinstance(v, list) and len(v) == 2
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v))
    if not ok or not np.isfinite(v).all():
        r.error("shutter", f"'shutter' in [camera] must be [open, close] (two finite times), not {_show(v)}")
    if v[1] < v[0]:
        r.error("shutter", f"'shutter' in [camera] closes before it opens: {v}")
    return float(v[0]), float(v[1])


def _read_motion(r):
    """An object's `motion = { translate = [x, y, z] }`: its velocity, world units per unit
    of time (it is where the object's other keys put it at time 0)."""
    if not r.has("motion"):
        return None
    data = r.data["motion"]
    if not isinstance(data, dict):
        r.error("motion", f"'motion' in {r.label} must be a table such as "
                f"motion = {{ translate = [1, 0, 0] }}, not {_show(data)}")
    m = _InlineReader(r, "motion", data)
    m.check_keys(MOTION_KEYS)
    if not m.has("translate"):
        m.error("translate", f"'motion' in {r.label} needs 'translate' (world units per unit of time)")
    return m.vec3("translate")


def _read_environment(ctx, data) -> Environment:
    r = ctx.reader(data, ("environment",))
    r.check_keys({"radiance", "map", "rotate"})
    radiance = r.vec3("radiance", [1, 1, 1], scalar_ok=True)
    file = r.string("map")
    if file is None:
        if r.has("rotate"):
            r.error("rotate", "'rotate' turns an environment map: give 'map' too")
        return Environment(radiance, source=f"{ctx.path}:{r.line()}")
    try:
        image = read_environment_image(ctx.path.parent / file)
    except SceneError as e:
        r.error("map", f"{e.message}: {ctx.path.parent / file}")
    to_world = prim.euler_matrix(r.vec3("rotate", [0, 0, 0]))[:3, :3]
    return Environment(radiance, image=image, to_world=to_world, source=f"{ctx.path}:{r.line()}",
                       image_file=str(ctx.path.parent / file))


def _read_light(ctx, i, data) -> DistantLight:
    r = ctx.reader(data, ("lights",), i, label=f"light #{i + 1}")
    kind = r.string("type", "distant")
    if kind != "distant":
        r.error("type", f"unknown light type '{kind}' (lights are 'distant'; area lights are "
                "objects with an emissive material)")
    r.check_keys({"type", "direction", "irradiance"})
    if not r.has("direction"):
        r.error(None, f"light #{i + 1} needs a 'direction' (towards the light)")
    direction = r.vec3("direction")
    if not np.linalg.norm(direction) > 0:
        r.error("direction", "'direction' must not be zero")
    return DistantLight(direction, r.vec3("irradiance", [1, 1, 1], scalar_ok=True),
                        source=f"{ctx.path}:{r.line()}")


def _read_material(ctx, name, data, textures) -> Material:
    r = ctx.reader(data, ("materials", name), label=f"material '{name}'")
    kind = r.string("type", "diffuse")
    if kind not in MATERIAL_KEYS:
        r.error("type", f"unknown material type '{kind}' in material '{name}' "
                f"(expected one of: {', '.join(MATERIAL_KEYS)})")
    everything = set().union(*MATERIAL_KEYS.values())
    r.check_keys(MATERIAL_KEYS[kind], everything, f"a {kind} material")
    source = f"{ctx.path}:{r.line()}"
    m = Material(name=name, type=kind, source=source,
                 base_color=r.vec3("color", [0.8, 0.8, 0.8] if kind == "diffuse" else [1, 1, 1],
                                   scalar_ok=True),
                 emission=r.vec3("emission", [0, 0, 0], scalar_ok=True))
    if r.has("texture"):
        m.texture = textures.load(ctx.path.parent / r.string("texture"), srgb=True,
                                  where=(ctx.path, r.line("texture")))
    if kind == "diffuse":
        return m
    if r.has("roughness") and r.has("alpha"):
        r.error("alpha", f"material '{name}' gives both 'roughness' and 'alpha'; use one")
    if r.has("roughness"):  # perceptual roughness; the sign kept for validate_scene's rule
        roughness = r.number("roughness")
        m.alpha = roughness * abs(roughness)
    else:
        m.alpha = r.number("alpha", 0.0)
    if kind in ("dielectric", "plastic"):
        m.ior = r.number("ior", 1.5, positive=True)
        if kind == "plastic":
            m.nonlinear = r.boolean("nonlinear", False)
        return m
    if r.has("metal"):
        metal = r.string("metal").lower()
        if metal not in METALS:
            r.error("metal", f"unknown metal '{metal}' (expected one of: "
                    f"{', '.join(sorted(METALS))})")
        if r.has("eta") or r.has("k"):
            r.error("metal", f"material '{name}' gives both 'metal' and 'eta'/'k'; use one")
        m.eta, m.k = (np.array(x) for x in METALS[metal])
    elif r.has("eta") or r.has("k"):
        if not (r.has("eta") and r.has("k")):
            r.error("eta" if r.has("eta") else "k", f"material '{name}' needs both 'eta' and 'k'")
        m.eta = r.vec3("eta", scalar_ok=True)
        m.k = r.vec3("k", scalar_ok=True)
    return m


def _read_object(ctx, i, data, scene):
    r = ctx.reader(data, ("objects",), i, label=f"object #{i + 1}")
    kind = r.string("type")
    if kind is None:
        r.error(None, f"object #{i + 1} needs a 'type' ({', '.join(OBJECT_KEYS)})")
    if kind not in OBJECT_KEYS:
        r.error("type", f"unknown object type '{kind}' (expected one of: "
                f"{', '.join(OBJECT_KEYS)})")
    r.check_keys(OBJECT_COMMON | OBJECT_KEYS[kind], set().union(*OBJECT_KEYS.values()),
                 f"a {kind}")
    material = _material_index(r, scene)
    name = r.string("name", f"{kind}{i + 1}")
    source = f"{ctx.path}:{r.line()}"
    scale = r.vec3("scale", [1, 1, 1], scalar_ok=True)
    if (scale == 0).any():
        r.error("scale", "'scale' must not be zero")
    m = prim.trs_matrix(r.vec3("translate", [0, 0, 0]), r.vec3("rotate", [0, 0, 0]), scale)

    velocity = _read_motion(r)

    if kind == "sphere":
        if r.has("prototype"):
            r.error("prototype", "a sphere cannot be a prototype for [[instances]] (use a mesh)")
        if not prim.uniform_scale(m):
            r.error("scale", "a sphere needs a uniform 'scale' (use a mesh for ellipsoids)")
        s = prim.sphere(r.vec3("center", [0, 0, 0]), r.number("radius", 1.0, positive=True),
                        material, source)
        s = prim.transform_sphere(s, m)
        s.velocity = velocity
        s.authored = copy.deepcopy(data)
        scene.spheres.append(s)
        return
    if kind == "mesh":
        file = r.string("file")
        if file is None:
            r.error(None, f"object #{i + 1} (mesh) needs a 'file'")
        mesh = load_mesh_file(ctx.path.parent / file, ref=(ctx.path, r.line("file")),
                              material=material)
    elif kind == "quad":
        for key in ("u", "v"):
            if not r.has(key):
                r.error(None, f"quad object #{i + 1} needs edge vector '{key}'")
        if r.has("corner") and r.has("center"):
            r.error("center", "a quad takes 'corner' or 'center', not both")
        u, v = r.vec3("u"), r.vec3("v")
        if np.linalg.norm(np.cross(u, v)) == 0:
            r.error("v", "quad edges 'u' and 'v' are parallel (zero area)")
        if r.has("corner"):
            mesh = prim.quad(r.vec3("corner"), u, v, material)
        else:
            mesh = prim.quad_centered(r.vec3("center", [0, 0, 0]), u, v, material)
    else:  # box
        size = r.vec3("size", [1, 1, 1], scalar_ok=True)
        if not (size > 0).all():
            r.error("size", "box 'size' must be positive")
        mesh = prim.box(r.vec3("center", [0, 0, 0]), size, material)
    mesh.name, mesh.source = name, source
    mesh = prim.transform_mesh(mesh, m)
    mesh.velocity = velocity
    mesh.authored = copy.deepcopy(data)
    if r.boolean("prototype", False):  # drawn only where [[instances]] place it
        scene.prototypes.append(mesh)
    else:
        scene.meshes.append(mesh)


def _read_instance(ctx, i, data, scene):
    """An [[instances]] table: the mesh object `mesh` (by name; a `prototype = true` object,
    or any mesh, box or quad object) placed again by `transform` (a 4x4 matrix, rows, object
    to world) or translate / rotate / scale, applied after the object's own."""
    r = ctx.reader(data, ("instances",), i, label=f"instance #{i + 1}")
    r.check_keys(INSTANCE_KEYS)
    name = r.string("mesh")
    if name is None:
        r.error(None, f"instance #{i + 1} needs 'mesh', the name of a mesh object")
    index = _prototype_index(scene, name)
    if index is None:
        known = sorted({m.name for m in (*scene.prototypes, *scene.meshes)})
        r.error("mesh", f"unknown mesh '{name}' in instance #{i + 1} (mesh objects: {', '.join(known) or 'none'})")
    source = f"{ctx.path}:{r.line()}"
    if r.has("transform"):
        for key in ("translate", "rotate", "scale"):
            if r.has(key):
                r.error(key, f"instance #{i + 1} gives both 'transform' and '{key}'; use one")
        v = r.data["transform"]
        rows = v if isinstance(v, list) and len(v) == 4 else None
        flat = [x for row in rows for x in row] if rows and all(isinstance(row, list) and len(row) == 4
                                                                for row in rows) else v
        if not (isinstance(flat, list) and len(flat) == 16
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in flat)):
            r.error("transform", f"'transform' in instance #{i + 1} must be a 4x4 matrix (4 rows of 4 "
                    f"numbers, or 16 numbers row by row), not {_show(v)}")
        m = np.asarray(flat, dtype=np.float64).reshape(4, 4)
    else:
        m = prim.trs_matrix(r.vec3("translate", [0, 0, 0]), r.vec3("rotate", [0, 0, 0]),
                            r.vec3("scale", [1, 1, 1], scalar_ok=True))
    try:
        m = check_transform(m, f"instance #{i + 1}")
    except SceneError as e:
        r.error("transform" if r.has("transform") else "scale", e.message)
    material = _material_index(r, scene) if r.has("material") else None
    scene.instances.append(Instance(index, m, material, name=r.string("name", f"{name}#{i + 1}"), source=source))


def _prototype_index(scene: Scene, name: str) -> int | None:
    """Index in scene.prototypes of the mesh object `name`; an ordinary (drawn) mesh object
    becomes a prototype too the first time an instance names it."""
    for k, mesh in enumerate(scene.prototypes):
        if mesh.name == name:
            return k
    for mesh in scene.meshes:
        if mesh.name == name:
            scene.prototypes.append(mesh)
            return len(scene.prototypes) - 1
    return None


def build_object(table: dict, scene: Scene, path):
    """The mesh or sphere that one [[objects]] table describes, built as load_toml builds it
    (the scene editor rebuilds an edited object with it). Materials are found by name in
    `scene`; relative mesh files are relative to `path`, the scene file."""
    built = Scene(camera=scene.camera, materials=scene.materials)
    _read_object(_Context(Path(path), SourceMap("")), 0, table, built)
    return (built.meshes + built.spheres)[0]


def _material_index(r, scene) -> int:
    name = r.string("material")
    if name is None:  # students can start without materials: a grey diffuse default
        try:
            return scene.material_index("default")
        except KeyError:
            scene.materials.append(Material("default", source=f"{r.ctx.path}"))
            return len(scene.materials) - 1
    try:
        return scene.material_index(name)
    except KeyError:
        known = ", ".join(m.name for m in scene.materials) or "none defined"
        r.error("material", f"unknown material '{name}' (known: {known})")
