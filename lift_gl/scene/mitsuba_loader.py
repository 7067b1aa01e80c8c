"""Mitsuba XML scenes: Mitsuba 3 files, and Mitsuba 0.5/0.6 files (camelCase parameter
names are read as Mitsuba 3's snake_case, as Mitsuba 3's own upgrade does).

Supported (the rest is reported once per kind, naming file and line, and skipped):
- <default name value/> and $name substitution in any attribute; <include filename/>;
  id/<ref id/> for BSDFs and textures.
- <integrator type="path"> max_depth (Mitsuba counts path vertices: max_depth 1 shows only
  emitters, so lift-gl's bounces are max_depth - 1; -1 is unlimited), nested integrators.
- <sensor type="perspective"|"thinlens">: fov, fov_axis (x, y, diagonal, smaller, larger),
  focal_length, to_world (matrix, lookat, translate, rotate, scale), aperture_radius and
  focus_distance; <film> width/height (768x576 by default).
- <shape>: obj, ply (face_normals, flip_normals, flip_tex_coords), rectangle, cube, sphere
  (center, radius), disk (triangulated, area kept), each with to_world; a nested or
  referenced <bsdf>; an <emitter type="area"> (radiance) inside.
- BSDFs: see mitsuba_bsdfs.py. Emitters: constant, envmap (filename, scale, to_world),
  directional (irradiance, direction).

Conventions: Mitsuba cameras look along +z with +x to the image's left; where a camera's
frame would show lift-gl a mirrored image, the world is mirrored (primitives.mirror_scene_x).
Faces keep Mitsuba's orientation: a mirroring to_world flips the geometric normal (and an
area light's emitting side), unlike lift-gl's own formats.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..limits import IncludeBudget
from . import primitives as prim
from .loader import warn_at
from .mesh_io import load_mesh_file
from .mitsuba_bsdfs import BsdfReader
from .mitsuba_props import Props
from .model import Camera, DistantLight, Environment, Material, Mesh, PixelFilter, Scene, film_filter
from .texture_files import TextureLibrary, read_environment_image
from .xml_tree import Node, parse_xml

# Elements whose parameters lift-gl reads elsewhere or that change nothing in its image.
IGNORED_SILENTLY = {"sampler", "rfilter"}  # rfilter: read by _film
# Mitsuba's film filter when the scene names none: a gaussian of standard deviation 0.5 pixel, cut at 2.
MITSUBA_DEFAULT_FILTER = PixelFilter("gaussian", (2.0, 2.0), alpha=2.0, source="Mitsuba's default rfilter")
SHAPES = {"obj", "ply", "rectangle", "cube", "sphere", "disk"}
DISK_SEGMENTS = 96


class _Loader:
    def __init__(self, path: Path):
        self.path = Path(path)
        self.folder = self.path.parent
        self.scene = Scene(camera=Camera(position=[0, 0, 0], target=[0, 0, 1]), film_size=(768, 576),
                           pixel_filter=MITSUBA_DEFAULT_FILTER)
        self.ids: dict[str, Node] = {}
        self.defaults: dict[str, str] = {}
        self.warned: set = set()
        self.texture_files = TextureLibrary(self.scene)
        self.bsdfs = BsdfReader(self)
        self.material_ids: dict = {}
        self.version = 3
        self.sensor: Node | None = None
        self.included: set[Path] = set()
        self.include_budget = IncludeBudget()  # pbrt's limits: inclusions and bytes, all files together

    # ---- messages, references ------------------------------------------------------------
    def warn(self, node: Node, message: str, key=None) -> None:
        """Once per kind of problem (key, or the message itself), at its first line."""
        key = key if key is not None else message
        if key in self.warned:
            return
        self.warned.add(key)
        warn_at(node.path, node.line, message)

    def lookup(self, ident, node: Node) -> Node:
        if ident is None:
            raise SceneError("<ref> needs an 'id'", *node.where)
        if ident not in self.ids:
            raise SceneError(f"reference to an unknown id '{ident}'", *node.where)
        return self.ids[ident]

    # ---- the file --------------------------------------------------------------------------
    def load(self) -> Scene:
        root = self._read(self.path)
        version = root.get("version", "3.0.0")
        try:
            self.version = int(version.split(".")[0])
        except ValueError:
            raise SceneError(f"bad scene version '{version}'", *root.where) from None
        self._top_level(root)
        self._finish_camera()
        return self.scene

    def _read(self, path: Path) -> Node:
        root = parse_xml(path)
        if root.tag != "scene":
            raise SceneError(f"expected a <scene> element, found <{root.tag}>", *root.where)
        for child in root.children:  # defaults first: they may be used before they appear
            if child.tag == "default":
                name, value = child.get("name"), child.get("value")
                if name is None or value is None:
                    raise SceneError("<default> needs 'name' and 'value'", *child.where)
                self.defaults.setdefault(name, value)
        self._substitute(root)
        self._register_ids(root)
        return root

    def _substitute(self, node: Node) -> None:
        for key, value in node.attrs.items():
            if "$" in value:
                def replace(m, node=node):
                    if m.group(1) not in self.defaults:
                        raise SceneError(f"'${m.group(1)}' is not defined (add <default name=\"{m.group(1)}\" "
                                         "value=\"...\"/>)", *node.where)
                    return self.defaults[m.group(1)]
                node.attrs[key] = re.sub(r"\$([A-Za-z_][A-Za-z0-9_]*)", replace, value)
        for child in node.children:
            self._substitute(child)

    def _register_ids(self, node: Node) -> None:
        for child in node.children:
            if child.tag in ("bsdf", "texture", "shape", "emitter") and child.get("id") is not None:
                self.ids.setdefault(child.get("id"), child)
            self._register_ids(child)

    def _top_level(self, root: Node) -> None:
        for child in root.children:
            tag = child.tag
            if tag in ("default", "bsdf", "texture"):
                continue  # defaults read already; BSDFs and textures when a shape uses them
            if tag == "include":
                self._include(child)
            elif tag == "integrator":
                self._integrator(child)
            elif tag == "sensor":
                self.sensor = child
            elif tag == "shape":
                self._shape(child)
            elif tag == "emitter":
                self._emitter(child)
            elif tag in ("medium", "phase"):
                self.warn(child, f"participating media (<{tag}>) are not supported; ignored", key=("medium",))
            else:
                self.warn(child, f"unknown element <{tag}>; ignored", key=("element", tag))

    def _include(self, node: Node) -> None:
        filename = node.get("filename")
        if filename is None:
            raise SceneError("<include> needs a 'filename'", *node.where)
        try:
            path = (self.folder / filename).resolve()
        except (RuntimeError, OSError) as e:  # Python raises RuntimeError for a symlink loop
            raise SceneError(f"cannot follow the include {filename} ({e})", *node.where) from None
        if path in self.included:
            raise SceneError(f"{filename} is included twice (or includes itself)", *node.where)
        if not path.is_file():
            raise SceneError(f"included file not found: {path}", *node.where)
        self.include_budget.add(path, node.where)
        self.included.add(path)
        self._top_level(self._read(path))

    # ---- integrator and camera -------------------------------------------------------------
    def _integrator(self, node: Node) -> None:
        inner = [c for c in node.children if c.tag == "integrator"]
        if inner:  # Mitsuba 0.5's wrappers (adaptive, irrcache...): the inner one renders
            self.warn(node, f"integrator '{node.get('type')}' wraps another; using the inner one's max_depth")
            self._integrator(inner[0])
            return
        p = Props(node, self.warn)
        if p.kind not in ("path", "volpath", "volpathmis", "direct", "bdpt", "pssmlt", "mlt", "ptracer"):
            self.warn(node, f"integrator '{p.kind}': only its max_depth is used")
        depth = p.int("max_depth", -1 if p.kind != "direct" else 2)
        self.scene.max_depth = 1000 if depth < 0 else max(depth - 1, 0)
        if p.bool("hide_emitters", False):
            self.warn(node, "hide_emitters is not supported; emitters stay visible")
        p.used.update({"rr_depth", "samples_per_pass", "timeout", "strict_normals"})
        for child in node.children:
            if child.get("name") is None and child.tag not in IGNORED_SILENTLY:
                self.warn(child, f"unknown element <{child.tag}> in the integrator; ignored", key=("element", child.tag))
        p.warn_unused()

    def _finish_camera(self) -> None:
        node = self.sensor
        if node is None:
            self.warn(Node("scene", {}, 1, self.path), "the scene has no <sensor>: a camera framing it is used")
            from .loader import framing_camera
            self.scene.camera = framing_camera(self.scene)
            return
        p = Props(node, self.warn)
        if p.kind not in ("perspective", "thinlens"):
            self.warn(node, f"sensor '{p.kind}' is not supported; using a perspective camera")
        for child in node.children:
            if child.tag == "film":
                self._film(child)
            elif child.tag not in IGNORED_SILENTLY and child.get("name") is None:
                self.warn(child, f"unknown element <{child.tag}> in the sensor; ignored", key=("element", child.tag))
        w, h = self.scene.film_size
        m = p.transform("to_world")
        if p.has("focal_length"):
            text = p.string("focal_length")
            try:
                f = float(text.lower().removesuffix("mm"))
            except ValueError:
                raise SceneError(f"focal_length '{text}' is not a length in mm", *p.items["focal_length"].where) from None
            fov, axis = float(np.degrees(2 * np.arctan(np.hypot(36, 24) / (2 * f)))), "diagonal"
        else:
            fov, axis = p.float("fov", 40.0), p.string("fov_axis", "x").lower()
        t = np.tan(np.radians(fov) / 2)
        if axis == "smaller":
            axis = "x" if w < h else "y"
        elif axis == "larger":
            axis = "x" if w >= h else "y"
        if axis == "x":
            t_vertical = t * h / w
        elif axis == "y":
            t_vertical = t
        elif axis == "diagonal":
            t_vertical = t * h / np.hypot(w, h)
        else:
            raise SceneError(f"unknown fov_axis '{axis}' (x, y, diagonal, smaller, larger)",
                             *p.items["fov_axis"].where)
        linear = m[:3, :3]
        position = m[:3, 3].copy()
        forward = linear @ [0.0, 0.0, 1.0]
        up = linear @ [0.0, 1.0, 0.0]
        left = linear @ [1.0, 0.0, 0.0]
        if not (np.linalg.norm(forward) > 0 and np.linalg.norm(np.cross(forward, up)) > 0):
            raise SceneError("the sensor's to_world is degenerate", *node.where)
        forward = forward / np.linalg.norm(forward)
        aperture = p.float("aperture_radius", 0.0) if p.kind == "thinlens" else 0.0
        focus = p.float("focus_distance", None)
        self.scene.camera = Camera(position=position, target=position + forward, up=up,
                                   fov_deg=float(np.degrees(2 * np.arctan(t_vertical))),
                                   aperture_radius=aperture, focus_distance=focus if aperture > 0 else None)
        p.used.update({"near_clip", "far_clip", "shutter_open", "shutter_close", "focus_distance"})
        p.warn_unused()
        # Mitsuba's image left is the camera's +x; lift-gl's right is forward x up.
        if np.dot(np.cross(forward, up), -left) < 0:
            prim.mirror_scene_x(self.scene)

    def _rfilter(self, node: Node | None) -> None:
        """The film's reconstruction filter (Mitsuba's default is a gaussian of standard
        deviation 0.5 pixel, cut at 4 of them); radii in the film's pixels."""
        if node is None:
            self.scene.pixel_filter = MITSUBA_DEFAULT_FILTER
            return
        p = Props(node, self.warn)
        where = f"{node.where[0]}:{node.where[1]}"
        if p.kind == "box":  # Mitsuba's box: half a pixel either way
            self.scene.pixel_filter = film_filter("box", (0.5, 0.5), source=where)
        elif p.kind == "tent":
            radius = p.float("radius", 1.0)
            if not radius > 0:
                raise SceneError("the tent filter's radius must be positive", *node.where)
            self.scene.pixel_filter = film_filter("triangle", (radius, radius), source=where)
        elif p.kind == "gaussian":
            stddev = p.float("stddev", 0.5)
            if not stddev > 0:
                raise SceneError("the gaussian filter's stddev must be positive", *node.where)
            self.scene.pixel_filter = film_filter("gaussian", (4 * stddev, 4 * stddev), alpha=0.5 / stddev ** 2,
                                                  source=where)
        else:
            self.warn(node, f"rfilter '{p.kind}' cannot be sampled as a density (negative lobes or unknown); "
                            "using a box over each pixel")
            self.scene.pixel_filter = None
            return
        p.warn_unused()

    def _film(self, node: Node) -> None:
        p = Props(node, self.warn)
        self.scene.film_size = (p.int("width", 768), p.int("height", 576))
        if min(self.scene.film_size) <= 0:
            raise SceneError("film width and height must be positive", *node.where)
        for name in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
            if p.has(name):
                p.int(name)
                self.warn(node, "film crop windows are not supported; the whole image is rendered", key=("crop",))
        self._rfilter(next((c for c in node.children if c.tag == "rfilter"), None))
        # Output options (file format, pixel format, banner, gamma...) belong to
        # lift-gl's --out, not to the scene.
        p.used.update({"file_format", "pixel_format", "component_format", "banner", "gamma",
                       "high_quality_edges", "filename", "tonemap_method", "exposure", "sample_border",
                       "compensate", "attach_log", "rfilter"})
        p.warn_unused()

    # ---- shapes ------------------------------------------------------------------------------
    def _shape(self, node: Node) -> None:
        p = Props(node, self.warn)
        kind = p.kind
        if kind not in SHAPES:
            self.warn(node, f"shape '{kind}' is not supported; skipped", key=("shape", kind))
            return
        bsdf_node, emission, emitter = None, None, None
        for child in node.children:
            if child.tag == "bsdf" or (child.tag == "ref" and child.get("name") in (None, "bsdf")):
                bsdf_node = self.lookup(child.get("id"), child) if child.tag == "ref" else child
                p.used.add("bsdf")
            elif child.tag == "emitter":
                emission, emitter = self._area_emission(child), child
            elif child.get("name") is None and child.tag not in IGNORED_SILENTLY:
                self.warn(child, f"unknown element <{child.tag}> in a shape; ignored", key=("element", child.tag))
        src = f"{node.path}:{node.line}"
        material = self._material_index(bsdf_node, emission, emitter or node)
        if material is None:
            return
        m = p.transform("to_world")
        if kind == "sphere":
            center = p.vector("center", [0, 0, 0])
            radius = p.float("radius", 1.0)
            if not radius > 0:
                raise SceneError("sphere radius must be positive", *node.where)
            if not prim.uniform_scale(m):
                self.warn(node, "a sphere under non-uniform scale is approximated with the mean scale")
            if p.bool("flip_normals", False):
                self.warn(node, "flip_normals on a sphere is not supported; it faces outwards")
            p.warn_unused()
            self.scene.spheres.append(prim.transform_sphere(prim.sphere(center, radius, material, src), m))
            return
        if kind in ("obj", "ply"):
            mesh = self._mesh_file(node, p, material)
        elif kind == "rectangle":
            mesh = _rectangle(material)
        elif kind == "cube":
            mesh = prim.box([0, 0, 0], 2.0, material)
        else:
            mesh = _disk(material)
        mesh.source = src
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise SceneError("the shape's to_world is singular", *node.where)
        # Keep the file's winding under a mirroring transform (Mitsuba's geometric normal).
        mesh = prim.transform_mesh(mesh, m, flip=np.linalg.det(m[:3, :3]) < 0)
        if p.bool("flip_normals", False):
            mesh.indices = mesh.indices[:, [0, 2, 1]]
            if mesh.normals is not None:
                mesh.normals = -mesh.normals
        p.warn_unused()
        self.scene.meshes.append(prim.orient_to_normals(mesh))

    def _mesh_file(self, node: Node, p: Props, material: int) -> Mesh:
        filename = p.string("filename")
        if filename is None:
            raise SceneError(f"shape '{p.kind}' needs a 'filename'", *node.where)
        mesh = load_mesh_file(self.folder / filename, ref=node.where, material=material)
        if p.bool("face_normals", False):
            mesh.normals = None
        elif mesh.normals is None:  # Mitsuba computes smooth normals when the file has none
            mesh.normals = prim.smooth_normals(mesh.positions, mesh.indices).astype(np.float32)
        if p.kind == "obj" and not p.bool("flip_tex_coords", True) and mesh.uvs is not None:
            # Mitsuba flips OBJ's v by default to its top-left texture origin; lift-gl's
            # origin is bottom-left, so the default needs nothing and false needs a flip.
            mesh.uvs = np.column_stack([mesh.uvs[:, 0], 1.0 - mesh.uvs[:, 1]])
        if p.has("max_smooth_angle"):
            p.float("max_smooth_angle")
            self.warn(node, "max_smooth_angle is not supported; normals are smooth", key=("max_smooth_angle",))
        return mesh

    def _area_emission(self, node: Node) -> np.ndarray | None:
        p = Props(node, self.warn)
        if p.kind != "area":
            self.warn(node, f"emitter '{p.kind}' inside a shape is not supported; ignored", key=("emitter", p.kind))
            return None
        rgb, tex = self.bsdfs.colour(p, "radiance", [1, 1, 1])
        if tex is not None:
            self.warn(node, "textured emission is not supported; using 1")
        rgb = rgb * p.float("scale", 1.0)
        p.used.add("sampling_weight")
        p.warn_unused()
        return rgb

    def _material_index(self, bsdf_node: Node | None, emission, shape: Node) -> int | None:
        """`shape`: the emitter's node where there is one (an emitting material is defined there)."""
        if bsdf_node is None:
            base = self.material_ids.get("default")
            if base is None:
                base = Material("mitsuba-default", "diffuse", base_color=[0.5] * 3)
                self.material_ids["default"] = base
        else:
            base = self.bsdfs.material(bsdf_node, bsdf_node.get("id") or f"{bsdf_node.get('type')}@{bsdf_node.line}")
        # Any emission but zero, so that a negative one reaches validate_scene, which refuses it.
        emissive = emission is not None and bool(np.any(np.asarray(emission) != 0))
        if base is None:  # a null BSDF: invisible unless it emits
            if not emissive:
                self.warn(shape, "a shape with a null BSDF (invisible) is skipped", key=("null",))
                return None
            base = Material("null", "diffuse", base_color=[0.0] * 3)
        key = (id(base), tuple(np.asarray(emission, dtype=float)) if emissive else None)
        if key not in self.material_ids:
            m = base
            if emissive:
                from dataclasses import replace
                m = replace(base, name=f"{base.name}+emitter{len(self.material_ids)}",
                            emission=np.asarray(emission, dtype=np.float64), source=f"{shape.path}:{shape.line}")
            self.scene.materials.append(m)
            self.material_ids[key] = len(self.scene.materials) - 1
        return self.material_ids[key]

    # ---- emitters ------------------------------------------------------------------------------
    def _emitter(self, node: Node) -> None:
        p = Props(node, self.warn)
        src = f"{node.path}:{node.line}"
        if p.kind in ("constant", "envmap"):
            if self.scene.environment is not None:
                self.warn(node, "a second environment emitter replaces the first")
            if p.kind == "constant":
                rgb, _ = self.bsdfs.colour(p, "radiance", [1, 1, 1])
                self.scene.environment = Environment(rgb, source=src)
            else:
                filename = p.string("filename")
                if filename is None:
                    raise SceneError("envmap needs a 'filename'", *node.where)
                try:
                    image = read_environment_image(self.folder / filename)
                except SceneError as e:
                    raise SceneError(f"{e.message}: {self.folder / filename}", *node.where) from None
                scale = p.float("scale", 1.0)
                self.scene.environment = Environment(np.full(3, scale), image=image,
                                                     to_world=p.transform("to_world")[:3, :3], source=src,
                                                     image_file=str(self.folder / filename))
                p.used.update({"gamma", "cache", "mis_compensation"})
            p.used.add("sampling_weight")
            p.warn_unused()
        elif p.kind == "directional":
            rgb, _ = self.bsdfs.colour(p, "irradiance", [1, 1, 1])
            travel = p.vector("direction", None)
            if travel is None:
                travel = p.transform("to_world")[:3, :3] @ [0.0, 0.0, 1.0]
            if not np.linalg.norm(travel) > 0:
                raise SceneError("directional emitter: zero direction", *node.where)
            p.used.add("sampling_weight")
            p.warn_unused()
            self.scene.distant_lights.append(DistantLight(-np.asarray(travel, dtype=float), rgb, source=src))
        elif p.kind == "area":
            self.warn(node, "an area emitter must be inside a <shape>; ignored")
        else:
            self.warn(node, f"emitter '{p.kind}' is not supported; ignored", key=("emitter", p.kind))


def _rectangle(material: int) -> Mesh:
    """Mitsuba's rectangle: [-1, 1]^2 at z = 0 facing +z; its uv (x/2 + 1/2, y/2 + 1/2) has
    Mitsuba's top-left texture origin, so lift-gl's v is 1 minus that."""
    positions = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float64)
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    return Mesh("rectangle", positions, np.array([[0, 1, 2], [0, 2, 3]]), material, normals=normals, uvs=uvs)


def _disk(material: int) -> Mesh:
    """Mitsuba's disk: radius 1 at z = 0 facing +z, as a fan of triangles whose radius is
    enlarged so that the polygon's area is the disk's (an emitting disk keeps its power)."""
    n = DISK_SEGMENTS
    radius = np.sqrt(np.pi / (0.5 * n * np.sin(2 * np.pi / n)))
    angle = 2 * np.pi * np.arange(n) / n
    rim = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(n)])
    positions = np.vstack([[0.0, 0.0, 0.0], rim])
    indices = np.column_stack([np.zeros(n, int), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n])
    uvs = np.vstack([[0.0, 0.0], np.column_stack([np.ones(n), 1.0 - np.arange(n) / n])])
    normals = np.tile([0.0, 0.0, 1.0], (n + 1, 1))
    return Mesh("disk", positions, indices, material, normals=normals, uvs=uvs)


def load_mitsuba(path: Path) -> Scene:
    return _Loader(Path(path)).load()
