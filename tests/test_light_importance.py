"""Densities of the light-tracing samplers against what they sample, by the identity
E_p[g / p] = integral of g: shaders/lift/camera_importance.glsl (the pinhole's importance and
direction density) and shaders/lift/emission.glsl (rays leaving emitters, the sky, an
environment map and a distant light).
A density that does not match its sampler, or a wrong normalisation, moves these means."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import REPO
from lift_gl.renderer import Renderer
from lift_gl.scene import DistantLight, Environment
from lift_gl.scene.loader import load_scene

SIZE = (32, 32)
SPP = 16

MANIFEST = """name = "densities"
entry = "main.glsl"
primary = "gbuffer"
[params.mode]
type = "int"
default = 0
"""
SHADER = """#include "lift/camera_importance.glsl"
#include "lift/emission.glsl"
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    if (mode == 0) {
        // Directions uniform over the sphere (density 1 / 4 pi): the integrals over the image
        // of W_e cos and of the camera's direction density are both 1.
        vec3 w = sample_uniform_sphere(rng_next2(rng));
        vec2 pixel_pos;
        if (!camera_project(u_cam_pos + w, pixel_pos)) return vec3(0.0);
        return 4.0 * LIFT_PI * vec3(camera_importance(w) * dot(w, u_cam_forward), camera_pdf_dir(w), 0.0);
    }
    EmissionSample es;
    if (!sample_emission(rng_next3(rng), rng_next2(rng), es)) return vec3(-1.0);
    bool wanted = mode == 1 ? !es.light.infinite : mode == 2 ? es.light.infinite && !es.light.delta : es.light.delta;
    // Emitters: 1 / origin density integrates to their area, 1 / direction density to the
    // hemisphere (2 pi); the sky or a map: to its disk (pi R^2) and the sphere (4 pi); a
    // distant light: to the disk and to 1 (a discrete choice). All are picked with their
    // choice probabilities, which the densities include.
    return wanted ? vec3(1.0 / es.pdf_pos, 1.0 / es.pdf_dir, 1.0) : vec3(0.0);
}
"""


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plugins") / "densities"
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST)
    (folder / "main.glsl").write_text(SHADER)
    return folder


def estimates(plugin, scene, mode, size=SIZE):
    r = Renderer(scene, size=size, integrator=str(plugin), seed=3, params={"mode": mode})
    image = r.render(spp=SPP).reshape(-1, 3).astype(np.float64)
    # The probability of picking the sky rather than an emitter, as the light choice sets it
    # (lift_gl/scene/light_choice.py: by estimated power).
    weights = np.array(r.scene_uniforms["u_light_weights"][:3])
    r.release()
    # Pixels are independent means of SPP samples each. The choice probabilities of the
    # environment, the distant lights and the emitters, as light_choice.py sets them.
    return image.mean(axis=0), image.std(axis=0, ddof=1) / math.sqrt(len(image)), weights / weights.sum()


def cornell_with(light):
    """The Cornell box's emitter and one light at infinity, each picked with its probability."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    if light == "sky":
        scene.environment = Environment([1.0, 1.0, 1.0])
    elif light == "map":
        from test_envmap import TO_WORLD, env_image
        img = env_image()
        img[9:14, 20:28] = 0.5  # no black texels: the map's density covers the whole sphere
        scene.environment = Environment([1.0, 1.0, 1.0], image=img, to_world=TO_WORLD)
    else:
        scene.distant_lights = [DistantLight([0.3, 1.0, 0.8], [2.0, 2.0, 2.0])]
    return scene


@pytest.mark.parametrize("fov, size", [(19.5, (32, 32)), (70.0, (48, 24))])
def test_camera_importance_and_direction_density_integrate_to_one(plugin, fov, size):
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    scene.camera.fov_deg = fov
    mean, se, _ = estimates(plugin, scene, mode=0, size=size)
    assert np.all(np.abs(mean[:2] - 1.0) < 4 * se[:2]), (mean, se)


@pytest.mark.parametrize("mode, light", [(1, "sky"), (2, "sky"), (2, "map"), (3, "distant")],
                         ids=["emitter", "sky", "map", "distant"])
def test_emitted_rays_have_the_densities_they_claim(plugin, mode, light):
    scene = cornell_with(light)
    mean, se, choice = estimates(plugin, scene, mode)
    p_sky = choice[0] + choice[1]  # the light at infinity, whichever
    assert 0.05 < p_sky < 0.95
    light_area = 0.94 * 0.76
    lo, hi = (np.min([m.positions.min(0) for m in scene.meshes], axis=0),
              np.max([m.positions.max(0) for m in scene.meshes], axis=0))
    radius = np.linalg.norm(hi - lo) / 2
    if mode == 1:
        expected = np.array([light_area, (1 - p_sky) * 2 * math.pi, 1 - p_sky])
    else:
        expected = np.array([p_sky * math.pi * radius ** 2, 4 * math.pi if mode == 2 else 1.0, p_sky])
    assert np.all(np.abs(mean - expected) < 4 * se + 1e-4 * expected), (mean, expected, se)
