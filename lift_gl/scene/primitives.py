"""Geometry building blocks: quads, boxes and spheres, and the affine transforms that place them.

Orientation convention (shared by every loader): a triangle (p0, p1, p2) faces the direction
of its geometric normal n = normalize(cross(p1 - p0, p2 - p0)) (counter-clockwise winding
seen from the front). Triangles are visible from both sides, but emitters emit from the
front side only, and glass uses the front side as "outside".

- quad(corner, u, v): the parallelogram corner + s*u + t*v, s, t in [0, 1]; its normal is
  normalize(cross(u, v)). quad_centered(center, u, v) is the same quad around its centre.
- box(center, size): an axis-aligned box whose faces point outwards.
- sphere(center, radius): an analytic Sphere (the renderer intersects it exactly).
"""
from __future__ import annotations

import numpy as np

from .model import Mesh, Sphere


def quad(corner, u, v, material: int = 0, name: str = "quad", source: str = "") -> Mesh:
    corner, u, v = (np.asarray(a, dtype=np.float64) for a in (corner, u, v))
    n = np.cross(u, v)
    length = np.linalg.norm(n)
    if length == 0:
        raise ValueError("quad edges u and v are parallel (zero area)")
    positions = np.array([corner, corner + u, corner + u + v, corner + v])
    # (0,1,2) and (0,2,3) both have cross(p1-p0, p2-p0) along cross(u, v).
    indices = np.array([[0, 1, 2], [0, 2, 3]])
    normals = np.tile(n / length, (4, 1))
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    return Mesh(name, positions, indices, material, normals=normals, uvs=uvs, source=source)


def quad_centered(center, u, v, material: int = 0, name: str = "quad", source: str = "") -> Mesh:
    center, u, v = (np.asarray(a, dtype=np.float64) for a in (center, u, v))
    return quad(center - 0.5 * u - 0.5 * v, u, v, material, name, source)


def box(center=(0, 0, 0), size=(1, 1, 1), material: int = 0, name: str = "box",
        source: str = "") -> Mesh:
    """Axis-aligned box, 24 vertices so that every face keeps its own flat normal."""
    center = np.asarray(center, dtype=np.float64)
    half = 0.5 * np.broadcast_to(np.asarray(size, dtype=np.float64), (3,))
    faces = []
    for axis in range(3):
        a, b = (axis + 1) % 3, (axis + 2) % 3
        for sign in (1.0, -1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            eu = np.zeros(3)
            ev = np.zeros(3)
            eu[a] = 2 * half[a]
            ev[b] = 2 * half[b]
            if sign < 0:  # swap the edges so cross(u, v) points outwards on this side too
                eu, ev = ev, eu
            face_center = center + normal * half[axis]
            faces.append(quad_centered(face_center, eu, ev))
    positions = np.concatenate([f.positions for f in faces])
    normals = np.concatenate([f.normals for f in faces])
    uvs = np.concatenate([f.uvs for f in faces])
    indices = np.concatenate([f.indices + 4 * i for i, f in enumerate(faces)])
    return Mesh(name, positions, indices, material, normals=normals, uvs=uvs, source=source)


def sphere(center=(0, 0, 0), radius: float = 1.0, material: int = 0, source: str = "") -> Sphere:
    if radius <= 0:
        raise ValueError("sphere radius must be positive")
    return Sphere(np.asarray(center, dtype=np.float64), float(radius), material, source=source)


# --- transforms -------------------------------------------------------------------------

def translate_matrix(t) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


def scale_matrix(s) -> np.ndarray:
    return np.diag([*np.broadcast_to(np.asarray(s, dtype=np.float64), (3,)), 1.0])


def axis_angle_matrix(angle_deg: float, axis) -> np.ndarray:
    """Right-handed rotation by angle_deg about axis (Rodrigues)."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    x, y, z = axis
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) * c + s * k + (1 - c) * np.outer(axis, axis)
    return m


def euler_matrix(degrees_xyz) -> np.ndarray:
    """Rotate about x, then y, then z (world axes): R = Rz @ Ry @ Rx."""
    rx, ry, rz = degrees_xyz
    return (axis_angle_matrix(rz, (0, 0, 1)) @ axis_angle_matrix(ry, (0, 1, 0))
            @ axis_angle_matrix(rx, (1, 0, 0)))


def trs_matrix(translate=(0, 0, 0), rotate=(0, 0, 0), scale=1.0) -> np.ndarray:
    """Scale first, then rotate, then translate."""
    return translate_matrix(translate) @ euler_matrix(rotate) @ scale_matrix(scale)


def transform_mesh(mesh: Mesh, m: np.ndarray, flip: bool = False) -> Mesh:
    """Apply the 4x4 affine `m`; normals use the inverse transpose. A mirroring matrix
    (negative determinant) reverses the winding so the front side follows the mirrored
    surface, as a scene author expects; `flip` reverses it once more (pbrt's
    ReverseOrientation)."""
    p = mesh.positions.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    normals = None
    if mesh.normals is not None:
        n = mesh.normals.astype(np.float64) @ np.linalg.inv(m[:3, :3])  # (M^-T n) as rows
        length = np.linalg.norm(n, axis=1, keepdims=True)
        normals = n / np.where(length > 0, length, 1.0)
    indices = mesh.indices
    if (np.linalg.det(m[:3, :3]) < 0) != flip:
        indices = indices[:, [0, 2, 1]]
    return Mesh(mesh.name, p, indices, mesh.material, normals=normals, uvs=mesh.uvs,
                source=mesh.source)


def transform_sphere(s: Sphere, m: np.ndarray) -> Sphere:
    """Spheres stay exact only under uniform scale; callers check `uniform_scale` first."""
    center = m[:3, :3] @ s.center + m[:3, 3]
    radius = s.radius * float(np.mean(np.linalg.norm(m[:3, :3], axis=0)))
    return Sphere(center, radius, s.material, source=s.source)


def uniform_scale(m: np.ndarray, tol: float = 1e-4) -> bool:
    cols = np.linalg.norm(m[:3, :3], axis=0)
    return bool(np.ptp(cols) <= tol * max(cols.max(), 1e-30))


def geometric_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Unnormalised geometric normal of every triangle (the front-side direction)."""
    p = positions[indices]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


def orient_to_normals(mesh: Mesh) -> Mesh:
    """Turn each triangle's front (winding) towards its vertices' shading normals, as pbrt
    (Faceforward) and Mitsuba (one-sided emitters in the shading frame) do."""
    if mesh.normals is None or len(mesh.indices) == 0:
        return mesh
    g = geometric_normals(mesh.positions, mesh.indices)
    ns = mesh.normals[mesh.indices].sum(axis=1)
    back = np.einsum("ij,ij->i", g, ns) < 0
    if back.any():
        mesh.indices[back] = mesh.indices[back][:, [0, 2, 1]]
    return mesh


def smooth_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Vertex normals: the normals of the triangles around each vertex, weighted by the
    triangle's angle at that vertex (shared vertices only: a seam in the index buffer stays
    a crease)."""
    p = positions.astype(np.float64)[indices]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    out = np.zeros((len(positions), 3))
    for corner in range(3):
        a = p[:, (corner + 1) % 3] - p[:, corner]
        b = p[:, (corner + 2) % 3] - p[:, corner]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        np.add.at(out, indices[:, corner], n * angle[:, None])
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0)


def mirror_scene_x(scene) -> None:
    """Mirror everything in x (geometry, camera, lights), in place: loaders use it when a
    file's camera shows the image mirrored relative to lift-gl's camera convention."""
    flip = np.diag([-1.0, 1.0, 1.0, 1.0])
    scene.meshes = [transform_mesh(m, flip) for m in scene.meshes]
    scene.spheres = [transform_sphere(x, flip) for x in scene.spheres]
    for inst in scene.instances:  # prototypes stay in their object space
        inst.transform = flip @ inst.transform
    c = scene.camera
    c.position, c.target, c.up = (flip[:3, :3] @ v for v in (c.position, c.target, c.up))
    if scene.environment is not None:
        scene.environment.to_world = flip[:3, :3] @ scene.environment.to_world
    for light in scene.distant_lights:
        light.direction = flip[:3, :3] @ light.direction
