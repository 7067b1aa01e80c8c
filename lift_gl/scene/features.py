"""SceneFeatures: what a scene uses, so that shaders compile only the code it needs.

Each feature becomes a `#define` in every shader of the frame; code for absent features is
not compiled (a diffuse-only scene compiles no conductor or glass code).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields

from .instances import instance_material, split_instances
from .model import Scene


@dataclass(frozen=True)
class SceneFeatures:
    conductor: bool = False
    rough_conductor: bool = False
    dielectric: bool = False
    rough_dielectric: bool = False
    spheres: bool = False
    environment: bool = False
    emissive: bool = False  # emissive triangles or spheres (light sampling code)
    motion: bool = False  # objects that move while the shutter is open (motion blur)
    plastic: bool = False  # diffuse base under a dielectric coat
    rough_plastic: bool = False
    textures: bool = False  # image textures (base colour)
    environment_map: bool = False  # an image-based environment, importance sampled
    distant_lights: bool = False  # directional (delta) lights
    beckmann: bool = False  # rough conductors with a Beckmann distribution
    pixel_filter: bool = False  # a film filter wider than a box over the pixel (camera rays sample it)
    instances: bool = False  # meshes placed by transforms: a second level of BVH (scene/instances.py)

    @classmethod
    def of(cls, scene: Scene) -> "SceneFeatures":
        traced = []
        if scene.instances:  # emissive and moving instances become world meshes (as pack.py does)
            flat, traced = split_instances(scene)
            scene = dataclasses.replace(scene, meshes=list(scene.meshes) + flat)
        used = [scene.materials[m.material] for m in scene.meshes if len(m.indices)]
        used += [scene.materials[instance_material(scene, scene.instances[i])] for i in traced]
        used += [scene.materials[s.material] for s in scene.spheres]
        return cls(
            conductor=any(m.type == "conductor" for m in used),
            rough_conductor=any(m.type == "conductor" and m.alpha > 0 for m in used),
            dielectric=any(m.type == "dielectric" for m in used),
            rough_dielectric=any(m.type == "dielectric" and m.alpha > 0 for m in used),
            spheres=bool(scene.spheres),
            environment=_has_environment(scene),
            emissive=any(m.is_emissive for m in used),
            motion=scene.has_motion,
            plastic=any(m.type == "plastic" for m in used),
            rough_plastic=any(m.type == "plastic" and m.alpha > 0 for m in used),
            textures=any(m.texture is not None for m in used),
            environment_map=_has_environment(scene) and scene.environment.image is not None,
            distant_lights=any((d.irradiance > 0).any() for d in scene.distant_lights),
            beckmann=any(m.type == "conductor" and m.alpha > 0 and m.distribution == "beckmann" for m in used),
            pixel_filter=scene.pixel_filter is not None,
            instances=bool(traced),
        )

    @classmethod
    def everything(cls) -> "SceneFeatures":
        return cls(**{f.name: True for f in fields(cls)})

    def defines(self) -> dict:
        return {f"HAS_{f.name.upper()}": True for f in fields(self) if getattr(self, f.name)}

    def explain(self) -> list[str]:
        return [f"{'+' if getattr(self, f.name) else '-'} {f.name}" for f in fields(self)]


def _has_environment(scene: Scene) -> bool:
    env = scene.environment
    if env is None or not (env.radiance > 0).any():
        return False
    return env.image is None or bool((env.image > 0).any())
