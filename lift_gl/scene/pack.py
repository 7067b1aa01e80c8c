"""Flatten a Scene into the arrays that shaders/lift/scene_data.glsl declares.

Triangles of all meshes are concatenated and reordered into BVH leaf order. Where the BVH
split large triangles (accel/presplit.py) a triangle is stored once per leaf that holds it:
every copy carries the same corners, normals, uvs, material and light-selection pdf, only the
first is in the light table and rasterized (`raster_rows`), and `tri_order` maps each row back
to its triangle.
Moving objects (motion blur) are stored where they are when the shutter opens, plus their
displacement until it closes (`motion`). One BVH serves the whole shutter interval: its
topology is built over the boxes the triangles sweep, and each node keeps two boxes, at
shutter open (in `bvh_nodes`) and at shutter close (in `motion`); a ray at time t tests the
blend of the two, which bounds every triangle below the node at t (motion is linear).

Coordinates are rebased before they are rounded to float32: the GPU sees world space minus
`origin` (the centre of the scene's bounds, kept in float64), so a scene far from the world
origin (1e5 away) keeps the precision it has at the origin. Cameras must be rebased with
`to_gpu_camera` too. Where that centre cannot hold every object in float32, validate_scene
chose the camera's position instead (Scene.gpu_origin, scene/precision.py).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, replace

import numpy as np

from ..accel.bvh import build_bvh, refit_boxes
from ..accel.cache import build_bvh_cached, resolve_builder, wide_layout_cached
from ..accel.wide import LAYOUTS
from .images import pack_images
from .instances import (InstanceTable, build_blas, instance_table, instance_world_bounds,
                        split_instances)
from .light_choice import light_uniforms
from .light_tree import build_light_tree, concat_bounds, sphere_bounds, triangle_bounds
from .loader import geometry_boxes
from .model import Camera, Scene
from .optics import internal_diffuse_reflectance

MATERIAL_CODES = {"diffuse": 0, "conductor": 1, "dielectric": 2, "plastic": 3}
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass
class PackedScene:
    # float32 (N, 8): the binary tree (accel/bvh.py); with bvh_width 4, (W, 32): the 4-wide
    # tree collapsed from it (accel/wide.py), what shaders compiled with LIFT_BVH_WIDTH read.
    bvh_nodes: np.ndarray
    tri_pos: np.ndarray  # float32 (T, 3, 4)
    tri_normal: np.ndarray  # float32 (T, 3, 4)
    tri_uv: np.ndarray  # float32 (T, 3, 4)
    tri_info: np.ndarray  # uint32 (T, 2)
    materials: np.ndarray  # float32 (M, 4, 4)
    lights: np.ndarray  # float32 (L, 4)
    spheres: np.ndarray  # float32 (S, 2, 4)
    bvh_depth: int
    bounds: np.ndarray  # (2, 3) bounds of everything, rebased (GPU coordinates)
    # Real counts: the arrays above hold one dummy row when empty (GL needs non-empty buffers).
    num_triangles: int
    num_spheres: int
    num_lights: int
    # Motion blur (shaders/lift/scene_data.glsl): rows 0 .. T+S-1 hold each primitive's
    # displacement from shutter open to close (xyz; triangles in BVH order, then spheres);
    # then two rows per BVH node, its box at shutter close (bmin.xyz, bmax.xyz). None when
    # nothing moves (has_motion False): see still_motion().
    motion: np.ndarray | None = None  # float32 (T + S + 2 N, 4)
    has_motion: bool = False
    # Textures and the environment map (images.py), and the uniforms that describe them and
    # the other lights (light_choice.py).
    images: np.ndarray = field(default_factory=lambda: np.zeros(1, np.uint32))
    uniforms: dict = field(default_factory=dict)
    origin: np.ndarray = None  # float64 (3,): world position of the GPU coordinates' zero
    # Each packed triangle's index in the meshes' concatenated order (before the BVH's
    # reordering): temporal reprojection matches triangles across frames with it.
    tri_order: np.ndarray | None = None  # int (T,)
    bvh_builder: str = "sah"  # which builder made the tree (accel/cache.py BUILDERS)
    bvh_width: int = 2  # children per node of bvh_nodes: 2 (binary) or 4 (accel/wide.py)
    bvh_quantized: bool = False  # 4-wide nodes with 8-bit child boxes (wide.quantize)
    bvh_stack: int = 0  # 4-wide: the deepest its traversal stack can get (WideBVH.stack_bound)
    bvh_levels: int = 0  # 4-wide: wide nodes on its longest root path (WideBVH.levels)
    # Instances (scene/instances.py): the world geometry's triangles and nodes come first,
    # each traced prototype's BLAS after them; `instances` holds the TLAS nodes and then one
    # record per traced instance (None: no instances, nothing compiled for them).
    world_triangles: int = -1  # triangles of the world BVH (-1: all of them)
    instances: np.ndarray | None = None  # float32 (R, 4)
    instance_table: InstanceTable | None = None
    instance_blas: dict | None = None  # prototype index -> (Blas, root node, first triangle)
    world_bounds: np.ndarray | None = None  # bounds of everything but the traced instances
    emitter_power: float = 0.0  # sum of luminance x area of the emitters (light_choice.py)
    # `lights` holds the light tree after its L entries (light_tree.py; shaders compiled with
    # LIFT_LIGHT_TREE pick lights by it): the option light_selection.
    light_tree: bool = False

    @property
    def num_instances(self) -> int:
        return 0 if self.instance_table is None else len(self.instance_table.order)

    @property
    def num_world_triangles(self) -> int:
        """Triangles in world space (the rest are the instances' BLAS triangles)."""
        return self.num_triangles if self.world_triangles < 0 else self.world_triangles

    @property
    def instance_draws(self) -> list:
        """(first triangle, triangles, first record, records) per G-buffer draw of instances."""
        return [] if self.instance_table is None else self.instance_table.draws
    # The rows the raster G-buffer draws, one per triangle (its first copy), when the BVH
    # repeats triangles (accel/presplit.py); None: every row, each triangle is stored once.
    raster_rows: np.ndarray | None = None  # uint32 (triangles,)
    num_source_triangles: int | None = None  # triangles before the BVH's repeats (None: num_triangles)

    def to_gpu_camera(self, camera: Camera) -> Camera:
        """The camera in the rebased coordinates the GPU uses."""
        origin = self.origin if self.origin is not None else np.zeros(3)
        return replace(camera, position=camera.position - origin, target=camera.target - origin)


def _as_float_bits(values) -> np.ndarray:
    return np.asarray(values, dtype=np.uint32).view(np.float32)


def pack_materials(scene: Scene) -> np.ndarray:
    out = np.zeros((max(len(scene.materials), 1), 4, 4), np.float32)
    for i, m in enumerate(scene.materials):
        out[i, 0, :3] = m.base_color
        out[i, 0, 3] = MATERIAL_CODES[m.type]
        out[i, 1, :3] = m.emission
        out[i, 1, 3] = m.alpha
        if m.type == "conductor" and m.distribution == "beckmann" and m.alpha > 0:
            out[i, 1, 3] = -m.alpha  # bsdf.glsl: a negative alpha marks Beckmann
        if m.eta is not None and m.k is not None:
            out[i, 2, :3] = m.eta
            out[i, 3, :3] = m.k
            if m.type == "conductor":
                out[i, 0, :3] = m.specular  # tints the Fresnel reflectance
        else:
            out[i, 2, :3] = -1.0  # Schlick with F0 = base_color
        out[i, 2, 3] = m.ior
        if m.type == "plastic":
            out[i, 2, 0] = internal_diffuse_reflectance(m.ior)
            out[i, 2, 1] = 1.0 if m.nonlinear else 0.0
            out[i, 3, :3] = m.specular
        out[i, 3, 3] = 0.0 if m.texture is None else m.texture + 1
    return out


def scene_origin(scene: Scene, extra_bounds: np.ndarray | None = None) -> np.ndarray:
    """The centre of the scene's bounds in float64 (zero for an empty scene); `extra_bounds`
    (2, 3): more that the scene holds (its traced instances)."""
    lo, hi = geometry_boxes(scene)
    if extra_bounds is not None:
        lo.append(extra_bounds[0])
        hi.append(extra_bounds[1])
    if not lo:
        return np.zeros(3)
    return 0.5 * (np.min(lo, axis=0) + np.max(hi, axis=0))


def mesh_corners(mesh, origin: np.ndarray):
    """One mesh's triangle corners: positions (float64, minus origin), shading normals
    (flat where the mesh has none) and texture coordinates, (T, 3, 3) / (T, 3, 3) / (T, 3, 2)."""
    corners = mesh.positions[mesh.indices] - origin  # float64 until here
    if mesh.normals is not None:
        normals = mesh.normals[mesh.indices]
    else:  # flat shading: the geometric normal at each corner
        n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        normals = np.repeat(n[:, None, :], 3, axis=1)
    uvs = mesh.uvs[mesh.indices] if mesh.uvs is not None else np.zeros((len(mesh.indices), 3, 2), np.float32)
    return corners, normals, uvs


def _triangles(scene: Scene, origin: np.ndarray):
    if not scene.meshes:
        return (np.zeros((0, 3, 3), np.float32), np.zeros((0, 3, 3), np.float32),
                np.zeros((0, 3, 2), np.float32), np.zeros(0, np.uint32), np.zeros((0, 3)))
    pos, nrm, uvs, mat, vel = [], [], [], [], []
    for mesh in scene.meshes:
        vel.append(np.broadcast_to(mesh.velocity if mesh.velocity is not None else np.zeros(3),
                                   (len(mesh.indices), 3)))
        corners, normals, tex = mesh_corners(mesh, origin)
        pos.append(corners)
        nrm.append(normals)
        uvs.append(tex)
        mat.append(np.full(len(mesh.indices), mesh.material, np.uint32))
    return (np.concatenate(pos).astype(np.float32), np.concatenate(nrm).astype(np.float32),
            np.concatenate(uvs).astype(np.float32), np.concatenate(mat), np.concatenate(vel))


def _pad4(a: np.ndarray) -> np.ndarray:
    out = np.zeros(a.shape[:-1] + (4,), np.float32)
    out[..., : a.shape[-1]] = a
    return out


def _shutter_motion(scene: Scene, velocity: np.ndarray):
    """(offset at shutter open, displacement from open to close) for velocities (N, 3)."""
    open_, close = scene.camera.shutter
    return velocity * open_, velocity * (close - open_)


def _boxes_at_open_and_close(bvh, open_positions: np.ndarray, displacement: np.ndarray):
    """Node rows with the boxes at shutter open, and two rows per node with the boxes at
    close. The GPU blends them with float rounding, so both are padded by a few ulps."""
    def padded(lo, hi):
        pad = 4 * np.spacing(np.maximum(np.abs(lo), np.abs(hi)))
        return lo - pad, hi + pad

    nodes = bvh.nodes.copy()
    nodes[:, 0:3], nodes[:, 4:7] = padded(*refit_boxes(bvh, open_positions))
    close = np.zeros((bvh.num_nodes, 2, 4), np.float32)
    close[:, 0, :3], close[:, 1, :3] = padded(*refit_boxes(bvh, open_positions + displacement[:, None, :]))
    return nodes, close.reshape(-1, 4)


def still_motion(packed: PackedScene) -> np.ndarray:
    """`motion` rows for a scene that does not move, for shaders compiled with HAS_MOTION
    anyway (every feature): no displacement, and node boxes at close = at open."""
    displacement = np.zeros((packed.num_triangles + packed.num_spheres, 4), np.float32)
    return np.concatenate([displacement, packed.bvh_nodes.reshape(-1, 4)])


def pack_scene(scene: Scene, cache_dir=None, origin=None, bvh_builder: str | None = None,
               bvh_splits=None, bvh_width=None, bvh_bins=None, bvh_slot_order=None,
               light_selection: str = "power") -> PackedScene:
    """`origin`: the world point that becomes the GPU's zero; default: the scene's centre.
    `bvh_builder`: see accel/cache.py BUILDERS (None: auto).
    `bvh_splits`: see accel/presplit.py resolve_splits (None: auto).
    `bvh_bins`: see accel/cache.py resolve_bins (None: auto).
    `bvh_width`: 2, 4 or 4q (None: 2; the renderer passes its device's choice, the option
    bvh_width of lift_gl/options.py). `bvh_slot_order`: the 4-wide nodes' order of children,
    area or build (None: area; the renderer passes its device's choice). Scenes with motion blur or traced
    instances keep the binary tree whatever is asked (the wide layout has no close boxes and no BLAS roots),
    and so does a tree the wide layout cannot hold (wide.wide_layout returns None; the layout of a
    large tree is cached beside its BVH, accel/cache.py wide_layout_cached).
    `light_selection`: "tree" appends the light tree to `lights` (light_tree.py), "power" not.
    Instances: those that must be are flattened into world meshes (scene/instances.py), the
    others traced through their prototypes' BLAS and a TLAS (the BLAS are not split)."""
    instanced, traced = scene, []
    if scene.instances:
        flat, traced = split_instances(scene)
        scene = dataclasses.replace(scene, meshes=list(scene.meshes) + flat, prototypes=[], instances=[])
    if origin is None and scene.gpu_origin is not None:  # the camera's position (scene/precision.py)
        origin = scene.gpu_origin
    if origin is None:
        origin = scene_origin(scene, instance_world_bounds(instanced, traced) if traced else None)
    origin = np.asarray(origin, dtype=np.float64)
    positions, normals, uvs, material_ids, tri_velocity = _triangles(scene, origin)
    has_motion = scene.has_motion
    tri_open, tri_move = _shutter_motion(scene, tri_velocity)
    if tri_open.any():  # where the shutter opens after time 0, things have moved already
        positions = (positions + tri_open[:, None, :]).astype(np.float32)
    bvh_input = positions
    if has_motion:
        # Corners at shutter open and at close: the BVH bounds the box each triangle sweeps.
        bvh_input = np.concatenate([positions, positions + tri_move[:, None, :].astype(np.float32)], axis=1)
    bvh_builder = resolve_builder(bvh_builder, len(bvh_input))
    bvh = (build_bvh_cached(bvh_input, cache_dir=cache_dir, builder=bvh_builder, splits=bvh_splits, bins=bvh_bins)
           if len(positions) else build_bvh(positions))
    order = bvh.order
    n_source = len(positions)
    positions, normals, uvs, material_ids = positions[order], normals[order], uvs[order], material_ids[order]
    T_world, S = len(positions), len(scene.spheres)
    # each world triangle's first row: the one copy that is a light and is rasterized
    raster_rows = np.unique(order, return_index=True)[1].astype(np.uint32) if T_world > n_source else None
    first_copy = np.ones(T_world, bool)
    if raster_rows is not None:
        first_copy[:] = False
        first_copy[raster_rows] = True
    world_positions = positions
    blas_of, blas_nodes = {}, []
    if traced:  # the prototypes' BLAS after the world's triangles and nodes
        positions, normals, uvs, material_ids = [positions], [normals], [uvs], [material_ids]
        node_count, tri_count = bvh.num_nodes, T_world
        for i in traced:
            k = instanced.instances[i].mesh
            if k in blas_of:
                continue
            blas = build_blas(instanced.prototypes[k], cache_dir=cache_dir)
            blas_of[k] = (blas, node_count, tri_count)
            blas_nodes.append(_offset_nodes(blas.nodes, node_count, tri_count))
            positions.append(blas.positions)
            normals.append(blas.normals)
            uvs.append(blas.uvs)
            material_ids.append(np.full(len(blas.positions), instanced.prototypes[k].material, np.uint32))
            node_count += len(blas.nodes)
            tri_count += len(blas.positions)
        positions, normals, uvs, material_ids = (np.concatenate(a) for a in (positions, normals, uvs, material_ids))
    T = len(positions)
    sphere_velocity = np.array([s.velocity if s.velocity is not None else np.zeros(3)
                                for s in scene.spheres]).reshape(S, 3)
    sphere_open, sphere_move = _shutter_motion(scene, sphere_velocity)
    bvh_nodes, motion = bvh.nodes, None
    if has_motion:
        bvh_nodes, close_boxes = _boxes_at_open_and_close(bvh, world_positions, tri_move[order].astype(np.float32))
        displacement = np.zeros((T + S, 4), np.float32)
        displacement[:T_world, :3] = tri_move[order]  # instanced triangles do not move
        displacement[T:, :3] = sphere_move
        motion = np.concatenate([displacement, close_boxes] + [b.reshape(-1, 4) for b in blas_nodes])
    if blas_nodes:
        bvh_nodes = np.concatenate([bvh_nodes] + blas_nodes)
    layout = "2" if bvh_width is None else str(bvh_width)
    if layout not in LAYOUTS:
        raise ValueError(f"bvh_width must be one of {', '.join(LAYOUTS)}, not {bvh_width!r}")
    wide = None
    if layout != "2" and not has_motion and not blas_nodes and T_world:
        wide = wide_layout_cached(bvh_nodes, layout, cache_dir=cache_dir, slot_order=bvh_slot_order or "area")
    if wide is not None:
        bvh_nodes = wide.rows

    # Light selection proportional to emitted power (luminance x area); pi is common to all.
    emission = np.array([m.emission for m in scene.materials]).reshape(-1, 3) if scene.materials else np.zeros((0, 3))
    light_prims, light_power, light_area, light_bounds = [], [], [], []
    if T_world:  # instanced triangles never emit: emissive instances are flattened
        p = world_positions.astype(np.float64)  # float32's squares overflow beyond edges of 1e19
        tri_area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        tri_power = (emission[material_ids[:T_world]] @ LUMINANCE) * tri_area
        emissive = np.nonzero((tri_power > 0) & first_copy)[0]
        # in the order of the input triangles, not the tree's: a light's index (the random
        # number that picks it) does not depend on how the BVH was built
        emissive = emissive[np.argsort(order[emissive], kind="stable")]
        light_prims += list(emissive)
        light_power += list(tri_power[emissive])
        light_area += list(tri_area[emissive])
        if light_selection == "tree" and len(emissive):
            light_bounds.append(triangle_bounds(world_positions[emissive], tri_move[order][emissive] if has_motion
                                                else None, emission[material_ids[emissive]] @ LUMINANCE))
    emissive_spheres = []
    for i, s in enumerate(scene.spheres):
        area = 4.0 * np.pi * s.radius ** 2
        power = float(emission[s.material] @ LUMINANCE) * area
        if power > 0:
            light_prims.append(T + i)
            light_power.append(power)
            light_area.append(area)
            emissive_spheres.append(i)
    if light_selection == "tree" and emissive_spheres:
        k = np.array(emissive_spheres)
        light_bounds.append(sphere_bounds(
            [scene.spheres[i].center - origin + sphere_open[i] for i in k], [scene.spheres[i].radius for i in k],
            sphere_move[k] if has_motion else None, emission[[scene.spheres[i].material for i in k]] @ LUMINANCE))
    light_power = np.asarray(light_power, np.float64)
    select_pdf = light_power / light_power.sum() if len(light_power) else light_power
    cdf = np.cumsum(select_pdf)
    if len(cdf):
        cdf[-1] = 1.0
    lights = np.zeros((max(len(light_prims), 1), 4), np.float32)
    lights[: len(light_prims), 0] = _as_float_bits(light_prims)
    lights[: len(light_prims), 1] = cdf
    lights[: len(light_prims), 2] = select_pdf
    lights[: len(light_prims), 3] = light_area
    if light_bounds:
        lights = np.concatenate([lights, build_light_tree(concat_bounds(light_bounds), np.array(light_prims))])
    prim_select_pdf = np.zeros(T + S, np.float32)
    prim_select_pdf[np.asarray(light_prims, dtype=np.int64)] = select_pdf
    if raster_rows is not None:  # every copy of an emissive triangle: its light's pdf (MIS)
        prim_select_pdf[:T_world] = prim_select_pdf[raster_rows[order]]

    tri_info = np.zeros((max(T, 1), 2), np.uint32)
    tri_info[:T, 0] = material_ids
    tri_info[:T, 1] = prim_select_pdf[:T].view(np.uint32)

    spheres = np.zeros((max(S, 1), 2, 4), np.float32)
    for i, s in enumerate(scene.spheres):
        spheres[i, 0, :3] = s.center - origin + sphere_open[i]
        spheres[i, 0, 3] = s.radius
        spheres[i, 1, 0] = _as_float_bits([s.material])[0]
        spheres[i, 1, 1] = prim_select_pdf[T + i:T + i + 1].view(np.uint32).view(np.float32)[0]

    # Everything the scene holds at any time the shutter is open.
    swept = bvh_input.reshape(-1, 3)
    lo = [swept.min(0)] if T_world else []
    hi = [swept.max(0)] if T_world else []
    for i, s in enumerate(scene.spheres):
        for c in (s.center - origin + sphere_open[i], s.center - origin + sphere_open[i] + sphere_move[i]):
            lo.append(c - s.radius)
            hi.append(c + s.radius)
    world_bounds = np.array([np.min(lo, axis=0), np.max(hi, axis=0)]) if lo else None
    table = instance_table(instanced, traced, blas_of, origin) if traced else None
    bounds = _bounds_with_instances(world_bounds, table)

    def nonempty(a, shape):
        return a if len(a) else np.zeros(shape, np.float32)

    images, uniforms = pack_images(scene)
    uniforms.update(light_uniforms(scene, float(np.sum(light_power)), bounds))

    return PackedScene(
        bvh_nodes=bvh_nodes,
        tri_pos=nonempty(_pad4(positions), (1, 3, 4)),
        tri_normal=nonempty(_pad4(normals), (1, 3, 4)),
        tri_uv=nonempty(_pad4(uvs), (1, 3, 4)),
        tri_info=tri_info,
        materials=pack_materials(scene),
        lights=lights,
        spheres=spheres,
        bvh_depth=bvh.depth,
        bounds=bounds,
        num_triangles=T,
        num_spheres=S,
        num_lights=len(light_prims),
        motion=motion,
        has_motion=has_motion,
        images=images,
        uniforms=uniforms,
        origin=origin,
        tri_order=np.asarray(order[:T_world]),
        bvh_builder=bvh_builder,
        bvh_width=2 if wide is None else wide.width,
        bvh_quantized=wide is not None and wide.quantized,
        bvh_stack=0 if wide is None else wide.stack_bound,
        bvh_levels=0 if wide is None else wide.levels,
        world_triangles=T_world if traced else -1,
        instances=table.rows if table is not None else None,
        instance_table=table,
        instance_blas=blas_of or None,
        world_bounds=world_bounds,
        emitter_power=float(np.sum(light_power)),
        raster_rows=raster_rows,
        num_source_triangles=n_source,
        light_tree=bool(light_bounds),
    )


def _offset_nodes(nodes: np.ndarray, node_base: int, tri_base: int) -> np.ndarray:
    """A BLAS's nodes placed at node_base in the node array, its triangles at tri_base."""
    out = nodes.copy()
    first = out[:, 3].view(np.uint32)
    leaf = out[:, 7].view(np.uint32) > 0
    first += np.where(leaf, tri_base, node_base).astype(np.uint32)
    return out


def _bounds_with_instances(world_bounds, table) -> np.ndarray:
    boxes = [b for b in (world_bounds, None if table is None else table.bounds) if b is not None]
    if not boxes:
        return np.array([[-1.0] * 3, [1.0] * 3])
    return np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])


def repack_instances(packed: PackedScene, scene: Scene) -> PackedScene:
    """`packed` with the instances of `scene` placed anew: only the TLAS and the instance
    records are rebuilt (no BLAS, no world BVH), at the same GPU origin. The scene must
    differ from the packed one in instance transforms only, and trace the same instances."""
    flat, traced = split_instances(scene)
    table = instance_table(scene, traced, packed.instance_blas, packed.origin)
    bounds = _bounds_with_instances(packed.world_bounds, table)
    uniforms = dict(packed.uniforms)
    uniforms.update(light_uniforms(scene, packed.emitter_power, bounds))
    return replace(packed, instances=table.rows, instance_table=table, bounds=bounds, uniforms=uniforms)
