"""Environment maps: the importance sampler of shaders/lift/lights.glsl against its pdf
(chi-square over the map's cells and within them), the pdf's normalisation and value, the
radiance lookup, and an end-to-end render of a diffuse sphere lit by a map, against the
irradiance integral computed here in numpy.

The test's expectations come from the conventions alone (envmap.py's docstring): direction
<-> (u, v) and bilinear lookup are re-derived below, and the cell probabilities are the
mean luminance of the bilinear radiance over each cell (supersampled here) times
sin(theta) at the cell's centre.
"""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.chi2 import pearson_chi2
from lift_gl.glsl_kernel import Kernel
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Environment, Material, Scene, Sphere
from lift_gl.scene.images import pack_images
from lift_gl.scene.primitives import axis_angle_matrix

LUM = np.array([0.2126, 0.7152, 0.0722])
SAMPLES = 1 << 20
SIGNIFICANCE = 1e-3


# ---- the conventions, re-derived -----------------------------------------------------------
def to_uv(d):
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.stack([np.mod(np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi), 1.0),
                     np.arccos(np.clip(d[..., 1], -1, 1)) / np.pi], axis=-1)


def from_uv(uv):
    phi, theta = 2 * np.pi * uv[..., 0], np.pi * uv[..., 1]
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)


def lookup(img, uv):
    """Bilinear between texel centres; u repeats, v clamps."""
    h, w = img.shape[:2]
    x, y = uv[..., 0] * w - 0.5, uv[..., 1] * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    c = lambda yy, xx: img[np.clip(yy, 0, h - 1), np.mod(xx, w)].astype(np.float64)  # noqa: E731
    return ((c(y0, x0) * (1 - fx) + c(y0, x0 + 1) * fx) * (1 - fy)
            + (c(y0 + 1, x0) * (1 - fx) + c(y0 + 1, x0 + 1) * fx) * fy)


def env_image(h=16, w=32):
    """Smooth colour gradients, a bright spot, and a block of zeros (never to be sampled)."""
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    img = np.zeros((h, w, 3), np.float32)
    img[..., 0] = 1.0 + np.cos(np.pi * v)[:, None]
    img[..., 1] = 0.6 + 0.5 * np.sin(2 * np.pi * u)[None, :]
    img[..., 2] = 0.2 + v[:, None] * u[None, :]
    img[3, 7] = (40.0, 30.0, 20.0)
    img[9:14, 20:28] = 0.0
    return img


TO_WORLD = (axis_angle_matrix(35.0, (1.0, 2.0, 0.5)))[:3, :3]
SCALE = np.array([1.5, 1.0, 0.5])


def scene_with_map(img, **kw):
    return Scene(camera=Camera(position=[0, 0, 3], target=[0, 0, 0], fov_deg=45.0),
                 environment=Environment(SCALE, image=img, to_world=TO_WORLD), **kw)


# ---- the sampler, in a kernel --------------------------------------------------------------
SAMPLE_KERNEL = """
#include "lift/lights.glsl"
layout(std430, binding = 10) writeonly buffer Out0 { vec4 out_dir[]; };   // wi, ls.pdf (-1: failed)
layout(std430, binding = 11) writeonly buffer Out1 { vec4 out_pdf[]; };   // radiance, env_light_pdf(wi)
layout(std430, binding = 12) writeonly buffer Out2 { vec4 out_rad[]; };   // env_radiance(wi)
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    Rng rng = rng_init(uvec2(i, 1u), 0u, 0u, 9u);
    LightSample ls;
    bool ok = sample_light(vec3(0.0), rng_next3(rng), ls);
    out_dir[i] = vec4(ls.wi, ok ? ls.pdf : -1.0);
    out_pdf[i] = vec4(ls.radiance, env_light_pdf(ls.wi));
    out_rad[i] = vec4(env_radiance(ls.wi), ls.is_delta ? 1.0 : 0.0);
}
"""
PDF_KERNEL = """
#include "lift/lights.glsl"
layout(std430, binding = 10) readonly buffer In0 { vec4 dirs[]; };
layout(std430, binding = 11) writeonly buffer Out0 { vec4 result[]; };  // env_radiance, env_light_pdf
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    result[i] = vec4(env_radiance(dirs[i].xyz), env_light_pdf(dirs[i].xyz));
}
"""
DEFINES = {"HAS_ENVIRONMENT": True, "HAS_ENVIRONMENT_MAP": True}


def env_uniforms(scene):
    heap, uniforms = pack_images(scene)
    uniforms = dict(uniforms, u_env_radiance=tuple(scene.environment.radiance), u_light_weights=(1.0, 0.0, 0.0, 0.0))
    return heap, uniforms


@pytest.fixture(scope="module")
def sampled():
    img = env_image()
    scene = scene_with_map(img)
    heap, uniforms = env_uniforms(scene)
    out = Kernel(SAMPLE_KERNEL, DEFINES).run(SAMPLES, inputs={9: heap},
                                             outputs={10: (SAMPLES, 4), 11: (SAMPLES, 4), 12: (SAMPLES, 4)},
                                             uniforms=uniforms)
    return img, heap, uniforms, out[10].astype(np.float64), out[11].astype(np.float64), out[12].astype(np.float64)


def expected_cell_probabilities(img, sub=8):
    h, w = img.shape[:2]
    offs = (np.arange(sub) + 0.5) / sub
    us = ((np.arange(w)[:, None] + offs[None, :]) / w).ravel()
    vs = ((np.arange(h)[:, None] + offs[None, :]) / h).ravel()
    uv = np.stack(np.meshgrid(us, vs), axis=-1)  # (h*sub, w*sub, 2)
    lum = lookup(img, uv) @ LUM
    mean = lum.reshape(h, sub, w, sub).mean(axis=(1, 3))
    weights = mean * np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None]
    return weights / weights.sum()


def test_samples_follow_the_cell_distribution_and_are_uniform_within_cells(sampled):
    img, _, _, dirs, _, _ = sampled
    h, w = img.shape[:2]
    ok = dirs[:, 3] > 0
    assert ok.all(), f"{(~ok).sum()} failed samples"
    uv = to_uv(dirs[:, :3] @ TO_WORLD)  # world -> map frame: the inverse of a rotation
    # Twice the map's resolution: each cell's four quarters must get a quarter each.
    x = np.clip((uv[:, 0] * 2 * w).astype(int), 0, 2 * w - 1)
    y = np.clip((uv[:, 1] * 2 * h).astype(int), 0, 2 * h - 1)
    observed = np.bincount(y * 2 * w + x, minlength=4 * h * w).astype(float)
    probs = np.repeat(np.repeat(expected_cell_probabilities(img), 2, axis=0), 2, axis=1) / 4
    expected = probs.ravel() * SAMPLES
    # Cells whose probability is zero must get nothing.
    assert observed[expected == 0].sum() == 0
    keep = expected > 0
    chi2, dof, p = pearson_chi2(observed[keep], expected[keep])
    assert p > SIGNIFICANCE, f"chi2 = {chi2:.1f} with {dof} dof, p = {p:.3g}"


def test_reported_pdf_is_the_density_of_the_samples(sampled):
    img, _, _, dirs, pdfs, _ = sampled
    h, w = img.shape[:2]
    d_map = dirs[:, :3] @ TO_WORLD
    uv = to_uv(d_map)
    cell = expected_cell_probabilities(img)
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip((uv[:, 1] * h).astype(int), 0, h - 1)
    sin_theta = np.sqrt(np.maximum(0, 1 - (d_map[:, 1] / np.linalg.norm(d_map, axis=1)) ** 2))
    # A cell's probability spread uniformly over its (u, v) area 1 / (w h), where
    # d(solid angle) = 2 pi^2 sin(theta) du dv.
    expected = cell[y, x] * w * h / (2 * np.pi ** 2 * sin_theta)
    away_from_edges = (np.abs(uv[:, 0] * w - np.round(uv[:, 0] * w)) > 1e-3) & \
                      (np.abs(uv[:, 1] * h - np.round(uv[:, 1] * h)) > 1e-3)
    np.testing.assert_allclose(dirs[away_from_edges, 3], expected[away_from_edges], rtol=2e-3)
    # env_light_pdf (what MIS uses for a BSDF-sampled escape) agrees with the sample's pdf.
    np.testing.assert_allclose(pdfs[away_from_edges, 3], dirs[away_from_edges, 3], rtol=2e-3)


def test_radiance_is_the_bilinear_map_times_scale_in_its_frame(sampled):
    img, _, _, dirs, pdfs, rads = sampled
    dirs, pdfs, rads = dirs[: 1 << 17], pdfs[: 1 << 17], rads[: 1 << 17]  # plenty, and quicker
    uv = to_uv(dirs[:, :3] @ TO_WORLD)
    expected = lookup(img, uv) * SCALE
    # GLSL's float32 atan and acos place a direction to about 1e-4 in (u, v) (3e-3 of a
    # texel here): allow what the map changes over that distance, where it is steep.
    delta = 1e-4
    slack = np.max([np.abs(lookup(img, uv + shift) * SCALE - expected)
                    for shift in ([delta, 0], [-delta, 0], [0, delta], [0, -delta])], axis=0)
    # At the poles u is undefined and float32 atan returns any longitude: leave them out.
    poles = np.minimum(uv[:, 1], 1 - uv[:, 1]) < 1e-3
    assert poles.mean() < 1e-2
    ok = np.abs(rads[:, :3] - expected) <= slack + 1e-4 * np.abs(expected) + 1e-6
    assert ok[~poles].all()
    # The slack is a fraction of a percent of the radiance: any other convention would fail.
    assert np.median(slack / np.maximum(np.abs(expected), 1e-3)) < 1e-3
    # LightSample.radiance, looked up at the sampled (u, v): the same map value, poles included
    # (where env_radiance's atan picks any longitude, the sample keeps its own).
    sample_ok = np.abs(pdfs[:, :3] - expected) <= slack + 1e-4 * np.abs(expected) + 1e-6
    assert sample_ok.all(axis=1).mean() > 0.9999
    assert sample_ok[~poles].all()
    assert not rads[:, 3].any(), "an environment sample is not a delta"


def test_pdf_integrates_to_one_and_estimator_is_unbiased(sampled):
    img, heap, uniforms, dirs, pdfs, _ = sampled
    # A midpoint grid in (cos theta, phi) of world directions: d(omega) = d(cos) d(phi).
    n_cos, n_phi = 512, 1024
    c = -1 + (np.arange(n_cos) + 0.5) * 2 / n_cos
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    cc, pp = np.meshgrid(c, phi, indexing="ij")
    s = np.sqrt(1 - cc ** 2)
    grid = np.stack([s * np.cos(pp), s * np.sin(pp), cc, np.zeros_like(cc)], -1).reshape(-1, 4).astype(np.float32)
    out = Kernel(PDF_KERNEL, DEFINES).run(len(grid), inputs={9: heap, 10: grid}, outputs={11: (len(grid), 4)},
                                          uniforms=uniforms)[11].astype(np.float64)
    d_omega = (2 / n_cos) * (2 * np.pi / n_phi)
    total = out[:, 3].sum() * d_omega
    assert total == pytest.approx(1.0, abs=2e-3)
    # E[L / pdf] over the sampler = the integral of L over the sphere (by the grid above).
    integral = (lookup(img, to_uv(grid[:, :3].astype(np.float64) @ TO_WORLD)) * SCALE).sum(axis=0) * d_omega
    estimates = pdfs[:, :3] / dirs[:, 3:4]
    mean, se = estimates.mean(axis=0), estimates.std(axis=0) / np.sqrt(len(estimates))
    # The grid's own error: the bilinear map's kinks, well below 0.2% at this resolution.
    assert np.all(np.abs(mean - integral) < 4 * se + 2e-3 * integral), (mean, integral, se)


# ---- end to end: a diffuse sphere lit by the map ------------------------------------------------
SIZE = (40, 40)
SPP = 64


def irradiance(normals, img, n=96):
    """E(n) = integral of L(w) max(0, n.w) dw, midpoint grid over the sphere (world)."""
    c = -1 + (np.arange(n) + 0.5) * 2 / n
    phi = (np.arange(2 * n) + 0.5) * np.pi / n
    cc, pp = np.meshgrid(c, phi, indexing="ij")
    s = np.sqrt(1 - cc ** 2)
    w = np.stack([s * np.cos(pp), s * np.sin(pp), cc], -1).reshape(-1, 3)
    L = lookup(img, to_uv(w @ TO_WORLD)) * SCALE * (2 / n) * (np.pi / n)
    return np.maximum(normals @ w.T, 0.0) @ L


def test_diffuse_sphere_under_the_map_matches_the_irradiance_integral():
    from conftest import sphere_pixel_cosines

    # A smoother map (no spot): the irradiance integral on a grid stays accurate to 1e-3.
    img = env_image()
    img[3, 7] = img[3, 6]
    albedo = 0.7
    scene = scene_with_map(img, materials=[Material("d", base_color=[albedo] * 3)],
                           spheres=[Sphere([0, 0, 0], 1.0, 0)], film_size=SIZE)
    scene.max_depth = 1  # direct light only; a convex sphere never sees itself anyway
    images = []
    for seed in (1, 2):
        r = Renderer(scene, size=SIZE, seed=seed)
        images.append(r.render(spp=SPP).astype(np.float64))
        assert r.stats.dropped_samples == 0
        r.release()
    a, b = images
    # Pixels fully on the sphere: the centre ray's normal stands for the pixel (E(n) is smooth).
    cos = sphere_pixel_cosines(scene, SIZE, subpixels=4)
    inside = np.isfinite(cos).all(axis=-1)
    cam = scene.camera
    right, up, forward = cam.basis()
    t = np.tan(np.radians(cam.fov_deg) / 2)
    x = (np.arange(SIZE[0]) + 0.5) / SIZE[0] * 2 - 1
    y = (np.arange(SIZE[1]) + 0.5) / SIZE[1] * 2 - 1
    d = forward + x[None, :, None] * t * right + y[:, None, None] * t * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    bq = d @ cam.position
    disc = bq ** 2 - (cam.position @ cam.position - 1.0)
    hit = cam.position + (-bq - np.sqrt(np.maximum(disc, 0)))[..., None] * d
    normals = hit[::-1][inside]
    expected = albedo / np.pi * irradiance(normals, img)
    mean = 0.5 * (a + b)[inside]
    se = np.sqrt(((a - b)[inside] ** 2 / 4).mean(axis=0) / inside.sum())
    diff = (mean - expected).mean(axis=0)
    assert np.all(np.abs(diff) < 4 * se + 2e-3 * expected.mean(axis=0)), (diff, se)
    # Per pixel too: the z-scores of the difference look like noise (and a mis-oriented map
    # fails here even where it cancels on average).
    var = (a - b)[inside] ** 2 / 4
    z = (mean - expected) / np.sqrt(np.maximum(var.mean(axis=0), 1e-12))
    assert np.mean(np.abs(z) > 4) < 0.01


# ---- the search guides: the same cell as a search of the whole cdf -----------------------------
def test_guided_search_finds_the_cell_of_the_whole_search_at_every_bucket_edge():
    from lift_gl.scene.envmap import _density_and_cdf, search_cdf, search_guides

    rng = np.random.default_rng(5)
    n = 97   # not a power of two: u * n rounds inexactly
    weights = rng.random((4, n)) ** 8          # skewed: many cells share a bucket
    weights[1, 10:80] = 0.0                     # a run of empty cells
    weights[2] = 0.0                            # an empty row (uniform)
    weights[3, :] = 1e-9
    weights[3, 50] = 1.0                        # one cell holds nearly everything
    _, cdfs = _density_and_cdf(weights)
    cdfs = cdfs.astype(np.float32)
    guides = search_guides(cdfs)
    # u at every bucket edge k / n and the float32 values just around it, plus random ones
    edges = (np.arange(n + 1) / n).astype(np.float32)
    u = np.concatenate([edges, np.nextafter(edges, np.float32(0)), np.nextafter(edges, np.float32(1)),
                        rng.random(20000).astype(np.float32)])
    u = u[(u >= 0) & (u < 1)]
    for cdf, guide in zip(cdfs, guides):
        bucket = np.minimum((u * np.float32(n)).astype(np.uint32), n - 1)   # float32, as the shader
        lo, span = guide[bucket] & 0xFFFF, guide[bucket] >> 16
        cell = search_cdf(cdf, u)
        assert np.all((lo <= cell) & (cell <= lo + span))
        # a guide narrows the search: buckets of the skewed rows span few cells on average
        assert span.mean() < 8


def test_guides_refuse_a_map_wider_than_their_words():
    from lift_gl.scene.envmap import GUIDE_MAX_CELLS, search_guides

    with pytest.raises(ValueError, match="at most"):
        search_guides(np.linspace(0, 1, GUIDE_MAX_CELLS + 2, dtype=np.float32))
