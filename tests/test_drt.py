"""The distribution ray tracer (plugins/drt) against independent answers: the thin lens's
circle of confusion and the motion extent, measured on blurred edges; pt's direct light;
an analytic white furnace for clear glass; pt on a glossy sphere.

Statistics: an edge that is straight and vertical has the same expected profile in every
image row, and every pixel draws its own random numbers, so groups of rows are independent
renders of one profile. The blur parameters are fitted per group, and the tolerance is a
number of standard errors of their mean.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from conftest import REPO, furnace_scene
from sample_stats import block_means, welch_t
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene
from lift_gl.scene.loader import load_scene
from lift_gl.scene.primitives import quad

# Two-sided p < 1e-3 for Student's t with 11 degrees of freedom (12 groups): 4.44.
T_CRIT = 4.5
GROUPS = 12


# ---------------------------------------------------------------- edge profiles
def disk_edge_integral(s):
    """Antiderivative of the edge spread function of a uniform unit disk (the fraction of
    the disk left of x = s): 0 below s = -1, s above s = 1."""
    s = np.asarray(s, np.float64)
    c = np.clip(s, -1.0, 1.0)
    root = np.sqrt(1.0 - c * c)
    inside = c / 2 + (-(root ** 3) / 3 + c * np.arcsin(c) + root) / math.pi
    return np.where(s < -1, 0.0, np.where(s > 1, s, inside))


def defocused_edge(columns, edge, radius):
    """Pixel values (box filter over [c, c + 1]) of a unit step at x = edge, seen through a
    uniform disk of `radius` pixels."""
    return radius * (disk_edge_integral((columns + 1 - edge) / radius)
                     - disk_edge_integral((columns - edge) / radius))


def ramp_integral(s):
    """Antiderivative of clamp(s, 0, 1)."""
    s = np.asarray(s, np.float64)
    return np.where(s < 0, 0.0, np.where(s > 1, s - 0.5, s * s / 2))


def moving_edge(columns, centre, extent):
    """Pixel values of a unit step x > edge(t) whose edge moves at constant speed over
    `extent` pixels, centred on `centre`, while the shutter is open (a box shutter)."""
    start = centre - extent / 2
    return extent * (ramp_integral((columns + 1 - start) / extent) - ramp_integral((columns - start) / extent))


def fit_profiles(image, model, guess):
    """Fit model(columns, centre, width) to the mean row of each of GROUPS row groups.
    Returns the fitted (centre, width) of each group, shape (GROUPS, 2)."""
    rows = image[..., 0].astype(np.float64)   # a white emitter: every channel the same
    columns = np.arange(rows.shape[1], dtype=np.float64)
    fits = []
    for group in np.array_split(rows, GROUPS, axis=0):
        profile = group.mean(axis=0)
        result = least_squares(lambda p: model(columns, *p) - profile, guess)
        assert result.success
        fits.append(result.x)
    return np.array(fits)


def assert_mean_within(values, expected, name, max_relative_se):
    mean = values.mean()
    se = values.std(ddof=1) / math.sqrt(len(values))
    # The test must be able to fail: its standard error is well below the effect sizes
    # worth catching (a lens or a shutter off by a few percent).
    assert se < max_relative_se * abs(expected) + 1e-3, f"{name}: standard error {se:.3g} too large"
    assert abs(mean - expected) < T_CRIT * se + 1e-9, (
        f"{name}: measured {mean:.4f} +- {se:.4f}, expected {expected:.4f} "
        f"({(mean - expected) / se:.1f} standard errors)")


def edge_scene(depth, camera: Camera, size, velocity=None) -> Scene:
    """A white emitter (radiance 1) filling the half plane x > 0 at distance `depth` in
    front of a camera at the origin looking down -z; nothing else, black background."""
    big = 20.0 * depth
    emitter = quad([0.0, -big / 2, -depth], [big, 0, 0], [0, big, 0], material=0, name="edge")  # faces +z
    emitter.velocity = velocity
    return Scene(camera=camera, materials=[Material("lamp", base_color=[0, 0, 0], emission=[1, 1, 1])],
                 meshes=[emitter], film_size=size)


SIZE = (64, 48)
FOV = 20.0
SPP = 64


def pixel_size_at(distance: float) -> float:
    """World size of one pixel at `distance` along the view direction (square pixels)."""
    return 2.0 * distance * math.tan(math.radians(FOV) / 2) / SIZE[1]


def render_drt(scene, seed=1, spp=SPP, **params):
    r = Renderer(scene, size=SIZE, integrator="drt", seed=seed, params=params)
    image = r.render(spp=spp)
    assert r.stats.dropped_samples == 0
    r.release()
    return image


# ---------------------------------------------------------------- depth of field
@pytest.mark.parametrize("depth", [4.0, 1.25], ids=["behind focus", "in front of focus"])
def test_defocus_blur_is_the_thin_lens_circle_of_confusion(depth):
    """A point at distance Z seen by a thin lens of radius A focused at F spreads over a disk
    of radius A |1 - F / Z| on the plane of focus: in pixels, that over the pixel size there."""
    aperture, focus = 0.25, 2.0
    camera = Camera(position=[0, 0, 0], target=[0, 0, -1], fov_deg=FOV, aperture_radius=aperture,
                    focus_distance=focus)
    image = render_drt(edge_scene(depth, camera, SIZE))
    coc = aperture * abs(1.0 - focus / depth) / pixel_size_at(focus)
    assert 6 < coc < 14  # wide enough to measure, narrow enough to stay inside the image
    fits = fit_profiles(image, defocused_edge, guess=[SIZE[0] / 2 + 1, coc * 0.7])
    assert_mean_within(fits[:, 0], SIZE[0] / 2, "edge position (px)", 0.01)
    assert_mean_within(fits[:, 1], coc, "circle of confusion radius (px)", 0.01)


def test_pinhole_edge_is_sharp():
    """Aperture 0: the same edge is a step antialiased over one pixel, exactly."""
    camera = Camera(position=[0, 0, 0], target=[0, 0, -1], fov_deg=FOV, aperture_radius=0.0)
    image = render_drt(edge_scene(4.0, camera, SIZE), spp=16)
    columns = image[..., 0].mean(axis=0)
    half = SIZE[0] // 2
    assert np.all(columns[:half] == 0.0) and np.all(columns[half:] == 1.0)


# ---------------------------------------------------------------- motion blur
def test_motion_blur_spreads_an_edge_over_its_motion_extent():
    """An edge moving at constant speed across the image while the shutter is open covers
    each pixel for the fraction of the shutter it is past it: a linear ramp as wide as the
    motion in pixels. The shutter opens at t = 0.5, so the edge (at x = -v at time 0) moves
    from -v/2 to +v/2 and the ramp is centred in the image."""
    depth, speed = 3.0, 0.27
    camera = Camera(position=[0, 0, 0], target=[0, 0, -1], fov_deg=FOV, shutter=(0.5, 1.5))
    scene = edge_scene(depth, camera, SIZE, velocity=[speed, 0, 0])
    scene.meshes[0].positions[:, 0] -= speed
    image = render_drt(scene)
    extent = speed / pixel_size_at(depth)
    assert 8 < extent < 20
    fits = fit_profiles(image, moving_edge, guess=[SIZE[0] / 2 + 1, extent * 0.7])
    assert_mean_within(fits[:, 0], SIZE[0] / 2, "ramp centre (px)", 0.01)
    assert_mean_within(fits[:, 1], extent, "motion extent (px)", 0.01)


# ---------------------------------------------------------------- against pt and analytic values
def _renders(scene, integrator, seeds, size, spp, **params):
    images = []
    for seed in seeds:
        r = Renderer(scene, size=size, integrator=integrator, seed=seed, params=params)
        images.append(r.render(spp=spp).astype(np.float64))
        assert r.stats.dropped_samples == 0, integrator
        r.release()
    return np.array(images)


def _assert_same_expectation(a, b, what):
    """a, b: (K, H, W, 3) independent renders. The whole image and each 4x4 block agree
    within the standard errors of their means. With 2K - 2 = 14 degrees of freedom,
    P(|t| > 6) ~ 4e-5 per block: over 64 blocks a false alarm is a 1-in-400 event."""
    whole = welch_t(a.mean(axis=(1, 2, 3)), b.mean(axis=(1, 2, 3)))
    assert abs(whole) < T_CRIT, f"{what}: image means differ by {whole:.2f} standard errors"
    t = welch_t(block_means(a), block_means(b))
    assert np.abs(t).max() < 6.0, f"{what}: worst block {np.abs(t).max():.2f} standard errors"


def test_drt_direct_light_matches_pt_with_one_bounce():
    """On a diffuse scene drt computes emitted plus direct light (shadow rays only), pt with
    max_depth = 1 the same (light and BSDF sampling with MIS): the same expectation."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    for m in scene.materials:
        if m.type != "diffuse":
            m.type, m.base_color, m.alpha = "diffuse", np.array([0.6, 0.6, 0.6]), 0.0
    size, seeds = (32, 32), range(1, 9)
    drt = _renders(scene, "drt", seeds, size, 32, max_depth=1)
    pt = _renders(scene, "pt", [100 + s for s in seeds], size, 32, max_depth=1)
    _assert_same_expectation(drt, pt, "drt vs pt, direct light")
    # More bounces add nothing in drt: a diffuse surface ends the ray tree.
    deeper = _renders(scene, "drt", seeds, size, 32, max_depth=5)
    assert np.array_equal(deeper, drt)


def test_drt_direct_light_from_a_distant_light_matches_pt():
    """A distant (delta) light on diffuse and rough metal surfaces: drt's shadow rays must
    count it in full (no MIS: BSDF sampling can never find it), as pt's do."""
    from test_bdpt_lights import porch
    scene = porch("distant")
    scene.spheres[0].material = scene.material_index("metal")  # glossy, where drt weighs by MIS
    size, seeds = (32, 32), range(1, 9)
    drt = _renders(scene, "drt", seeds, size, 16, max_depth=1)
    pt = _renders(scene, "pt", [100 + s for s in seeds], size, 16, max_depth=1)
    assert drt.mean() > 0.05
    _assert_same_expectation(drt, pt, "drt vs pt, direct light from a distant light")


def test_clear_glass_is_invisible_in_a_white_furnace():
    """A smooth glass sphere in a constant environment of radiance 1: every branch of the
    ray tree (mirror or refraction, weights F/F and (1-F)/(1-F) with the eta^2 radiance
    scaling undone on the way out) escapes to the environment, so every pixel is 1, up to
    branches cut by max_depth (rare: internal reflections at grazing angles)."""
    scene = furnace_scene(Material("glass", "dielectric", base_color=[1, 1, 1], ior=1.5), size=(32, 32))
    image = _renders(scene, "drt", [3], (32, 32), 16, max_depth=32)[0]
    np.testing.assert_allclose(image, 1.0, atol=2e-3)
    assert abs(image.mean() - 1.0) < 2e-4


@pytest.mark.parametrize("light_samples", [1, 3])
def test_glossy_sphere_in_a_furnace_matches_pt(light_samples):
    """A rough gold sphere lit by a white sky: drt weighs light_samples sky samples against
    one sampled glossy bounce (MIS); pt does the same with one of each. A convex sphere never
    sees itself, so both give its directional albedo."""
    scene = furnace_scene(Material("gold", "conductor", base_color=[1, 0.8, 0.4], alpha=0.2), size=(32, 32))
    seeds = range(1, 9)
    drt = _renders(scene, "drt", seeds, (32, 32), 16, light_samples=light_samples)
    pt = _renders(scene, "pt", [100 + s for s in seeds], (32, 32), 16)
    _assert_same_expectation(drt, pt, f"glossy furnace, {light_samples} light samples")
