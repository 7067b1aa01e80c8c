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

import json
from pathlib import Path

import numpy as np

from ..errors import SceneError
from .loader import framing_camera, warn_at
from .mesh_io import clean_triangles
from .model import Camera, DistantLight, Environment, Material, Mesh, Scene, Texture

SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_ior",
                        "KHR_materials_transmission"}


def read_gltf_json(path: Path) -> dict:
    """The JSON of a .gltf file, or the JSON chunk of a .glb."""
    data = path.read_bytes()
    try:
        if path.suffix.lower() == ".glb":
            if data[:4] != b"glTF" or len(data) < 20:
                raise ValueError("not a binary glTF (no 'glTF' magic)")
            length = int.from_bytes(data[12:16], "little")
            if data[16:20] != b"JSON":
                raise ValueError("the first chunk of a .glb must be JSON")
            return json.loads(data[20:20 + length].decode("utf-8"))
        return json.loads(data.decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as e:
        line = getattr(e, "lineno", None)
        raise SceneError(f"not a readable glTF file ({e})", path, line) from None


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    t = np.eye(4)
    t[:3, 3] = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    r = np.eye(4)
    r[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    s = np.diag([*node.get("scale", [1, 1, 1]), 1.0])
    return t @ r @ s


def _world_matrices(doc: dict) -> list[tuple[int, np.ndarray]]:
    """(node index, world matrix) of every node under the default scene."""
    nodes = doc.get("nodes", [])
    scenes = doc.get("scenes", [])
    roots = scenes[doc.get("scene", 0)].get("nodes", []) if scenes else range(len(nodes))
    out, stack, seen = [], [(i, np.eye(4)) for i in roots], set()
    while stack:
        i, parent = stack.pop()
        if i in seen or not 0 <= i < len(nodes):
            continue
        seen.add(i)
        world = parent @ _node_matrix(nodes[i])
        out.append((i, world))
        stack.extend((c, world) for c in nodes[i].get("children", []))
    return out


class _Gltf:
    def __init__(self, path: Path):
        self.path = path
        self.doc = read_gltf_json(path)
        self.scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0]))
        self.warned: set[str] = set()
        self.textures: dict[int, int] = {}
        self.materials: dict[int, int] = {}
        json_materials = self.doc.get("materials", [])
        names = [m.get("name") for m in json_materials]
        # Exact factors by material name, where names are unique (trimesh keeps 8 bits).
        self.by_name = {n: m for n, m in zip(names, json_materials) if n and names.count(n) == 1}
        # glTF: primitives without NORMAL are flat-shaded. trimesh would invent smooth ones.
        prims = [p for m in self.doc.get("meshes", []) for p in m.get("primitives", [])]
        with_normals = [("NORMAL" in p.get("attributes", {})) for p in prims]
        self.use_normals = bool(with_normals) and all(with_normals)
        if any(with_normals) and not self.use_normals:
            self.warn("some primitives have normals and some not: all are flat-shaded")
        for extension in self.doc.get("extensionsUsed", []):
            if extension not in SUPPORTED_EXTENSIONS:
                self.warn(f"extension {extension} is not supported; ignored")

    def warn(self, message: str) -> None:
        if message not in self.warned:
            self.warned.add(message)
            warn_at(self.path, None, message)

    def load(self) -> Scene:
        import trimesh
        try:
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
        uv = getattr(geometry.visual, "uv", None)
        uvs = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(positions) else None
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
        m = self._convert(pbr, exact, name)
        self.scene.materials.append(m)
        self.materials[key] = len(self.scene.materials) - 1
        return self.materials[key]

    def _convert(self, pbr, exact: dict | None, name: str) -> Material:
        src = f"{self.path}: material '{name}'"
        if pbr is None:
            return Material(name, "diffuse", base_color=[0.8] * 3, source=src)
        metal_rough = (exact or {}).get("pbrMetallicRoughness", {})
        if exact is not None:
            base = np.asarray(metal_rough.get("baseColorFactor", [1, 1, 1, 1]), dtype=np.float64)[:3]
            emission = np.asarray(exact.get("emissiveFactor", [0, 0, 0]), dtype=np.float64)
        else:
            factor = pbr.baseColorFactor
            base = np.ones(3) if factor is None else np.asarray(factor[:3], dtype=np.float64) / 255.0
            emission = np.zeros(3) if pbr.emissiveFactor is None else np.asarray(pbr.emissiveFactor, dtype=np.float64)
        metallic = 1.0 if pbr.metallicFactor is None else float(pbr.metallicFactor)
        roughness = 1.0 if pbr.roughnessFactor is None else float(pbr.roughnessFactor)
        extensions = (exact or {}).get("extensions", {})
        emission = emission * float(extensions.get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0))
        ior = float(extensions.get("KHR_materials_ior", {}).get("ior", 1.5))
        transmission = float(extensions.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0))

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
        alpha = roughness ** 2
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
            rgba = np.asarray(image.convert("RGBA"), dtype=np.uint8)
            self.scene.textures.append(Texture(f"{self.path.stem}-texture{len(self.textures)}", rgba, srgb=True,
                                               source=str(self.path)))
            self.textures[id(image)] = len(self.scene.textures) - 1
        return self.textures[id(image)]

    # ---- cameras and lights ------------------------------------------------------------------
    def _cameras_and_lights(self) -> None:
        nodes = self.doc.get("nodes", [])
        cameras = self.doc.get("cameras", [])
        lights = self.doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
        camera = None
        for i, world in _world_matrices(self.doc):
            node = nodes[i]
            if "camera" in node and camera is None and 0 <= node["camera"] < len(cameras):
                camera = self._camera(cameras[node["camera"]], world)
            light_index = node.get("extensions", {}).get("KHR_lights_punctual", {}).get("light")
            if light_index is not None and 0 <= light_index < len(lights):
                self._light(lights[light_index], world)
        if camera is None:
            camera = framing_camera(self.scene)
        self.scene.camera = camera

    def _camera(self, cam: dict, world: np.ndarray) -> Camera | None:
        if cam.get("type") != "perspective" or "perspective" in cam and "yfov" not in cam["perspective"]:
            self.warn("only perspective cameras are supported; the camera is ignored")
            return None
        p = cam["perspective"]
        if "aspectRatio" in p and p["aspectRatio"] > 0:
            height = 256
            self.scene.film_size = (max(1, int(round(height * p["aspectRatio"]))), height)
        # glTF cameras look down -z with +y up.
        position = world[:3, 3]
        forward = -world[:3, 2] / np.linalg.norm(world[:3, 2])
        return Camera(position=position, target=position + forward, up=world[:3, 1],
                      fov_deg=float(np.degrees(p["yfov"])))

    def _light(self, light: dict, world: np.ndarray) -> None:
        color = np.asarray(light.get("color", [1, 1, 1]), dtype=np.float64)
        intensity = float(light.get("intensity", 1.0))
        if light.get("type") == "directional":
            # The light shines along its node's -z: it arrives from +z.
            self.scene.distant_lights.append(DistantLight(world[:3, 2], color * intensity,
                                                          source=f"{self.path}: light '{light.get('name', '')}'"))
        else:
            self.warn(f"KHR_lights_punctual '{light.get('type')}' lights are not supported; skipped")


def load_gltf(path: Path) -> Scene:
    return _Gltf(Path(path)).load()
