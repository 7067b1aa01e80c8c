"""Which kind of light next event estimation samples (shaders/lift/lights.glsl), and the
distant lights as uniforms.

sample_light first picks a category: the environment, the distant lights, or the emissive
primitives. Each present category gets half its share of the estimated power plus half of
an equal share, so a dim category is still sampled now and then (a poor power estimate
then costs variance, never correctness). Powers, pbrt's estimates: an emitter pi L A, the
environment pi r^2 L_mean and a distant light pi r^2 E, with r the radius of the scene's
bounding sphere. Within the distant lights the choice is by power alone.
"""
from __future__ import annotations

import warnings

import numpy as np

from .envmap import LUMINANCE, mean_radiance
from .model import Scene

MAX_DISTANT = 4  # shaders/lift/lights.glsl: LIFT_MAX_DISTANT


def light_uniforms(scene: Scene, emitter_power: float, bounds: np.ndarray) -> dict:
    """`emitter_power`: sum of luminance x area over emissive primitives (pack.py's)."""
    radius = 0.5 * float(np.linalg.norm(np.asarray(bounds[1]) - np.asarray(bounds[0]))) or 1.0
    disk = np.pi * radius ** 2

    env_power = 0.0
    env = scene.environment
    if env is not None:
        mean = env.radiance if env.image is None else env.radiance * mean_radiance(env.image)
        env_power = disk * max(float(np.asarray(mean) @ LUMINANCE), 0.0)

    distant = [d for d in scene.distant_lights if (d.irradiance > 0).any()]
    if len(distant) > MAX_DISTANT:
        warnings.warn(f"{len(distant)} distant lights: only the {MAX_DISTANT} brightest are used",
                      stacklevel=2)
        distant = sorted(distant, key=lambda d: -float(d.irradiance @ LUMINANCE))[:MAX_DISTANT]
    distant_power = np.array([disk * max(float(d.irradiance @ LUMINANCE), 1e-12) for d in distant])

    powers = np.array([env_power, distant_power.sum(), np.pi * emitter_power])
    present = powers > 0
    weights = np.zeros(3)
    if present.any():
        weights[present] = 0.5 * powers[present] / powers[present].sum() + 0.5 / present.sum()

    directions = np.zeros((MAX_DISTANT, 4), np.float32)
    irradiance = np.zeros((MAX_DISTANT, 4), np.float32)
    if distant:
        select = distant_power / distant_power.sum()
        cdf = np.cumsum(select)
        cdf[-1] = 1.0
        for i, d in enumerate(distant):
            directions[i, :3], directions[i, 3] = d.direction, cdf[i]
            irradiance[i, :3], irradiance[i, 3] = d.irradiance, select[i]
    return {"u_light_weights": (float(weights[0]), float(weights[1]), float(weights[2]), 0.0),
            "u_num_distant": len(distant), "u_distant_dir": directions,
            "u_distant_irradiance": irradiance}


def one_flat_emitter(scene: Scene) -> bool:
    """Whether the emissive primitives are one sphere, or triangles in one plane facing one way
    (a quad, a disk): where a light tree would pick among them as their power does (the option
    light_selection's auto rule)."""
    emissive = [m.is_emissive for m in scene.materials]
    spheres = sum(1 for s in scene.spheres if emissive[s.material])
    if any(emissive[i.material if i.material is not None else scene.prototypes[i.mesh].material]
           for i in scene.instances):
        return False
    corners = [m.positions[m.indices] for m in scene.meshes if emissive[m.material] and len(m.indices)]
    if not corners:
        return spheres <= 1
    if spheres:
        return False
    corners = np.concatenate(corners).astype(np.float64)
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(n, axis=1)
    n = n[length > 0] / length[length > 0, None]
    if len(n) == 0:
        return True
    size = float(np.ptp(corners.reshape(-1, 3), axis=0).max()) or 1.0
    offsets = np.einsum("ij,ij->i", n, corners[length > 0, 0])
    return bool(np.all(n @ n[0] > 1.0 - 1e-6) and np.ptp(offsets) <= 1e-5 * (size + np.abs(offsets).max()))
