"""The scene model every loader produces and every pass consumes.

Units and spaces: all geometry is in world space (loaders apply transforms), lengths in
scene units, colours are linear RGB, radiance in W/(sr m^2) per channel.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MATERIAL_TYPES = ("diffuse", "conductor", "dielectric", "plastic")


def _optional_vec3(v) -> np.ndarray | None:
    return None if v is None else np.asarray(v, dtype=np.float64).reshape(3)


@dataclass
class Camera:
    position: np.ndarray
    target: np.ndarray
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    fov_deg: float = 40.0  # vertical field of view
    aperture_radius: float = 0.0  # thin lens; 0 is a pinhole
    focus_distance: float | None = None  # None: distance to target
    # Scene times at which the shutter opens and closes; objects with a velocity move
    # between them (motion blur). Time is in the same unit as the objects' velocities.
    shutter: tuple[float, float] = (0.0, 1.0)
    source: str = ""  # "file:line" where it was defined, for error messages

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=np.float64)
        self.target = np.asarray(self.target, dtype=np.float64)
        self.up = np.asarray(self.up, dtype=np.float64)

    @property
    def focus(self) -> float:
        if self.focus_distance is not None:
            return float(self.focus_distance)
        return float(np.linalg.norm(self.target - self.position))

    def basis(self):
        """Right, up, forward unit vectors (right-handed, camera looks along forward)."""
        forward = self.target - self.position
        forward = forward / np.linalg.norm(forward)
        right = _cross(forward, self.up)
        right = right / np.linalg.norm(right)
        up = _cross(right, forward)
        return right, up, forward


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of two 3-vectors, the same products and differences (so the same bits) without
    its general-axis machinery, which cost the host 0.2 ms a frame (the camera's basis is
    taken a few times a frame)."""
    a0, a1, a2 = (float(v) for v in a)
    b0, b1, b2 = (float(v) for v in b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


@dataclass
class Material:
    """One surface model. `type` picks the BSDF:

    - diffuse: Lambertian with albedo `base_color`.
    - conductor: GGX microfacet metal with GGX `alpha` (0 = smooth mirror; `distribution`
      "beckmann" for Beckmann's); Fresnel from the complex IOR (`eta`, `k`) where given,
      else Schlick with F0 = `base_color`.
    - dielectric: glass with index `ior`; smooth when `alpha` is 0, else GGX rough glass;
      `base_color` tints transmission.
    - plastic: a diffuse base of albedo `base_color` under a dielectric coat of index `ior`,
      smooth when `alpha` is 0, else GGX-rough; `nonlinear` accounts for the colour shift
      of light scattered inside the coat (Mitsuba's plastic option of that name).
    Any type may emit: `emission` is the radiance leaving its front side.
    `specular` tints the specular reflection of conductors given by (`eta`, `k`) and of the
    plastic coat. `texture` (an index into Scene.textures) multiplies `base_color` by an
    image looked up at the surface's texture coordinates.
    """

    name: str
    type: str = "diffuse"
    base_color: np.ndarray = field(default_factory=lambda: np.array([0.8, 0.8, 0.8]))
    alpha: float = 0.0
    eta: np.ndarray | None = None
    k: np.ndarray | None = None
    ior: float = 1.5
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    source: str = ""  # "file:line" where it was defined, for error messages
    specular: np.ndarray = field(default_factory=lambda: np.ones(3))
    texture: int | None = None  # base colour texture: index into Scene.textures
    nonlinear: bool = False  # plastic only
    distribution: str = "ggx"  # rough conductors: "ggx" or "beckmann"

    def __post_init__(self):
        self.base_color = np.asarray(self.base_color, dtype=np.float64)
        self.emission = np.asarray(self.emission, dtype=np.float64)
        self.specular = np.asarray(self.specular, dtype=np.float64)
        if self.eta is not None:
            self.eta = np.asarray(self.eta, dtype=np.float64)
        if self.k is not None:
            self.k = np.asarray(self.k, dtype=np.float64)

    @property
    def is_emissive(self) -> bool:
        return bool(np.any(self.emission > 0))


@dataclass
class Mesh:
    """A triangle mesh already transformed to world space."""

    name: str
    positions: np.ndarray  # float64 (V, 3): far from the origin float32 would round the mesh
    indices: np.ndarray  # int32 (T, 3)
    material: int  # index into Scene.materials
    normals: np.ndarray | None = None  # float32 (V, 3), shading normals
    uvs: np.ndarray | None = None  # float32 (V, 2)
    source: str = ""
    # Linear motion: world units per unit of scene time. The positions above are where the
    # mesh is at time 0; at time t it is translated by t * velocity. None: it stays put.
    velocity: np.ndarray | None = None
    # The [[objects]] table of a .toml scene this was built from (None for other formats):
    # the scene editor edits it and rebuilds the object, the writer saves it back.
    authored: dict | None = None

    def __post_init__(self):
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float64).reshape(-1, 3)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.int32).reshape(-1, 3)
        if self.normals is not None:
            self.normals = np.ascontiguousarray(self.normals, dtype=np.float32).reshape(-1, 3)
        if self.uvs is not None:
            self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float32).reshape(-1, 2)
        self.velocity = _optional_vec3(self.velocity)


@dataclass
class Sphere:
    """An analytic sphere (exact silhouettes and normals, as furnace tests need)."""

    center: np.ndarray
    radius: float
    material: int
    source: str = ""
    velocity: np.ndarray | None = None  # as Mesh.velocity: `center` is at time 0
    authored: dict | None = None  # as Mesh.authored

    def __post_init__(self):
        self.center = np.asarray(self.center, dtype=np.float64)
        self.velocity = _optional_vec3(self.velocity)


@dataclass
class Texture:
    """An image for a material's base colour: uint8 RGBA (H, W, 4), row 0 = top of the image.

    Texture coordinates follow OpenGL: (0, 0) is the bottom-left corner of the image, and
    the image repeats outside [0, 1]. `srgb` images are decoded to linear before filtering.
    """

    name: str
    pixels: np.ndarray
    srgb: bool = True
    source: str = ""

    def __post_init__(self):
        self.pixels = np.ascontiguousarray(self.pixels, dtype=np.uint8)


@dataclass
class Environment:
    """Radiance arriving from every direction that escapes the scene: constant `radiance`,
    or, with an `image`, the image times `radiance` (a scale per channel).

    The image is latitude-longitude, linear RGB float32 (H, W, 3), row 0 = top. A direction
    d in the map's own frame, d_map = inverse(to_world) @ d_world, is at
    u = atan2(d.x, -d.z) / 2pi (wrapped to [0, 1)), v = acos(d.y) / pi (Mitsuba's convention:
    +y is the top row, -z the left edge); texel (x, y) has its centre at ((x + .5) / W,
    (y + .5) / H).
    """

    radiance: np.ndarray
    image: np.ndarray | None = None
    to_world: np.ndarray = field(default_factory=lambda: np.eye(3))
    source: str = ""
    image_file: str = ""  # the map's file, for messages

    def __post_init__(self):
        self.radiance = np.asarray(self.radiance, dtype=np.float64)
        self.to_world = np.asarray(self.to_world, dtype=np.float64).reshape(3, 3)
        if self.image is not None:
            self.image = np.ascontiguousarray(self.image, dtype=np.float32)


@dataclass(frozen=True)
class PixelFilter:
    """The film's reconstruction filter, as the scene file asks for it: `kind` "box",
    "triangle" or "gaussian", `radius` (x, y) in pixels of the scene's film (`Scene.film_size`),
    `alpha` the gaussian's falloff (pbrt-v3: exp(-alpha x^2) minus its value at the radius).
    Renders importance-sample the subpixel position from it (lift_gl/passes/pixel_filter.py)."""

    kind: str = "box"
    radius: tuple[float, float] = (0.5, 0.5)
    alpha: float = 2.0
    source: str = ""


def film_filter(kind: str, radius, alpha: float = 2.0, source: str = "") -> PixelFilter | None:
    """The scene's PixelFilter as the importers keep it: None for a box of half a pixel, which
    is what every render does without a filter (a box over each rendered pixel)."""
    radius = tuple(float(v) for v in radius)
    if kind == "box" and radius == (0.5, 0.5):
        return None
    return PixelFilter(kind, radius, alpha=alpha, source=source)


@dataclass
class DistantLight:
    """A directional (delta) light: `irradiance` on a surface facing it, arriving from
    `direction` (unit, world space, pointing towards the light)."""

    direction: np.ndarray
    irradiance: np.ndarray
    source: str = ""

    def __post_init__(self):
        d = np.asarray(self.direction, dtype=np.float64)
        self.direction = d / np.linalg.norm(d)
        self.irradiance = np.asarray(self.irradiance, dtype=np.float64)


@dataclass
class Instance:
    """A mesh of Scene.prototypes placed in the world by a 4x4 affine `transform` (object to
    world). The renderer builds the prototype's BVH once and traces every instance of it
    through a top-level tree (lift_gl/scene/instances.py, docs/instancing.md)."""

    mesh: int  # index into Scene.prototypes
    transform: np.ndarray  # float64 (4, 4), object space to world space; last row 0 0 0 1
    material: int | None = None  # None: the prototype's own material
    name: str = ""
    source: str = ""

    def __post_init__(self):
        self.transform = np.asarray(self.transform, dtype=np.float64).reshape(4, 4)


@dataclass
class Scene:
    camera: Camera
    materials: list[Material] = field(default_factory=list)
    meshes: list[Mesh] = field(default_factory=list)
    spheres: list[Sphere] = field(default_factory=list)
    environment: Environment | None = None
    textures: list[Texture] = field(default_factory=list)
    distant_lights: list[DistantLight] = field(default_factory=list)
    # Meshes drawn only where `instances` place them (in their own object space), and the
    # instances. Scenes without instances leave both empty and compile no instance code.
    prototypes: list[Mesh] = field(default_factory=list)
    instances: list[Instance] = field(default_factory=list)
    max_depth: int = 16  # path length limit the scene file asks for
    film_size: tuple[int, int] = (256, 256)  # width, height the scene file asks for
    pixel_filter: PixelFilter | None = None  # None: a box over each rendered pixel
    path: Path | None = None
    # The world point that becomes the GPU coordinates' zero, where validate_scene found that the
    # centre of the scene's bounds cannot hold every object in float32 (scene/precision.py);
    # None: that centre (pack_scene computes it).
    gpu_origin: np.ndarray | None = None

    @property
    def has_motion(self) -> bool:
        """Whether anything moves while the shutter is open (motion blur is visible)."""
        open_, close = self.camera.shutter
        return close > open_ and any(o.velocity is not None and bool(np.any(o.velocity != 0))
                                     for o in (*self.meshes, *self.spheres))

    @property
    def triangle_count(self) -> int:
        return int(sum(len(m.indices) for m in self.meshes))

    def material_index(self, name: str) -> int:
        for i, m in enumerate(self.materials):
            if m.name == name:
                return i
        raise KeyError(name)
