"""Random training scenes for the denoiser, built with the project's own Scene model.

`random_scene(seed)` gives one scene: a procedural room (some walls left open to the sky),
objects from the repo's meshes and procedural shapes, materials from every BSDF family
(diffuse, plastic, smooth and rough conductors with GGX or Beckmann, smooth and rough glass,
textured ones), area lights, emissive spheres, an environment (constant or the sky map) and
a sun, and a random camera inside the room looking at something. The same seed always gives
the same scene; training uses seeds from TRAIN_SEEDS, validation from VALIDATION_SEEDS, and
the two ranges never meet.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from ...scene import primitives as prim
from ...scene.model import Camera, DistantLight, Environment, Material, Mesh, Scene, Texture
from ...scene.toml_loader import METALS as TOML_METALS

REPO = Path(__file__).resolve().parents[3]
REPO_MESHES = ("tests/data/icosphere_smooth.obj", "scenes/stress/mesh_clean.ply")
CHECKER = "assets/textures/checker.png"
SKY = "assets/env/sky.exr"

TRAIN_SEEDS = range(0, 1_000_000)
VALIDATION_SEEDS = range(1_000_000, 1_000_100)
# The metals drawn from (their complex IORs from the TOML loader's table); the order matters:
# a seed's scene, hence the shipped model's training set, depends on it.
METALS = {name: TOML_METALS[name] for name in ("gold", "silver", "copper")}


@lru_cache(maxsize=None)
def _repo_mesh(rel: str) -> Mesh:
    from ...scene.mesh_io import load_mesh_file
    return load_mesh_file(REPO / rel)


@lru_cache(maxsize=1)
def _checker_pixels() -> np.ndarray:
    from PIL import Image
    return np.asarray(Image.open(REPO / CHECKER).convert("RGBA"))


@lru_cache(maxsize=1)
def _sky_image() -> np.ndarray:
    from ...image_io import read_image
    return read_image(REPO / SKY)


def _colour(rng, lo=0.05, hi=0.9) -> np.ndarray:
    """A random albedo: a hue times a brightness, so that saturated and grey both occur."""
    base = rng.uniform(0, 1, 3)
    if rng.random() < 0.3:
        base = np.full(3, base.mean())
    return lo + (hi - lo) * base ** rng.uniform(0.5, 2.0)


def _stripes_texture(rng) -> np.ndarray:
    """A procedural RGBA texture (stripes or noise blobs) so that textures vary beyond the checker."""
    n = 64
    y, x = np.mgrid[0:n, 0:n] / n
    a, b = _colour(rng), _colour(rng)
    if rng.random() < 0.5:
        f = rng.integers(2, 9)
        t = (np.sin(2 * np.pi * f * (x * np.cos(rng.uniform(0, np.pi)) + y)) > 0)[..., None]
    else:
        t = rng.uniform(0, 1, (8, 8))
        t = np.kron(t, np.ones((8, 8)))[..., None]
    rgb = a * t + b * (1 - t)
    return np.concatenate([(255 * rgb).astype(np.uint8), np.full((n, n, 1), 255, np.uint8)], axis=2)


def random_material(rng, name: str, textures: list) -> Material:
    kind = rng.choice(["diffuse", "diffuse", "textured", "plastic", "conductor", "rough_conductor",
                       "dielectric", "rough_dielectric"])
    if kind in ("diffuse", "textured"):
        m = Material(name, "diffuse", base_color=_colour(rng))
        if kind == "textured":
            pixels = _checker_pixels() if rng.random() < 0.4 else _stripes_texture(rng)
            textures.append(Texture(f"{name}_tex", pixels))
            m.texture = len(textures) - 1
            m.base_color = np.full(3, rng.uniform(0.5, 1.0))
        return m
    if kind == "plastic":
        alpha = 0.0 if rng.random() < 0.4 else float(rng.uniform(0.02, 0.4))
        return Material(name, "plastic", base_color=_colour(rng), alpha=alpha, ior=float(rng.uniform(1.3, 1.7)),
                        nonlinear=bool(rng.random() < 0.3))
    if kind in ("conductor", "rough_conductor"):
        alpha = 0.0 if kind == "conductor" else float(rng.uniform(0.02, 0.5))
        dist = "beckmann" if (alpha > 0 and rng.random() < 0.3) else "ggx"
        if rng.random() < 0.5:
            eta, k = METALS[rng.choice(list(METALS))]
            return Material(name, "conductor", alpha=alpha, eta=eta, k=k, distribution=dist)
        return Material(name, "conductor", base_color=_colour(rng, 0.3, 1.0), alpha=alpha, distribution=dist)
    alpha = 0.0 if kind == "dielectric" else float(rng.uniform(0.02, 0.3))
    tint = np.ones(3) if rng.random() < 0.6 else _colour(rng, 0.5, 1.0)
    return Material(name, "dielectric", base_color=tint, alpha=alpha, ior=float(rng.uniform(1.3, 1.8)))


def _cylinder(radius=0.5, height=1.0, segments=24) -> Mesh:
    """A capped cylinder on y = 0..height with smooth side normals."""
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([radius * np.cos(a), np.zeros_like(a), radius * np.sin(a)], axis=1)
    side = np.concatenate([ring, ring + [0, height, 0]])
    side_n = np.concatenate([ring, ring]) / radius
    i = np.arange(segments)
    j = (i + 1) % segments
    side_idx = np.concatenate([np.stack([i, j + segments, j], 1), np.stack([i, i + segments, j + segments], 1)])
    top_c = len(side)
    caps = np.concatenate([side, [[0, height, 0], [0, 0, 0]]])
    normals = np.concatenate([side_n, [[0, 1, 0], [0, -1, 0]]])
    top = np.stack([np.full(segments, top_c), j + segments, i + segments], 1)
    bottom = np.stack([np.full(segments, top_c + 1), i, j], 1)
    # Caps reuse the side vertices, so their normals are smooth: good enough as a guide shape.
    return Mesh("cylinder", caps, np.concatenate([side_idx, top, bottom]), 0, normals=normals.astype(np.float32))


def _torus(r_major=0.5, r_minor=0.18, nu=32, nv=16) -> Mesh:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, nu, endpoint=False), np.linspace(0, 2 * np.pi, nv, endpoint=False),
                       indexing="ij")
    centre = np.stack([r_major * np.cos(u), np.zeros_like(u), r_major * np.sin(u)], -1)
    normal = np.stack([np.cos(v) * np.cos(u), np.sin(v), np.cos(v) * np.sin(u)], -1)
    pos = (centre + r_minor * normal).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = i * nv + j, ((i + 1) % nu) * nv + j
    c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
    idx = np.concatenate([np.stack([a, d, b], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])
    return Mesh("torus", pos, idx, 0, normals=normal.reshape(-1, 3).astype(np.float32))


def _place(mesh: Mesh, material: int, translate, rotate, scale) -> Mesh:
    placed = prim.transform_mesh(mesh, prim.trs_matrix(translate, rotate, scale))
    placed.material = material
    return placed


def random_scene(seed: int, max_depth: int = 8) -> Scene:
    rng = np.random.default_rng(seed)
    materials: list[Material] = []
    textures: list[Texture] = []
    meshes, spheres = [], []

    def material(m: Material) -> int:
        materials.append(m)
        return len(materials) - 1

    # The room: floor always; each wall and the ceiling present with some probability.
    w, d, h = rng.uniform(3, 8), rng.uniform(3, 8), rng.uniform(2.2, 4.5)
    wall = material(Material("walls", "diffuse", base_color=_colour(rng, 0.2, 0.85)))
    floor = material(random_material(rng, "floor", textures)
                     if rng.random() < 0.5 else Material("floor", "diffuse", base_color=_colour(rng)))
    if materials[floor].type == "dielectric":  # a glass floor hides the room's layout: use paint
        materials[floor] = Material("floor", "diffuse", base_color=_colour(rng))
    meshes.append(prim.quad_centered((0, 0, 0), (0, 0, d), (w, 0, 0), floor, "floor"))
    closed = rng.random() < 0.55
    walls = [((0, h / 2, -d / 2), (w, 0, 0), (0, h, 0)), ((0, h / 2, d / 2), (0, h, 0), (w, 0, 0)),
             ((-w / 2, h / 2, 0), (0, 0, d), (0, h, 0)), ((w / 2, h / 2, 0), (0, h, 0), (0, 0, d))]
    for k, (c, u, v) in enumerate(walls):
        if closed or rng.random() < 0.5:
            coloured = rng.random() < 0.3
            mat = material(Material(f"wall{k}", "diffuse", base_color=_colour(rng))) if coloured else wall
            meshes.append(prim.quad_centered(c, u, v, mat, f"wall{k}"))
    ceiling = closed or rng.random() < 0.3
    if ceiling:
        meshes.append(prim.quad_centered((0, h, 0), (w, 0, 0), (0, 0, d), wall, "ceiling"))

    # Objects on the floor (or floating), from the repo's meshes and procedural shapes.
    shapes = [lambda: _repo_mesh(REPO_MESHES[0]), lambda: _repo_mesh(REPO_MESHES[1]), _cylinder, _torus,
              lambda: prim.box()]
    centres = []
    for k in range(int(rng.integers(2, 8))):
        mat = material(random_material(rng, f"obj{k}", textures))
        x, z = rng.uniform(-0.4, 0.4) * w, rng.uniform(-0.4, 0.4) * d
        s = rng.uniform(0.3, 1.1)
        if rng.random() < 0.3:
            spheres.append(prim.sphere((x, s * rng.uniform(0.5, 2.0), z), s * 0.5, mat))
            centres.append(spheres[-1].center)
            continue
        shape = shapes[int(rng.integers(len(shapes)))]()
        lo = shape.positions.min(axis=0)
        y = -lo[1] * s + (rng.uniform(0, 1.0) if rng.random() < 0.2 else 0.0)
        scale = s * rng.uniform(0.6, 1.4, 3) if rng.random() < 0.4 else s
        meshes.append(_place(shape, mat, (x, y, z), (0, rng.uniform(0, 360), 0), scale))
        centres.append(meshes[-1].positions.mean(axis=0))

    # Lights: area quads under the ceiling, emissive spheres, the sky or a constant environment, a sun.
    environment, distant = None, []
    power = rng.uniform(0.5, 3.0)
    n_area = int(rng.integers(1, 3)) if ceiling else int(rng.integers(0, 2))
    for k in range(n_area):
        size = rng.uniform(0.3, 1.5, 2)
        emission = _colour(rng, 0.6, 1.0) * rng.uniform(3, 20) * power / (size[0] * size[1]) ** 0.5
        mat = material(Material(f"light{k}", "diffuse", base_color=np.zeros(3), emission=emission))
        c = (rng.uniform(-0.3, 0.3) * w, h - 0.01 if ceiling else rng.uniform(1.5, 3.5), rng.uniform(-0.3, 0.3) * d)
        # cross(u, v) = -y: the light faces down
        meshes.append(prim.quad_centered(c, (size[0], 0, 0), (0, 0, size[1]), mat, f"light{k}"))
    if rng.random() < 0.35 or n_area == 0:
        mat = material(Material("bulb", "diffuse", base_color=np.zeros(3),
                                emission=_colour(rng, 0.6, 1.0) * rng.uniform(5, 40) * power))
        spheres.append(prim.sphere((rng.uniform(-0.3, 0.3) * w, rng.uniform(1.0, h - 0.3), rng.uniform(-0.3, 0.3) * d),
                                   rng.uniform(0.05, 0.25), mat))
    if not ceiling or rng.random() < 0.2:
        if rng.random() < 0.5:
            environment = Environment(np.full(3, rng.uniform(0.3, 2.0)), image=_sky_image(),
                                      to_world=prim.euler_matrix((0, rng.uniform(0, 360), 0))[:3, :3])
        else:
            environment = Environment(_colour(rng, 0.3, 1.0) * rng.uniform(0.2, 1.5))
        if rng.random() < 0.5:
            direction = (rng.uniform(-1, 1), rng.uniform(0.3, 1.0), rng.uniform(-1, 1))
            distant.append(DistantLight(direction, _colour(rng, 0.7, 1.0) * rng.uniform(1, 6)))

    # The camera: inside the room, looking at an object or across the room.
    eye = np.array([rng.uniform(-0.45, 0.45) * w, rng.uniform(0.3, 0.9) * h, rng.uniform(-0.45, 0.45) * d])
    if rng.random() < 0.7:
        target = centres[int(rng.integers(len(centres)))]
    else:
        target = np.array([rng.uniform(-0.5, 0.5) * w, rng.uniform(0.2, 0.8) * h, rng.uniform(-0.5, 0.5) * d])
    if np.linalg.norm(target - eye) < 0.3:
        target = eye + np.array([0.0, -0.2, -1.0])
    camera = Camera(eye, target, fov_deg=float(rng.uniform(30, 70)))
    return Scene(camera, materials, meshes, spheres, environment, textures, distant, max_depth=max_depth,
                 film_size=(256, 256))
