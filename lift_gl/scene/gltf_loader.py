"""glTF 2.0 scenes (.gltf, .glb): geometry, node transforms and images through trimesh;
materials, cameras and lights from the file's JSON.

Materials (metallic-roughness) become lift-gl's:
- metallic >= 0.5: a conductor with Schlick Fresnel, F0 = the base colour (texture included);
- otherwise a plastic (a diffuse base of the base colour under a coat of index 1.5, or
  KHR_materials_ior), the dielectric half of glTF's BRDF;
- KHR_materials_transmission > 0: a dielectric tinted by the base colour;
- GGX alpha = roughness^2 in every case; emission = emissiveFactor (times
  KHR_materials_emissive_strength).
Metallic between 0 and 1, metallic-roughness, normal and emissive textures, alpha blending
and masking, and extensions other than those named here are reported once each and
approximated or ignored (occlusion textures are ignored silently: a path tracer computes
its own occlusion).
The first perspective camera of the scene is used (else a camera framing the scene);
KHR_lights_punctual directional lights become distant lights (intensity x colour as
irradiance); point and spot lights are reported and skipped. A file with no light at all
is lit by a white sky (radiance 1), as a single mesh file is.
"""
from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from .. import limits
from ..errors import SceneError
from .loader import framing_camera, warn_at
from .mesh_io import clean_triangles, texture_coordinates
from .model import Camera, DistantLight, Environment, Material, Mesh, Scene, Texture

SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_ior",
                        "KHR_materials_transmission"}


def read_gltf_json(path: Path) -> dict:
    """The JSON of a .gltf file, or the JSON chunk of a .glb (a UTF-8 byte order mark allowed)."""
    try:
        with open(path, "rb") as f:
            if path.suffix.lower() == ".glb":  # the JSON chunk alone: the binary one is trimesh's to read
                head = f.read(20)
                if head[:4] != b"glTF" or len(head) < 20:
                    raise ValueError("not a binary glTF (no 'glTF' magic)")
                length = int.from_bytes(head[12:16], "little")
                if head[16:20] != b"JSON":
                    raise ValueError("the first chunk of a .glb must be JSON")
                limits.check_scene_text(length, path, what="a JSON chunk")
                _check_glb_chunks(f, os.fstat(f.fileno()).st_size, length)
                f.seek(20)
                text = f.read(length)
            else:
                limits.check_scene_text(os.fstat(f.fileno()).st_size, path)
                text = f.read()
        doc = json.loads(text.decode("utf-8-sig"))
    except (ValueError, UnicodeDecodeError, RecursionError) as e:
        line = getattr(e, "lineno", None)
        raise SceneError(f"not a readable glTF file ({e})", path, line) from None
    if not isinstance(doc, dict):
        raise SceneError(f"the top level of a glTF file must be a JSON object, not {_json_type(doc)}", path)
    return doc


def _check_glb_chunks(f, size: int, json_length: int) -> None:
    """Every chunk of a .glb must fit in the file: trimesh reads a chunk's claimed length in one
    call, and a length of 2.7 GB in a 4 KB file ran out of memory instead of being refused."""
    start, length, number = 20, json_length, 0
    while True:
        if start + length > size:
            raise ValueError(f"chunk {number} claims {length:,} bytes, and the file has {size - start:,} after "
                             "its header")
        start += length
        if start + 8 > size:
            return
        f.seek(start)
        head = f.read(8)
        length, start, number = int.from_bytes(head[:4], "little"), start + 8, number + 1


def _json_type(value) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "true/false"}.get(
        type(value), "null" if value is None else "a number")


def _is_double(value) -> bool:
    """A JSON number that a float64 holds (JSON integers have no size limit: float() of one
    with 400 digits raises OverflowError); true and false are not numbers."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        float(value)
    except OverflowError:
        return False
    return True


class _Fields:
    """Typed reads of the JSON's values: a value of the wrong type is one SceneError naming the
    file and the value's place (glTF has no line numbers worth giving: files are often one line)."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, where: str, message: str):
        raise SceneError(f"{where}: {message}", self.path)

    def table(self, obj: dict, key: str, where: str) -> dict:
        value = obj.get(key, {})
        if not isinstance(value, dict):
            self.fail(f"{where}.{key}", f"must be a JSON object, not {_json_type(value)}")
        return value

    def items(self, obj: dict, key: str, where: str) -> list:
        value = obj.get(key, [])
        if not isinstance(value, list):
            self.fail(f"{where}.{key}", f"must be an array, not {_json_type(value)}")
        return value

    def _items_of(self, obj: dict, key: str, where: str, kind: type, what: str) -> list:
        values = self.items(obj, key, where)
        for i, v in enumerate(values):
            if not isinstance(v, kind):
                self.fail(f"{where}.{key}[{i}]", f"must be {what}, not {_json_type(v)}")
        return values

    def objects(self, obj: dict, key: str, where: str) -> list[dict]:
        return self._items_of(obj, key, where, dict, "a JSON object")

    def strings(self, obj: dict, key: str, where: str) -> list[str]:
        return self._items_of(obj, key, where, str, "a string")

    def number(self, obj: dict, key: str, default: float, where: str) -> float:
        value = obj.get(key, default)
        if not _is_double(value):
            self.fail(f"{where}.{key}", f"must be a number, not {_json_type(value)} {value!r:.40}")
        return float(value)

    def numbers(self, obj: dict, key: str, count: int, default, where: str) -> np.ndarray:
        value = obj.get(key, default)
        if not (isinstance(value, list) and len(value) == count and all(_is_double(v) for v in value)):
            self.fail(f"{where}.{key}", f"must be an array of {count} numbers, not {value!r:.60}")
        return np.asarray(value, dtype=np.float64)

    def index(self, obj: dict, key: str, where: str) -> int | None:
        value = obj.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
            self.fail(f"{where}.{key}", f"must be an index (an integer), not {value!r:.40}")
        return value


def _node_matrix(node: dict, fields: _Fields, where: str) -> np.ndarray:
    if "matrix" in node:
        return fields.numbers(node, "matrix", 16, None, where).reshape(4, 4).T  # column-major
    t = np.eye(4)
    t[:3, 3] = fields.numbers(node, "translation", 3, [0, 0, 0], where)
    x, y, z, w = fields.numbers(node, "rotation", 4, [0, 0, 0, 1], where)
    r = np.eye(4)
    r[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    s = np.diag([*fields.numbers(node, "scale", 3, [1, 1, 1], where), 1.0])
    return t @ r @ s


def _world_matrices(doc: dict, fields: _Fields) -> list[tuple[int, np.ndarray]]:
    """(node index, world matrix) of every node under the default scene."""
    nodes = fields.objects(doc, "nodes", "glTF")
    scenes = fields.objects(doc, "scenes", "glTF")
    scene = fields.index(doc, "scene", "glTF") or 0
    roots = fields.items(scenes[scene], "nodes", f"scenes[{scene}]") if 0 <= scene < len(scenes) else range(len(nodes))
    out, stack, seen = [], [(i, np.eye(4)) for i in roots], set()
    while stack:
        i, parent = stack.pop()
        if not isinstance(i, int) or i in seen or not 0 <= i < len(nodes):
            continue
        seen.add(i)
        world = parent @ _node_matrix(nodes[i], fields, f"nodes[{i}]")
        out.append((i, world))
        stack.extend((c, world) for c in fields.items(nodes[i], "children", f"nodes[{i}]"))
    return out


class _Gltf:
    def __init__(self, path: Path):
        self.path = path
        self.doc = read_gltf_json(path)
        self.scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0]))
        self.warned: set[str] = set()
        self.textures: dict[int, int] = {}
        self.materials: dict[int, int] = {}
        self.fields = f = _Fields(path)
        json_materials = f.objects(self.doc, "materials", "glTF")
        names = [m.get("name") for m in json_materials]
        # Exact factors by material name, where names are unique (trimesh keeps 8 bits).
        self.by_name = {n: m for n, m in zip(names, json_materials) if isinstance(n, str) and n and names.count(n) == 1}
        # glTF: primitives without NORMAL are flat-shaded. trimesh would invent smooth ones.
        prims = [p for i, m in enumerate(f.objects(self.doc, "meshes", "glTF"))
                 for p in f.objects(m, "primitives", f"meshes[{i}]")]
        with_normals = [("NORMAL" in f.table(p, "attributes", "primitive")) for p in prims]
        self.use_normals = bool(with_normals) and all(with_normals)
        if any(with_normals) and not self.use_normals:
            self.warn("some primitives have normals and some not: all are flat-shaded")
        for extension in f.strings(self.doc, "extensionsUsed", "glTF"):
            if extension not in SUPPORTED_EXTENSIONS:
                self.warn(f"extension {extension} is not supported; ignored")
        self._special_files()
        self._missing_images()

    def _special_files(self) -> None:
        """A buffer or image uri that names a FIFO, a device or a folder is refused before
        trimesh opens it (reading a FIFO waits for a writer for ever)."""
        from urllib.parse import unquote

        for kind in ("buffers", "images"):
            for i, item in enumerate(self.fields.objects(self.doc, kind, "glTF")):
                uri = item.get("uri")
                if not isinstance(uri, str) or uri.startswith("data:"):
                    continue
                target = self.path.parent / unquote(uri)
                if target.exists() and not target.is_file():
                    raise SceneError(f"{kind}[{i}].uri: {target} is not a regular file (a FIFO, a device or a "
                                     "folder)", self.path)

    def _missing_images(self) -> None:
        """trimesh drops an image file it cannot find without a word: say so; and an image file
        over MAX_TEXTURE_PIXELS, from its header."""
        from urllib.parse import unquote

        self.oversized: set[tuple[int, int]] = set()  # sizes of image files already warned about
        for i, image in enumerate(self.fields.objects(self.doc, "images", "glTF")):
            uri = image.get("uri")
            if isinstance(uri, str) and not uri.startswith("data:") and not (self.path.parent / unquote(uri)).is_file():
                self.warn(f"images[{i}]: texture file not found: {self.path.parent / unquote(uri)}; the materials "
                          "using it get their constant factors")
            elif isinstance(uri, str) and not uri.startswith("data:"):
                self._check_image_size(i, self.path.parent / unquote(uri))

    def _check_image_size(self, index: int, path: Path) -> None:
        """An image file over MAX_TEXTURE_PIXELS, from its header: trimesh drops one over
        pillow's own limit without a word, and _texture refuses the others."""
        import warnings

        from PIL import Image

        from .. import limits

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(path) as img:
                    width, height = img.size
        except Image.DecompressionBombError:
            width = height = None
        except Exception:  # unreadable: trimesh's or _texture's to report
            return
        if width is None or width * height > limits.MAX_TEXTURE_PIXELS:
            self.oversized.add((width, height))
            size = "more pixels than pillow allows" if width is None else f"{width:,}x{height:,} pixels"
            self.warn(f"images[{index}]: texture {path} has {size}, over the limit lift_gl.limits."
                      f"MAX_TEXTURE_PIXELS = {limits.MAX_TEXTURE_PIXELS:,}; the materials using it get their "
                      "constant factors")

    def warn(self, message: str) -> None:
        if message not in self.warned:
            self.warned.add(message)
            warn_at(self.path, None, message)

    def load(self) -> Scene:
        import warnings

        import trimesh
        from PIL import Image
        try:
            data = self.path.read_bytes()
            with warnings.catch_warnings():  # images are held to MAX_TEXTURE_PIXELS, lower, in _texture
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                if data.startswith(b"\xef\xbb\xbf"):  # trimesh refuses a byte order mark: give it the text without
                    tm_scene = trimesh.load(io.BytesIO(data[3:]), file_type="gltf", force="scene", process=False,
                                            resolver=trimesh.resolvers.FilePathResolver(str(self.path)))
                else:
                    tm_scene = trimesh.load(str(self.path), force="scene", process=False)
        except Exception as e:  # trimesh raises many kinds; all mean "unreadable"
            raise SceneError(f"cannot read glTF file ({type(e).__name__}: {e})", self.path) from None
        for node_name in tm_scene.graph.nodes_geometry:
            matrix, geometry_name = tm_scene.graph[node_name]
            geometry = tm_scene.geometry.get(geometry_name)
            if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
                continue
            self._mesh(geometry, matrix, f"{self.path}:{geometry_name}")
        if not self.scene.meshes:
            raise SceneError("the glTF file has no triangles", self.path)
        self._cameras_and_lights()
        if not self.scene.distant_lights and not any(m.is_emissive for m in self.scene.materials):
            self.scene.environment = Environment([1.0, 1.0, 1.0], source="default sky")
        return self.scene

    # ---- geometry and materials ------------------------------------------------------------
    def _mesh(self, geometry, matrix: np.ndarray, source: str) -> None:
        positions = np.asarray(geometry.vertices, dtype=np.float64)
        indices = np.asarray(geometry.faces, dtype=np.int64)
        if indices.min() < 0 or indices.max() >= len(positions):  # before trimesh computes normals from them
            raise SceneError(f"mesh {Path(source).name!r}: triangles use vertex indices outside "
                             f"0..{len(positions) - 1} (from {indices.min()} to {indices.max()})", self.path)
        uvs = texture_coordinates(getattr(geometry.visual, "uv", None), len(positions))
        if uvs is None and getattr(geometry.visual, "uv", None) is not None:
            self.warn(f"mesh {Path(source).name!r}: texture coordinates are not one (u, v) pair per vertex; it is "
                      "drawn without them")
        normals = np.asarray(geometry.vertex_normals, dtype=np.float64) if self.use_normals else None
        positions, indices, normals, uvs = clean_triangles(positions, indices, normals, uvs, source)
        material = self._material(getattr(geometry.visual, "material", None))
        from .primitives import transform_mesh
        mesh = Mesh(Path(source).name, positions, indices, material, normals=normals, uvs=uvs, source=source)
        self.scene.meshes.append(transform_mesh(mesh, matrix))

    def _material(self, pbr) -> int:
        key = id(pbr)
        if key in self.materials:
            return self.materials[key]
        name = getattr(pbr, "name", None) or f"material{len(self.materials)}"
        exact = self.by_name.get(getattr(pbr, "name", None))
        if exact is None and len(self.doc.get("materials", [])) == 1:
            exact = self.doc["materials"][0]
        if exact is not None:
            where = f"material '{name}'"
            for key in ("pbrMetallicRoughness", "extensions"):
                self.fields.table(exact, key, where)
        m = self._convert(pbr, exact, name)
        self.scene.materials.append(m)
        self.materials[key] = len(self.scene.materials) - 1
        return self.materials[key]

    def _convert(self, pbr, exact: dict | None, name: str) -> Material:
        src = str(self.path)  # validate_scene names the material
        if pbr is None:
            return Material(name, "diffuse", base_color=[0.8] * 3, source=src)
        f, where = self.fields, f"material '{name}'"
        metal_rough = (exact or {}).get("pbrMetallicRoughness", {})
        if exact is not None:
            base = f.numbers(metal_rough, "baseColorFactor", 4, [1, 1, 1, 1], f"{where}.pbrMetallicRoughness")[:3]
            emission = f.numbers(exact, "emissiveFactor", 3, [0, 0, 0], where)
        else:
            factor = pbr.baseColorFactor
            base = np.ones(3) if factor is None else np.asarray(factor[:3], dtype=np.float64) / 255.0
            emission = np.zeros(3) if pbr.emissiveFactor is None else np.asarray(pbr.emissiveFactor, dtype=np.float64)
        metallic = 1.0 if pbr.metallicFactor is None else float(pbr.metallicFactor)
        roughness = 1.0 if pbr.roughnessFactor is None else float(pbr.roughnessFactor)
        if exact is not None:  # the file's own values (trimesh may have rounded them)
            metallic = f.number(metal_rough, "metallicFactor", 1.0, f"{where}.pbrMetallicRoughness")
            roughness = f.number(metal_rough, "roughnessFactor", 1.0, f"{where}.pbrMetallicRoughness")
        extensions = (exact or {}).get("extensions", {})
        ext = {key: f.table(extensions, key, f"{where}.extensions") for key in
               ("KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission")}
        emission = emission * f.number(ext["KHR_materials_emissive_strength"], "emissiveStrength", 1.0,
                                       f"{where}.KHR_materials_emissive_strength")
        ior = f.number(ext["KHR_materials_ior"], "ior", 1.5, f"{where}.KHR_materials_ior")
        transmission = f.number(ext["KHR_materials_transmission"], "transmissionFactor", 0.0,
                                f"{where}.KHR_materials_transmission")

        texture = self._texture(pbr.baseColorTexture)
        for attr, what in (("metallicRoughnessTexture", "metallic-roughness textures are ignored: the factors are used"),
                           ("normalTexture", "normal maps are not supported; ignored"),
                           ("emissiveTexture", "emissive textures are not supported: emissiveFactor is used")):
            if getattr(pbr, attr, None) is not None:
                self.warn(what)
        if (getattr(pbr, "alphaMode", None) or "OPAQUE") != "OPAQUE":
            self.warn("alphaMode BLEND and MASK are not supported: surfaces are opaque")
        if 0.0 < metallic < 1.0:
            self.warn("metallic factors between 0 and 1 are approximated by the nearer of metal (>= 0.5) "
                      "and dielectric")
        alpha = roughness * abs(roughness)  # GGX alpha; a negative roughness stays negative for validate_scene
        if transmission > 0:
            if transmission < 1:
                self.warn("partial KHR_materials_transmission is approximated by full transmission")
            kind = "dielectric"
        else:
            kind = "conductor" if metallic >= 0.5 else "plastic"
        return Material(name, kind, base_color=base, alpha=alpha, ior=ior, texture=texture,
                        emission=emission, source=src)

    def _texture(self, image) -> int | None:
        if image is None:
            return None
        if id(image) not in self.textures:
            from .. import limits

            width, height = image.size  # trimesh's image is pillow's, not decoded yet
            if width * height > limits.MAX_TEXTURE_PIXELS:
                if (width, height) not in self.oversized:  # an embedded image: not warned yet
                    self.warn(f"a texture of {width:,}x{height:,} pixels, over the limit lift_gl.limits."
                              f"MAX_TEXTURE_PIXELS = {limits.MAX_TEXTURE_PIXELS:,}: the materials using it get "
                              "their constant factors")
                self.textures[id(image)] = None
                return None
            try:
                rgba = np.asarray(image.convert("RGBA"), dtype=np.uint8)  # decoded here, on first use
            except (OSError, ValueError, SyntaxError) as e:  # pillow's kinds for a broken image
                self.warn(f"a texture image that cannot be decoded ({type(e).__name__}: {e}): the materials "
                          "using it get their constant factors")
                self.textures[id(image)] = None
                return None
            self.scene.textures.append(Texture(f"{self.path.stem}-texture{len(self.textures)}", rgba, srgb=True,
                                               source=str(self.path)))
            self.textures[id(image)] = len(self.scene.textures) - 1
        return self.textures[id(image)]

    # ---- cameras and lights ------------------------------------------------------------------
    def _cameras_and_lights(self) -> None:
        f = self.fields
        nodes = f.objects(self.doc, "nodes", "glTF")
        cameras = f.objects(self.doc, "cameras", "glTF")
        punctual = f.table(f.table(self.doc, "extensions", "glTF"), "KHR_lights_punctual", "glTF.extensions")
        lights = f.objects(punctual, "lights", "KHR_lights_punctual")
        camera = None
        for i, world in _world_matrices(self.doc, f):
            node = nodes[i]
            index = f.index(node, "camera", f"nodes[{i}]")
            if index is not None and camera is None and 0 <= index < len(cameras):
                camera = self._camera(cameras[index], world, f"cameras[{index}]")
            node_lights = f.table(f.table(node, "extensions", f"nodes[{i}]"), "KHR_lights_punctual",
                                  f"nodes[{i}].extensions")
            light_index = f.index(node_lights, "light", f"nodes[{i}].KHR_lights_punctual")
            if light_index is not None and 0 <= light_index < len(lights):
                self._light(lights[light_index], world, light_index)
        if camera is None:
            camera = framing_camera(self.scene)
        self.scene.camera = camera

    def _camera(self, cam: dict, world: np.ndarray, where: str) -> Camera | None:
        p = self.fields.table(cam, "perspective", where)
        if cam.get("type") != "perspective" or "yfov" not in p:
            self.warn("only perspective cameras are supported; the camera is ignored")
            return None
        yfov = self.fields.number(p, "yfov", 0.0, f"{where}.perspective")
        aspect = self.fields.number(p, "aspectRatio", 0.0, f"{where}.perspective")
        if 1e-4 <= aspect <= 1e4:
            height = 256
            self.scene.film_size = (max(1, int(round(height * aspect))), height)
        elif aspect != 0:
            self.warn(f"{where}: aspectRatio {aspect:g} is ignored (not between 1e-4 and 1e4)")
        # glTF cameras look down -z with +y up.
        position = world[:3, 3]
        forward = -world[:3, 2] / np.linalg.norm(world[:3, 2])
        return Camera(position=position, target=position + forward, up=world[:3, 1],
                      fov_deg=float(np.degrees(yfov)), source=str(self.path))

    def _light(self, light: dict, world: np.ndarray, index: int) -> None:
        where = f"KHR_lights_punctual.lights[{index}]"
        color = self.fields.numbers(light, "color", 3, [1, 1, 1], where)
        intensity = self.fields.number(light, "intensity", 1.0, where)
        if light.get("type") == "directional":
            # The light shines along its node's -z: it arrives from +z.
            self.scene.distant_lights.append(DistantLight(world[:3, 2], color * intensity,
                                                          source=str(self.path)))
        else:
            self.warn(f"KHR_lights_punctual '{light.get('type')}' lights are not supported; skipped")


def load_gltf(path: Path) -> Scene:
    return _Gltf(Path(path)).load()
