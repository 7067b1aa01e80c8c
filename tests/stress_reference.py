"""Independent answers for the stress scenes (tests/test_stress.py), computed in numpy from
the scene description alone: camera rays through a grid of subpixel positions, ray-quad
intersections, and Lambert's closed form for the irradiance from a polygonal emitter.

Pixel values are box-filtered (the mean over the pixel's area), as the renderer's jittered
samples are; images are (H, W, 3), row 0 at the top.
"""
from __future__ import annotations

import numpy as np


def grid_offsets(n: int) -> np.ndarray:
    """An n x n grid of subpixel positions, (n*n, 2) in [0, 1)^2."""
    g = (np.arange(n) + 0.5) / n
    return np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)


def render_offsets(spp: int, seed: int) -> np.ndarray:
    """The subpixel positions a G-buffer render of `spp` samples used (one per frame, the
    same in every pixel): the expected image for exactly these positions leaves only the
    per-pixel, independent Monte Carlo noise of the light transport to compare."""
    from lift_gl.passes.camera import frame_jitter
    return np.array([frame_jitter(i, seed) for i in range(spp)])


def pixel_rays(camera, size, offsets):
    """Unit directions (H, W, N, 3) of pinhole rays through `offsets` (N, 2), in pixels from
    each pixel's bottom-left corner (y up, as shaders/lift/camera.glsl); row 0 = top."""
    right, up, forward = camera.basis()
    w, h = size
    t = np.tan(np.radians(camera.fov_deg) / 2)
    offsets = np.asarray(offsets, np.float64)
    xs = (np.arange(w)[:, None] + offsets[None, :, 0]) / w * 2 - 1  # (W, N)
    ys = (np.arange(h)[:, None] + offsets[None, :, 1]) / h * 2 - 1  # (H, N)
    d = (forward + xs[None, :, :, None] * t * (w / h) * right + ys[:, None, :, None] * t * up)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d[::-1]  # row 0 = top


def intersect_quad(origin, dirs, corner, u, v):
    """Distance along each ray to the parallelogram corner + s u + t v (inf: a miss), and
    whether the ray meets its front (cross(u, v)) side."""
    corner, u, v = (np.asarray(a, np.float64) for a in (corner, u, v))
    n = np.cross(u, v)
    denom = dirs @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((corner - origin) @ n) / denom
        p = origin + t[..., None] * dirs - corner
        # Coordinates of p in the (u, v) basis (u and v need not be orthogonal).
        g = np.array([[u @ u, u @ v], [u @ v, v @ v]])
        rhs = np.stack([p @ u, p @ v], axis=-1)
        st = rhs @ np.linalg.inv(g).T
    inside = (t > 0) & np.all((st >= 0) & (st <= 1), axis=-1) & np.isfinite(t)
    return np.where(inside, t, np.inf), denom < 0


def polygon_irradiance(points, normal, polygon, radiance=1.0):
    """Irradiance at `points` (N, 3) on a surface of unit `normal` from a one-sided emitter
    polygon of constant radiance (vertices (K, 3) counter-clockwise seen from its front):
    Lambert's formula E = L/2 sum_i angle_i (n . unit(r_i x r_i+1)). The polygon must lie
    wholly above the surface's plane; points behind the emitter get 0."""
    polygon = np.asarray(polygon, np.float64)
    r = polygon[None, :, :] - points[:, None, :]
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    r_next = np.roll(r, -1, axis=1)
    cross = np.cross(r, r_next)
    length = np.linalg.norm(cross, axis=-1)
    angle = np.arctan2(length, np.einsum("nki,nki->nk", r, r_next))
    unit = cross / np.maximum(length, 1e-300)[..., None]
    e = 0.5 * radiance * np.abs(np.sum(angle * (unit @ np.asarray(normal, np.float64)), axis=1))
    light_normal = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
    in_front = (points - polygon[0]) @ light_normal > 0
    return np.where(in_front, e, 0.0)


def quad_polygon(corner, u, v):
    corner, u, v = (np.asarray(a, np.float64) for a in (corner, u, v))
    return np.array([corner, corner + u, corner + u + v, corner + v])


def floor_under_quad_light(scene, size, offsets):
    """Expected image of the direct-light scenes (tiny_bright_light, huge_dim_light,
    grazing_light): a diffuse floor quad facing +y lit by one black emitter quad; nothing else
    reflects, so the floor shows albedo / pi * E and the emitter its radiance (front) or 0."""
    floor = next(m for m in scene.meshes if m.name == "floor")
    light = next(m for m in scene.meshes if m.name == "light")
    albedo = scene.materials[floor.material].base_color
    le = scene.materials[light.material].emission
    origin = np.asarray(scene.camera.position, np.float64)
    dirs = pixel_rays(scene.camera, size, offsets)

    def as_quad(mesh):  # primitives.quad: corner, corner + u, corner + u + v, corner + v
        p = mesh.positions.astype(np.float64)
        return p[0], p[1] - p[0], p[3] - p[0]

    t_floor, _ = intersect_quad(origin, dirs, *as_quad(floor))
    t_light, light_front = intersect_quad(origin, dirs, *as_quad(light))
    radiance = np.zeros(dirs.shape[:3] + (3,))
    sees_light = t_light < t_floor
    radiance[sees_light & light_front] = le
    on_floor = np.isfinite(t_floor) & ~sees_light
    points = origin + t_floor[on_floor][:, None] * dirs[on_floor]
    e = polygon_irradiance(points, [0.0, 1.0, 0.0], quad_polygon(*as_quad(light)))
    radiance[on_floor] = albedo[None, :] / np.pi * e[:, None] * le[None, :]
    return radiance.mean(axis=2)


def intersect_triangles(origin, dirs, triangles):
    """Nearest hit of each ray among triangles (T, 3, 3): distance (inf: none), triangle
    index and barycentrics (b1, b2) of corners 1 and 2."""
    shape = dirs.shape[:-1]
    d = dirs.reshape(-1, 3)
    best_t = np.full(len(d), np.inf)
    best_i = np.full(len(d), -1)
    best_b = np.zeros((len(d), 2))
    for i, (p0, p1, p2) in enumerate(np.asarray(triangles, np.float64)):
        e1, e2 = p1 - p0, p2 - p0
        pv = np.cross(d, e2)
        det = pv @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = origin - p0
            b1 = (pv @ tv) * inv
            qv = np.cross(tv, e1)
            b2 = (d @ qv) * inv
            t = (qv @ e2) * inv
        hit = (det != 0) & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t > 0) & (t < best_t)
        best_t[hit], best_i[hit] = t[hit], i
        best_b[hit] = np.stack([b1[hit], b2[hit]], axis=-1)
    return best_t.reshape(shape), best_i.reshape(shape), best_b.reshape(shape + (2,))


def ground_and_sky(scene, size, offsets):
    """Expected image of grazing_camera and ior_one: the ground quad shows albedo x sky (its
    upper hemisphere is all sky), everything else the sky; index-matched glass is invisible."""
    ground = next(m for m in scene.meshes if m.name == "ground")
    sky = scene.environment.radiance
    albedo = scene.materials[ground.material].base_color
    origin = np.asarray(scene.camera.position, np.float64)
    dirs = pixel_rays(scene.camera, size, offsets)
    t, _, _ = intersect_triangles(origin, dirs, ground.positions[ground.indices])
    radiance = np.where(np.isfinite(t)[..., None], albedo * sky, sky)
    return radiance.mean(axis=2)


def tilted_normals(scene, size, offsets):
    """Expected image of tilted_normals: open quads of albedo rho under a sky L. Seen from
    inside its shading hemisphere a quad reflects rho L (1 + cos theta) / 2 (the part of the
    cosine lobe around the shading normal that lies above the true surface; theta is the
    angle between the normals), else (geometric normal used) rho L."""
    mesh = scene.meshes[0]
    rho = scene.materials[mesh.material].base_color
    sky = scene.environment.radiance
    origin = np.asarray(scene.camera.position, np.float64)
    dirs = pixel_rays(scene.camera, size, offsets)
    tris = mesh.positions[mesh.indices]
    t, index, bary = intersect_triangles(origin, dirs, tris)
    hit = np.isfinite(t)
    ng = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    ng /= np.linalg.norm(ng, axis=1, keepdims=True)
    corner_n = mesh.normals[mesh.indices].astype(np.float64)
    b1, b2 = bary[..., 0:1], bary[..., 1:2]
    ns = (1 - b1 - b2) * corner_n[index, 0] + b1 * corner_n[index, 1] + b2 * corner_n[index, 2]
    ns /= np.linalg.norm(ns, axis=-1, keepdims=True)
    g = ng[index]
    ns = np.where((np.sum(ns * g, axis=-1) < 0)[..., None], -ns, ns)  # as surface.glsl
    wo = -dirs
    side = np.where(np.sum(wo * g, axis=-1) >= 0, 1.0, -1.0)[..., None]
    ns, g = ns * side, g * side
    cos_tilt = np.sum(ns * g, axis=-1)
    inside_lobe = np.sum(wo * ns, axis=-1) > 0
    factor = np.where(inside_lobe, 0.5 * (1 + cos_tilt), 1.0)
    radiance = np.where(hit[..., None], rho * sky * factor[..., None], sky)
    return radiance.mean(axis=2)


def tir_cube(scene, size, offsets):
    """Expected image of tir_cube (camera inside an axis-aligned glass cube under a sky L):
    n^2 L for directions that can escape, 0 for those trapped by total internal reflection
    (every |component| below sqrt(1 - 1/n^2))."""
    ior = scene.materials[scene.meshes[0].material].ior
    sky = scene.environment.radiance
    dirs = pixel_rays(scene.camera, size, offsets)
    trapped = np.all(dirs ** 2 < 1 - 1 / ior ** 2, axis=-1)
    radiance = np.where(trapped[..., None], 0.0, ior ** 2 * sky)
    return radiance.mean(axis=2)


def furnace_box(albedo: float, emission: float, max_depth: int) -> float:
    """Radiance inside a closed box of walls that emit `emission` and reflect `albedo`, for
    paths of at most max_depth bounces: the geometric series sum_k<=N a^k Le."""
    if albedo == 1.0:
        return emission * (max_depth + 1)
    return emission * (1 - albedo ** (max_depth + 1)) / (1 - albedo)


# ---------------------------------------------------------------- a light tracer for caustic.toml
def _cosine_about(normal, u1, u2):
    """Cosine-weighted unit directions about one unit normal (N draws)."""
    normal = np.asarray(normal, np.float64)
    a = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(normal, a)
    t /= np.linalg.norm(t)
    b = np.cross(normal, t)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    z = np.sqrt(np.maximum(0.0, 1 - u1))
    return (r * np.cos(phi))[:, None] * t + (r * np.sin(phi))[:, None] * b + z[:, None] * normal


def _fresnel_dielectric(cos_i, eta):
    """Unpolarised reflectance for incidence cosine cos_i > 0 and eta = n_t / n_i."""
    sin2_t = (1 - cos_i ** 2) / eta ** 2
    cos_t = np.sqrt(np.maximum(0.0, 1 - sin2_t))
    r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return np.where(sin2_t >= 1, 1.0, 0.5 * (r_par ** 2 + r_perp ** 2))


def caustic_light_tracer(scene, size, photons: int, batches: int, seed: int = 0):
    """Radiance of the floor in each pixel of caustic.toml, estimated by tracing photons from
    the light (a second estimator for what the path tracer computes): photons leave the light
    uniformly in area and cosine-distributed, pass the glass sphere with Fresnel-weighted
    choices between reflection and refraction, and every arrival on the floor is binned in the
    floor square that a pixel sees (the camera looks straight down, so pixels are squares of
    equal area); diffuse bounces off the floor continue the photon. Arrivals after more than
    max_depth - 1 scattering events are not counted (the path tracer's depth limit).
    Returns (mean, variance of the mean) radiance images (H, W) from `batches` batches."""
    floor = next(m for m in scene.meshes if m.name == "floor")
    light = next(m for m in scene.meshes if m.name == "light")
    sphere = scene.spheres[0]
    ior = scene.materials[sphere.material].ior
    rho = float(scene.materials[floor.material].base_color[0])
    le = float(scene.materials[light.material].emission[0])
    lp = light.positions.astype(np.float64)
    corner, u, v = lp[0], lp[1] - lp[0], lp[3] - lp[0]
    light_n = np.cross(u, v)
    area = np.linalg.norm(light_n)
    light_n /= area
    floor_lo, floor_hi = floor.positions.min(axis=0), floor.positions.max(axis=0)
    cam = scene.camera
    right, up, forward = cam.basis()
    tan_half = np.tan(np.radians(cam.fov_deg) / 2)
    w, h = size
    pixel_area = (2 * tan_half * (w / h) * abs(cam.position[1]) / w) * (2 * tan_half * abs(cam.position[1]) / h)
    flux_total = np.pi * le * area
    max_events = scene.max_depth - 1
    rng = np.random.default_rng(seed)
    images = np.zeros((batches, h, w))
    n = photons // batches
    eps = 1e-9
    for batch in range(batches):
        o = corner + rng.random(n)[:, None] * u + rng.random(n)[:, None] * v
        d = _cosine_about(-light_n if light_n[1] > 0 else light_n, rng.random(n), rng.random(n))
        weight = np.full(n, flux_total / n)
        events = np.zeros(n, int)
        alive = np.ones(n, bool)
        while alive.any():
            i = np.nonzero(alive)[0]
            oi, di = o[i], d[i]
            # the sphere
            oc = oi - sphere.center
            b = np.einsum("ij,ij->i", oc, di)
            disc = b * b - (np.einsum("ij,ij->i", oc, oc) - sphere.radius ** 2)
            root = np.sqrt(np.maximum(disc, 0))
            t0, t1 = -b - root, -b + root
            t_s = np.where(disc > 0, np.where(t0 > eps, t0, np.where(t1 > eps, t1, np.inf)), np.inf)
            # the floor (from above) and the light's plane (photons going up are absorbed by it
            # if they meet it: it is black)
            with np.errstate(divide="ignore", invalid="ignore"):
                t_f = np.where(di[:, 1] < 0, (floor_lo[1] - oi[:, 1]) / di[:, 1], np.inf)
                t_l = np.where(di[:, 1] > 0, (corner[1] - oi[:, 1]) / di[:, 1], np.inf)
            pf = oi + np.where(np.isfinite(t_f), t_f, 0)[:, None] * di
            on_floor = np.all((pf[:, [0, 2]] >= floor_lo[[0, 2]]) & (pf[:, [0, 2]] <= floor_hi[[0, 2]]), axis=1)
            t_f = np.where(on_floor, t_f, np.inf)
            pl = oi + np.where(np.isfinite(t_l), t_l, 0)[:, None] * di - corner
            s_u, s_v = pl @ u / (u @ u), pl @ v / (v @ v)
            t_l = np.where((s_u >= 0) & (s_u <= 1) & (s_v >= 0) & (s_v <= 1), t_l, np.inf)
            t = np.minimum(np.minimum(t_s, t_f), t_l)
            gone = ~np.isfinite(t) | (t == t_l)
            alive[i[gone]] = False
            # ---- glass: reflect with probability F, else refract (flux is unchanged) ----
            g = ~gone & (t == t_s)
            if g.any():
                k = i[g]
                p = o[k] + t[g][:, None] * d[k]
                nrm = (p - sphere.center) / sphere.radius
                cos_d = np.einsum("ij,ij->i", d[k], nrm)
                entering = cos_d < 0
                nf = np.where(entering[:, None], nrm, -nrm)  # normal on the incident side
                cos_i = np.abs(cos_d)
                eta = np.where(entering, ior, 1 / ior)  # n_t / n_i
                refl = rng.random(len(k)) < _fresnel_dielectric(cos_i, eta)
                d_refl = d[k] + 2 * cos_i[:, None] * nf
                r = 1 / eta
                cos_t = np.sqrt(np.maximum(0.0, 1 - r ** 2 * (1 - cos_i ** 2)))
                d_refr = r[:, None] * d[k] + (r * cos_i - cos_t)[:, None] * nf
                d_new = np.where(refl[:, None], d_refl, d_refr)
                d[k] = d_new / np.linalg.norm(d_new, axis=1, keepdims=True)
                o[k] = p
                events[k] += 1
            # ---- floor: count the arrival in its pixel, then reflect diffusely ----
            f = ~gone & (t == t_f) & ~g
            if f.any():
                k = i[f]
                p = o[k] + t[f][:, None] * d[k]
                rel = p - cam.position
                depth = rel @ forward
                x = (rel @ right) / depth / (tan_half * w / h)
                y = (rel @ up) / depth / tan_half
                col = np.floor((x + 1) / 2 * w).astype(int)
                row = h - 1 - np.floor((y + 1) / 2 * h).astype(int)
                seen = (events[k] <= max_events) & (col >= 0) & (col < w) & (row >= 0) & (row < h) & (depth > 0)
                np.add.at(images[batch], (row[seen], col[seen]), weight[k][seen])
                weight[k] *= rho
                events[k] += 1
                d[k] = _cosine_about(np.array([0.0, 1.0, 0.0]), rng.random(len(k)), rng.random(len(k)))
                o[k] = p + np.array([0.0, eps, 0.0])
            alive &= events <= max_events
    radiance = images * (rho / np.pi) / pixel_area
    return radiance.mean(axis=0), radiance.var(axis=0, ddof=1) / batches
