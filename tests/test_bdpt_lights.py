"""bdpt with lights at infinity: a constant environment, an importance-sampled environment map
and a distant light. Light subpaths start from them on a disk across the scene's bounding
sphere (lift/emission.glsl), so every strategy with s >= 1 and the light tracing splats see
them; camera subpaths that escape are weighted against them.

Independent answers: pt on the same scenes (a second estimator: the mean difference per
block within the standard errors of independent runs, tests/image_stats.py), and analytic
images of a diffuse sphere (under the map: the irradiance integral, as tests/test_envmap.py
checks pt; under the distant light: albedo / pi * E * max(0, cos)).
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import sphere_pixel_normals
from image_stats import assert_same_image
from test_bdpt import renders
from test_envmap import SCALE, TO_WORLD, env_image, irradiance
from lift_gl.scene import Camera, DistantLight, Environment, Material, Scene, Sphere
from lift_gl.scene import primitives as prim

SIZE = (32, 32)
RUNS = 16
SUN = DistantLight([0.4, 1.0, 0.5], [3.0, 2.8, 2.5])


def porch(light: str) -> Scene:
    """A floor, a roof that shades part of it (lit from below by the floor only), a rough
    metal block and a sphere. Under the environments the sphere is smooth glass (escaping
    paths through specular vertices); under the distant light it is diffuse, since no
    estimator but light tracing can carry a delta light through a delta lobe, and pt has none."""
    glass = light != "distant"
    materials = [Material("white", base_color=[0.7, 0.7, 0.7]), Material("red", base_color=[0.7, 0.2, 0.1]),
                 Material("metal", "conductor", base_color=[0.9, 0.8, 0.6], alpha=0.3),
                 Material("glass", "dielectric", base_color=[1.0] * 3, ior=1.5)]
    meshes = [prim.quad_centered([0, 0, 0], [0, 0, 4], [4, 0, 0], 0, name="floor"),
              prim.quad_centered([0.3, 1.4, -0.3], [2.2, 0, 0], [0, 0, 2.2], 1, name="roof"),
              prim.box([-0.5, 0.35, 0.2], [0.7, 0.7, 0.7], 2, name="block")]
    scene = Scene(camera=Camera(position=[0.4, 0.8, 3.6], target=[0, 0.55, 0], fov_deg=45.0),
                  materials=materials, meshes=meshes, spheres=[Sphere([0.55, 0.45, 0.1], 0.45, 3 if glass else 0)],
                  film_size=SIZE)
    if light == "sky":
        scene.environment = Environment([0.6, 0.7, 1.0])
    elif light == "map":
        scene.environment = Environment(SCALE, image=env_image(), to_world=TO_WORLD)
    else:
        scene.distant_lights = [SUN]
    return scene


# ---------------------------------------------------------------- PT and BDPT agree
@pytest.mark.parametrize("light", ["sky", "map", "distant"])
def test_pt_and_bdpt_agree_under_lights_at_infinity(light):
    scene = porch(light)
    pt = renders(scene, "pt", 16, range(1, RUNS + 1))
    bdpt = renders(scene, "bdpt", 4, range(101, RUNS + 101))
    assert_same_image(pt, bdpt, block=8, label=f"porch under {light}: pt vs bdpt")


def test_light_tracing_alone_sees_the_distant_light():
    """Direct light by light tracing alone (s = 2, t = 1: a ray from the disk, splatted) gives
    the MIS image of the same paths: the disk's density and the splat's weight are right."""
    scene = porch("distant")
    combined = renders(scene, "bdpt", 4, range(201, RUNS + 201), only_depth=1)
    alone = renders(scene, "bdpt", 4, range(301, RUNS + 301), only_depth=1, only_s=2)
    assert_same_image(combined, alone, block=8, label="distant light, depth 1: s = 2 alone vs MIS")


# ---------------------------------------------------------------- analytic spheres
SPHERE_SIZE = (40, 40)


def diffuse_sphere(albedo: float) -> Scene:
    scene = Scene(camera=Camera(position=[0, 0, 3], target=[0, 0, 0], fov_deg=45.0),
                  materials=[Material("d", base_color=[albedo] * 3)], spheres=[Sphere([0, 0, 0], 1.0, 0)],
                  film_size=SPHERE_SIZE)
    scene.max_depth = 1  # a convex sphere never sees itself: direct light is all there is
    return scene


def assert_matches(a: np.ndarray, b: np.ndarray, expected: np.ndarray, inside: np.ndarray, model: float,
                   groups: int = 8) -> None:
    """Two independent renders against an analytic image on the pixels `inside`, in groups of
    pixels of similar expected brightness (from the terminator to the brightest): each
    group's mean difference within 4 standard errors (plus `model`, the expected image's own
    accuracy). Groups, not single pixels: light tracing splats make a pixel's noise heavy
    tailed, a group's mean is near normal; a wrong density or orientation shifts whole groups."""
    mean = 0.5 * (a + b)[inside]
    var = (a - b)[inside] ** 2 / 4
    order = np.argsort(expected @ np.array([0.2126, 0.7152, 0.0722]))
    for group in np.array_split(order, groups):
        diff = (mean[group] - expected[group]).mean(axis=0)
        se = np.sqrt(var[group].mean(axis=0) / len(group))
        bound = 4 * se + model * expected[group].mean(axis=0) + 1e-6
        assert np.all(np.abs(diff) < bound), (diff, se, expected[group].mean(axis=0))


def test_diffuse_sphere_under_the_map_shows_the_irradiance_integral():
    img = env_image()
    img[3, 7] = img[3, 6]  # no spot: the grid integral stays accurate to 1e-3
    albedo = 0.7
    scene = diffuse_sphere(albedo)
    scene.environment = Environment(SCALE, image=img, to_world=TO_WORLD)
    a, b = renders(scene, "bdpt", 16, (1, 2), size=SPHERE_SIZE)
    inside = np.isfinite(sphere_pixel_normals(scene, SPHERE_SIZE, subpixels=4)[0]).all(axis=(-1, -2))
    # E(n) is smooth: the normal at the pixel's centre stands for the pixel.
    centre = sphere_pixel_normals(scene, SPHERE_SIZE, subpixels=1)[0][inside][:, 0]
    expected = albedo / np.pi * irradiance(centre, img)
    assert_matches(a, b, expected, inside, 2e-3)


def test_diffuse_sphere_under_a_distant_light_shows_lambert():
    albedo = 0.8
    scene = diffuse_sphere(albedo)
    scene.distant_lights = [SUN]
    a, b = renders(scene, "bdpt", 16, (1, 2), size=SPHERE_SIZE)
    normals, _ = sphere_pixel_normals(scene, SPHERE_SIZE, subpixels=8)
    cos = normals @ SUN.direction
    # Exact per subpixel ray, the pixel's value their mean (64 rays against the render's 16
    # jittered ones): pixels across the terminator are left out, where the kink of
    # max(0, cos) makes the two averages differ by more than the noise.
    inside = np.isfinite(normals).all(axis=(-1, -2)) & ((cos.min(axis=-1) > 0) | (cos.max(axis=-1) < 0))
    cos = np.maximum(cos[inside], 0.0)
    expected = albedo / np.pi * cos.mean(axis=1)[:, None] * SUN.irradiance
    assert_matches(a, b, expected, inside, 5e-3)
    # Light tracing alone makes the same image: the disk's density is right.
    c, d = renders(scene, "bdpt", 16, (3, 4), size=SPHERE_SIZE, only_s=2)
    assert_matches(c, d, expected, inside, 5e-3)


# ---------------------------------------------------------------- white furnace
@pytest.mark.parametrize("material", [Material("white", base_color=[1.0] * 3),
                                      Material("glass", "dielectric", base_color=[1.0] * 3, ior=1.5)],
                         ids=["diffuse-albedo-1", "clear-glass"])
def test_white_furnace_through_the_environment_map(material):
    """A sphere that loses nothing vanishes in an environment of radiance 1, here given as a
    map (all ones) so that light subpaths start from the map's importance sampling and its
    pdf weighs the escaped camera subpaths."""
    scene = diffuse_sphere(1.0)
    scene.materials = [material]
    scene.max_depth = 16
    scene.environment = Environment([1.0, 1.0, 1.0], image=np.ones((8, 16, 3), np.float32))
    image = renders(scene, "bdpt", 16, [5], size=SPHERE_SIZE)[0]
    values = image.ravel()
    se = values.std(ddof=1) / np.sqrt(values.size)  # pixels are independent estimates
    assert abs(values.mean() - 1.0) < 3 * se + 1e-6, (values.mean(), se)
