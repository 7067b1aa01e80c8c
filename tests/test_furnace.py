"""White furnace tests: analytic answers that the whole renderer (G-buffer, trace host, pt,
BSDFs, light sampling, accumulation) must reproduce within its own Monte Carlo error."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import furnace_scene, sphere_pixel_cosines
from furnace_reference import ggx_directional_albedo
from lift_gl.renderer import Renderer
from lift_gl.scene import Material

SIZE = (48, 48)
SPP = 64


def render(material, spp=SPP):
    scene = furnace_scene(material, size=SIZE)
    renderer = Renderer(scene, size=SIZE, integrator="pt", seed=1)
    image = renderer.render(spp=spp)
    assert renderer.stats.dropped_samples == 0
    assert np.isfinite(image).all()
    return scene, image


def assert_mean_within_3_standard_errors(values, expected):
    """Pixels are independent estimates: their mean is within 3 standard errors of `expected`."""
    residual = (values - expected).ravel()
    standard_error = residual.std(ddof=1) / np.sqrt(residual.size)
    # A zero-variance estimator must be exact to float precision.
    tolerance = max(3.0 * standard_error, 1e-5)
    assert abs(residual.mean()) <= tolerance, (residual.mean(), standard_error)


def interior_mask(scene):
    cos = sphere_pixel_cosines(scene, SIZE)
    return np.all(np.isfinite(cos), axis=-1), cos


def test_diffuse_sphere_albedo_08_shows_08():
    scene, image = render(Material("grey", "diffuse", base_color=[0.8, 0.8, 0.8]))
    inside, _ = interior_mask(scene)
    assert inside.sum() > 500
    assert_mean_within_3_standard_errors(image[inside], 0.8)
    # The background is the environment itself: pixels that miss a slightly larger sphere.
    larger = furnace_scene(Material("grey"), size=SIZE)
    larger.spheres[0].radius *= 1.05
    outside = ~np.any(np.isfinite(sphere_pixel_cosines(larger, SIZE)), axis=-1)
    assert outside.sum() > 300
    assert np.allclose(image[outside], 1.0, atol=1e-6)


def test_diffuse_sphere_albedo_1_vanishes():
    scene, image = render(Material("white", "diffuse", base_color=[1.0, 1.0, 1.0]))
    # Every pixel, silhouettes included, converges to the environment's radiance.
    assert_mean_within_3_standard_errors(image, 1.0)
    inside, _ = interior_mask(scene)
    assert_mean_within_3_standard_errors(image[inside], 1.0)


@pytest.mark.parametrize("alpha", [0.0, 0.1, 0.3, 0.6, 1.0])
def test_ggx_conductor_f0_1_loses_only_single_scattering_energy(alpha):
    scene, image = render(Material("mirror", "conductor", base_color=[1.0, 1.0, 1.0], alpha=alpha))
    inside, cos = interior_mask(scene)
    mus = np.linspace(0.0, 1.0, 65)
    table = np.array([1.0 if alpha == 0.0 else ggx_directional_albedo(max(mu, 1e-4), alpha) for mu in mus])
    expected = np.interp(cos[inside], mus, table).mean(axis=-1)  # box filter over the pixel
    assert_mean_within_3_standard_errors(image[inside][:, 0], expected)
