"""Two-level acceleration: meshes placed many times (Scene.instances), packed for the GPU.

Each prototype mesh that an instance uses gets a BVH of its own, the BLAS, built once in its
object space (and cached on disk as every BVH is). Its nodes and triangles are appended to
the scene's arrays after the world geometry's, so the split heap (split.py) and every
accessor of shaders/lift/scene_data.glsl serve them unchanged. The instances get a small
top-level tree, the TLAS, over their world boxes; `instances` holds the TLAS nodes and then
one record per instance (its transforms and BLAS), and is all that a moving instance
rewrites: no BLAS is rebuilt (`repack_instances`).

Which instances are traced and which are flattened (copied into world space as ordinary
meshes): an instance whose material emits is flattened, because light sampling picks world
triangles (lights.glsl); so is one whose prototype moves while the shutter is open (motion
blur moves world triangles). `flatten_instances` flattens all of them: the fallback for
passes that do not traverse a TLAS (OpenCL plugins) and the tests' reference.

Record layout (INSTANCE_ROWS vec4 rows, shaders/lift/bvh.glsl reads it):
    rows 0-2: object -> GPU world transform, rows of a 3x4 matrix
    rows 3-5: GPU world -> object transform, rows of a 3x4 matrix
    row 6:    uint bits (BLAS root node, material or NO_MATERIAL, prototype index, 1 if the
              transform mirrors, else 0)
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..accel.bvh import build_bvh
from ..accel.cache import build_bvh_cached
from ..errors import SceneError
from .model import Instance, Mesh, Scene
from .primitives import transform_mesh

INSTANCE_ROWS = 7
NO_MATERIAL = 0xFFFFFFFF
# The G-buffer's visibility texel keeps the material in 16 bits and the instance + 1 in the
# other 16 (shaders/passes/gbuffer.frag): instanced scenes are limited to these counts.
MAX_INSTANCES = 0xFFFF - 1
MAX_MATERIALS = 0xFFFF


def check_transform(m: np.ndarray, what: str, where: str = "") -> np.ndarray:
    """`m` as a float64 4x4 affine matrix, or a SceneError naming `where` ("file:line")."""
    from .validate import _where, affine_problem  # late: validate imports the model

    problem = affine_problem(m)
    if problem:
        raise SceneError(f"{what}: {problem}", *_where(where, None))
    m = np.asarray(m, dtype=np.float64)
    linear = m[:3, :3]
    scale = float(np.abs(linear).max())
    if not scale > 0 or abs(np.linalg.det(linear)) <= 1e-12 * scale ** 3:
        raise SceneError(f"{what}: the transform is singular (it flattens the mesh; determinant "
                         f"{np.linalg.det(linear):.3g})", *_where(where, None))
    return m


def instance_material(scene: Scene, inst: Instance) -> int:
    return scene.prototypes[inst.mesh].material if inst.material is None else inst.material


def instance_mesh(scene: Scene, inst: Instance) -> Mesh:
    """The instance as an ordinary world-space mesh (its prototype transformed)."""
    proto = scene.prototypes[inst.mesh]
    mesh = transform_mesh(proto, inst.transform)
    mesh.name = inst.name or proto.name
    mesh.material = instance_material(scene, inst)
    mesh.source = inst.source or proto.source
    mesh.velocity = proto.velocity
    return mesh


def must_flatten(scene: Scene, inst: Instance) -> bool:
    """Emitters and meshes moving within the shutter: see the module docstring."""
    proto = scene.prototypes[inst.mesh]
    moving = proto.velocity is not None and bool(np.any(proto.velocity != 0))
    return scene.materials[instance_material(scene, inst)].is_emissive or moving


def split_instances(scene: Scene) -> tuple[list[Mesh], list[int]]:
    """(the world meshes of the instances that are flattened, indices of those traced)."""
    flat, traced = [], []
    for i, inst in enumerate(scene.instances):
        if not len(scene.prototypes[inst.mesh].indices):
            continue  # nothing to draw
        if must_flatten(scene, inst):
            flat.append(instance_mesh(scene, inst))
        else:
            traced.append(i)
    return flat, traced


def flatten_instances(scene: Scene) -> Scene:
    """The same scene with every instance copied into world space as a mesh."""
    if not scene.instances:
        return scene
    meshes = list(scene.meshes) + [instance_mesh(scene, inst) for inst in scene.instances]
    return dataclasses.replace(scene, meshes=meshes, prototypes=[], instances=[])


def check_instances(scene: Scene) -> None:
    """Each instance names an existing prototype and material and has an invertible affine
    transform; the counts fit the G-buffer's visibility texel."""
    from .validate import _where  # late: validate imports this module

    fallback = str(scene.path) if scene.path is not None else None
    for i, inst in enumerate(scene.instances):
        what = f"instance '{inst.name or i + 1}'"
        where = _where(inst.source, fallback)
        if not 0 <= inst.mesh < len(scene.prototypes):
            raise SceneError(f"{what} uses mesh #{inst.mesh}, but there are {len(scene.prototypes)}", *where)
        if inst.material is not None and not 0 <= inst.material < len(scene.materials):
            raise SceneError(f"{what} uses material #{inst.material}, but there are {len(scene.materials)}", *where)
        inst.transform = check_transform(inst.transform, what, inst.source or fallback or "")
    if len(scene.instances) > MAX_INSTANCES:
        raise SceneError(f"{len(scene.instances):,} instances: at most {MAX_INSTANCES:,} are supported "
                         "(the G-buffer keeps an instance id in 16 bits)", scene.path)
    if scene.instances and len(scene.materials) > MAX_MATERIALS:
        raise SceneError(f"a scene with instances may have at most {MAX_MATERIALS:,} materials", scene.path)


def only_instances_moved(old: Scene, new: Scene) -> bool:
    """Whether `new` differs from `old` in the transforms of traced instances only (then
    pack.repack_instances places them anew without building any BVH)."""
    if not old.instances or len(old.instances) != len(new.instances):
        return False
    same_objects = (len(old.meshes) == len(new.meshes) and all(a is b for a, b in zip(old.meshes, new.meshes))
                    and len(old.spheres) == len(new.spheres) and all(a is b for a, b in zip(old.spheres, new.spheres))
                    and len(old.prototypes) == len(new.prototypes)
                    and all(a is b for a, b in zip(old.prototypes, new.prototypes)))
    if not same_objects:
        return False
    for a, b in zip(old.instances, new.instances):
        if a.mesh != b.mesh or a.material != b.material:
            return False
        if must_flatten(new, b) and not np.array_equal(a.transform, b.transform):
            return False  # a flattened instance is world geometry: the world BVH changes
    return True


# --- packing -------------------------------------------------------------------------------

@dataclass
class Blas:
    """One prototype's BVH and triangles, object space, in the BVH's order."""
    nodes: np.ndarray  # float32 (N, 8), node and triangle indices local to this BLAS
    positions: np.ndarray  # float32 (T, 3, 3)
    normals: np.ndarray  # float32 (T, 3, 3)
    uvs: np.ndarray  # float32 (T, 3, 2)
    depth: int

    @property
    def box(self) -> np.ndarray:
        return np.array([self.nodes[0, 0:3], self.nodes[0, 4:7]], np.float64)


def build_blas(mesh: Mesh, cache_dir=None, builder: str | None = None) -> Blas:
    from .pack import mesh_corners  # late: pack imports this module

    positions, normals, uvs = mesh_corners(mesh, np.zeros(3))
    positions = positions.astype(np.float32)
    bvh = build_bvh_cached(positions, cache_dir=cache_dir, builder=builder)
    o = bvh.order
    return Blas(bvh.nodes, positions[o], normals[o].astype(np.float32), uvs[o].astype(np.float32), bvh.depth)


def _box_corners(box: np.ndarray) -> np.ndarray:
    lo, hi = box
    return np.array([[(hi if (k >> a) & 1 else lo)[a] for a in range(3)] for k in range(8)])


def world_box(transform: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The axis-aligned box around a transformed object-space box, (2, 3), padded so that the
    float32 GPU arithmetic that brings rays into object space cannot step past it."""
    corners = _box_corners(box) @ transform[:3, :3].T + transform[:3, 3]
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    pad = 1e-6 * (hi - lo).max() + 8 * np.spacing(np.maximum(np.abs(lo), np.abs(hi)).astype(np.float32))
    return np.array([lo - pad, hi + pad])


@dataclass
class InstanceTable:
    """The `instances` array and what the host needs of it."""
    rows: np.ndarray  # float32 (2 * (2K - 1) + INSTANCE_ROWS * K, 4): TLAS nodes, padding, records
    record_base: int  # row of the first record (after the TLAS region)
    order: np.ndarray  # int (K,): record r is scene.instances[order[r]]
    draws: list  # (first triangle, triangles, first record, records): runs of one prototype
    bounds: np.ndarray  # (2, 3) GPU coordinates, around every instance
    tlas_depth: int
    tlas_nodes: int


def instance_table(scene: Scene, traced: list[int], blas_of: dict, origin: np.ndarray) -> InstanceTable:
    """blas_of: prototype index -> (Blas, root node, first triangle) as packed."""
    boxes, to_gpu = [], []
    rebase = np.eye(4)
    rebase[:3, 3] = -origin
    for i in traced:
        inst = scene.instances[i]
        m = rebase @ inst.transform
        to_gpu.append(m)
        boxes.append(world_box(m, blas_of[inst.mesh][0].box))
    boxes = np.array(boxes).reshape(-1, 2, 3)
    # The TLAS: the builder takes triangles, and (lo, hi, centre) has the box's bounds and centre.
    pseudo = np.stack([boxes[:, 0], boxes[:, 1], boxes.mean(axis=1)], axis=1).astype(np.float32)
    tlas = build_bvh(pseudo)
    order = np.asarray(traced, np.int64)[tlas.order]
    records = np.zeros((len(order), INSTANCE_ROWS, 4), np.float32)
    draws = []
    for r, (i, k) in enumerate(zip(order, tlas.order)):
        inst = scene.instances[i]
        blas, root, first_tri = blas_of[inst.mesh]
        m = to_gpu[k]
        records[r, 0:3] = m[:3]
        records[r, 3:6] = np.linalg.inv(m)[:3]
        material = NO_MATERIAL if inst.material is None else inst.material
        mirrored = int(np.linalg.det(m[:3, :3]) < 0)
        records[r, 6] = np.array([root, material, inst.mesh, mirrored], np.uint32).view(np.float32)
        if draws and draws[-1][0] == first_tri and draws[-1][2] + draws[-1][3] == r:
            draws[-1] = (first_tri, len(blas.positions), draws[-1][2], draws[-1][3] + 1)
        else:
            draws.append((first_tri, len(blas.positions), r, 1))
    # The TLAS region is sized for the most nodes K instances can need (2K - 1), so that the
    # array keeps its length when instances move and the TLAS is rebuilt with another shape:
    # a length compiled into the shaders (a uniform block's) then never changes with a move.
    tlas_rows = 2 * max(2 * len(order) - 1, 1)
    rows = np.zeros((tlas_rows + INSTANCE_ROWS * len(order), 4), np.float32)
    rows[:2 * tlas.num_nodes] = tlas.nodes.reshape(-1, 4)
    rows[tlas_rows:] = records.reshape(-1, 4)
    bounds = np.array([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)]) if len(boxes) else None
    return InstanceTable(rows, tlas_rows, order, draws, bounds, tlas.depth, tlas.num_nodes)


def instance_world_bounds(scene: Scene, traced: list[int]) -> np.ndarray | None:
    """Bounds of the traced instances in world space (float64), from their prototypes'
    vertices: the scene origin is chosen before any BLAS is built."""
    lo, hi = [], []
    for i in traced:
        inst = scene.instances[i]
        proto = scene.prototypes[inst.mesh]
        if not len(proto.positions):
            continue
        box = np.array([proto.positions.min(axis=0), proto.positions.max(axis=0)])
        b = world_box(inst.transform, box)
        lo.append(b[0])
        hi.append(b[1])
    return np.array([np.min(lo, axis=0), np.max(hi, axis=0)]) if lo else None
