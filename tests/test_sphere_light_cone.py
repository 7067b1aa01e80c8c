"""Next event estimation towards emissive spheres (shaders/lift/lights.glsl): from outside a
sphere, sample_light draws a direction uniform in the cone the sphere subtends, and
light_pdf (what MIS uses when a BSDF-sampled ray hits the sphere) must give that same
density. Checked here against things the sampler does not compute:
  - the directions, binned by (1 - cos theta) / (1 - cos theta_max) and the azimuth about
    the cone's axis, are uniform (chi-square);
  - E[1 / pdf] over the samples equals the solid angle of the spheres, which a second
    estimator (uniform directions over the sphere of directions, traced) measures;
  - light_pdf integrates to 1 over the directions that hit an emitter (uniform directions,
    traced): each sphere's density is its choice probability over the visible cap only;
  - tracing the sampled direction finds the sphere at the distance the sample claims, and
    light_pdf there equals the sample's pdf;
  - pt renders the same image with cone sampling and with the old area sampling
    (LIFT_SPHERE_AREA_LIGHTS), within noise.
"""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy import stats

from image_stats import assert_same_image
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

# Two emissive spheres of different power above a floor, far enough apart that neither
# hides the other from the floor the camera sees (so visible caps and solid angles add up).
SCENE = """
[camera]
position = [0, 3.0, 5.5]
target = [0, 0.4, 0]
fov = 40

[film]
size = [32, 32]

[integrator]
max_depth = 3

[materials.floor]
color = [0.6, 0.6, 0.6]

[materials.glossy]
type = "conductor"
metal = "gold"
roughness = 0.3

[materials.lamp]
color = 0
emission = [6, 5, 4]

[materials.small]
color = 0
emission = [20, 20, 30]

[[objects]]
type = "quad"
material = "floor"
center = [0, 0, 0]
u = [0, 0, 4]
v = [4, 0, 0]

[[objects]]
type = "sphere"
material = "glossy"
center = [0.4, 0.35, 0.6]
radius = 0.35

[[objects]]
type = "sphere"
material = "lamp"
center = [-1.2, 1.5, -0.6]
radius = 0.5

[[objects]]
type = "sphere"
material = "small"
center = [1.6, 1.5, -0.6]
radius = 0.2
"""

LAMP_RADIUS = 0.5  # the lamp, told from the other spheres by its radius

MANIFEST = """name = "sphere_cone_checks"
entry = "main.glsl"
primary = "gbuffer"
[params.mode]
type = "int"
default = 0
"""

SHADER = """
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    if (hit.prim == NO_HIT) return vec3(-1.0);
    Surface s = surface_at(ray, hit);
    if (s.prim >= u_num_triangles) return vec3(-1.0);  // floor points only
    if (mode == 0) {
        // Where the sample falls in the lamp's cone: bins of (1 - cos) / (1 - cos_max) and
        // of the azimuth, in a frame of this test's own (-1: not the lamp).
        LightSample ls;
        if (!sample_light(s.p, rng_next3(rng), ls)) return vec3(-2.0);
        vec4 cr = vec4(0.0);  // the lamp (the host may move the scene: read it where it is)
        for (uint k = 0u; k < 2u; ++k)
            if (abs(spheres[2u * k].w - LAMP_R) < 1e-5) cr = spheres[2u * k];
        vec3 d = cr.xyz - s.p;
        float dc = length(d);
        vec3 axis = d / dc;
        float cos_t = dot(ls.wi, axis);
        float sin2_max = LAMP_R * LAMP_R / (dc * dc);
        float cos_max = sqrt(1.0 - sin2_max);
        if (cos_t < cos_max - 1e-4) return vec3(-1.0);  // the other sphere
        vec3 x = normalize(vec3(0.0, 1.0, 0.0) - axis * axis.y), y = cross(axis, x);
        vec3 q = ls.wi - cos_t * axis;
        float phi = atan(dot(q, y), dot(q, x));
        return vec3((1.0 - cos_t) / (1.0 - cos_max), (phi + LIFT_PI) / (2.0 * LIFT_PI), 1.0);
    }
    if (mode == 1) {
        // x: 1 / pdf of light samples (E: solid angle of all emitters, times the choice);
        // y: 4 pi where a uniform direction hits an emitter (E: their solid angle);
        // z: 4 pi light_pdf there (E: 1, each emitter's choice over its visible cap).
        LightSample ls;
        float inv_pdf = sample_light(s.p, rng_next3(rng), ls) ? 1.0 / ls.pdf : 0.0;
        vec3 w = sample_uniform_sphere(rng_next2(rng));
        Hit h;
        Ray r = spawn_ray(s, w);
        float y = 0.0, z = 0.0;
        if (trace_closest(r, h)) {
            Surface l = surface_at(r, h);
            if (l.light_select_pdf > 0.0) {
                y = 4.0 * LIFT_PI;
                z = 4.0 * LIFT_PI * light_pdf(s.p, l, w, length(l.p - s.p));
            }
        }
        return vec3(inv_pdf, y, z);
    }
    // mode 2: the sampled direction, traced, hits the emitter at the claimed distance, and
    // light_pdf there gives the sample's pdf (x: 1 if both hold, y: 1 for a sample).
    LightSample ls;
    if (!sample_light(s.p, rng_next3(rng), ls)) return vec3(0.0);
    Ray r = spawn_ray(s, ls.wi);
    Hit h;
    if (!trace_closest(r, h)) return vec3(0.0, 1.0, 0.0);
    Surface l = surface_at(r, h);
    float t = length(l.p - s.p);
    bool same = abs(t - ls.dist) < 1e-3 * ls.dist
        && abs(light_pdf(s.p, l, ls.wi, t) - ls.pdf) < 1e-3 * ls.pdf;
    return vec3(same ? 1.0 : 0.0, 1.0, 0.0);
}
"""


class AreaRenderer(Renderer):
    """The renderer with the old sphere sampler: points uniform on the sphere's area."""

    def _shader_defines(self) -> dict:
        return dict(super()._shader_defines(), LIFT_SPHERE_AREA_LIGHTS=True)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "spheres.toml"
    path.write_text(SCENE)
    return load_scene(path)


@pytest.fixture(scope="module")
def lamps(scene):
    """The scene without the glossy ball, which would hide parts of the lamps from the floor."""
    only = copy.copy(scene)
    only.spheres = [s for s in scene.spheres if s.radius != 0.35]
    assert len(only.spheres) == 2
    return only


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plugins") / "sphere_cone_checks"
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST)
    (folder / "main.glsl").write_text(SHADER.replace("LAMP_R", f"{LAMP_RADIUS:.6f}"))
    return folder


def render_samples(scene, plugin, mode, size, seeds, spp=1, cls=Renderer):
    """Per-pixel values of `seeds` renders (each pixel the mean of spp samples)."""
    out = []
    for seed in seeds:
        r = cls(scene, size=size, integrator=str(plugin), seed=seed, params={"mode": mode})
        out.append(r.render(spp=spp).reshape(-1, 3).astype(np.float64))
        r.release()
    return np.concatenate(out)


def test_cone_directions_are_uniform(lamps, plugin):
    v = render_samples(lamps, plugin, 0, (64, 64), seeds=range(4))
    assert np.count_nonzero(v[:, 0] == -2.0) == 0  # no sample from outside the spheres fails
    lamp = v[v[:, 2] == 1.0]
    assert len(lamp) > 4000, len(lamp)
    assert np.all((lamp[:, :2] >= -1e-4) & (lamp[:, :2] <= 1 + 1e-4))
    bins = 8
    idx = (np.clip((lamp[:, 0] * bins).astype(int), 0, bins - 1) * bins
           + np.clip((lamp[:, 1] * bins).astype(int), 0, bins - 1))
    counts = np.bincount(idx, minlength=bins * bins)
    chi2, p = stats.chisquare(counts)
    assert p > 1e-3, (chi2, p, counts.reshape(bins, bins))


def test_pdf_matches_solid_angle_and_light_pdf(lamps, plugin):
    v = render_samples(lamps, plugin, 1, (32, 32), seeds=[5], spp=64)
    v = v[v[:, 0] >= 0.0]  # floor pixels
    assert len(v) > 300
    # Pixels are independent means: compare the two solid-angle estimators pixel by pixel,
    # then over the image (Welch).
    diff = v[:, 0] - v[:, 1]
    t = diff.mean() / (diff.std(ddof=1) / math.sqrt(len(diff)))
    assert abs(t) < 4.0, (t, v[:, 0].mean(), v[:, 1].mean())
    mean_z, se_z = v[:, 2].mean(), v[:, 2].std(ddof=1) / math.sqrt(len(v))
    assert abs(mean_z - 1.0) < 4.0 * se_z + 1e-3, (mean_z, se_z)


def test_area_pdf_fails_the_light_pdf_integral(lamps, plugin):
    """The integral check above can fail: with area sampling light_pdf integrates to the
    visible fraction of each sphere's area (under 1/2), not to 1."""
    v = render_samples(lamps, plugin, 1, (32, 32), seeds=[5], spp=64, cls=AreaRenderer)
    v = v[v[:, 0] >= 0.0]
    mean_z, se_z = v[:, 2].mean(), v[:, 2].std(ddof=1) / math.sqrt(len(v))
    assert mean_z + 6.0 * se_z < 1.0, (mean_z, se_z)


def test_sampled_direction_hits_the_sphere_with_that_pdf(lamps, plugin):
    v = render_samples(lamps, plugin, 2, (32, 32), seeds=[7], spp=16)
    v = v[v[:, 0] >= 0.0]  # floor pixels
    samples = v[:, 1].sum()
    assert samples > 300
    assert v[:, 0].sum() >= 0.999 * samples, (v[:, 0].sum(), samples)


def test_pt_cone_and_area_sampling_agree(scene):
    """pt with cone sampling and with the old area sampling converge to the same image."""
    def renders(cls, seeds):
        out = []
        for seed in seeds:
            r = cls(scene, size=(32, 32), integrator="pt", seed=seed)
            out.append(r.render(spp=4).astype(np.float64)[..., :3])
            r.release()
        return np.stack(out)

    cone = renders(Renderer, range(16))
    area = renders(AreaRenderer, range(100, 116))
    assert_same_image(cone, area, block=8, label="pt cone vs area")
    # Same spp, pixel by pixel: where both estimators had the same variance, the ratio of two
    # sample variances of 16 renders would be F(15, 15), whose median is 1 (the median over
    # hundreds of pixels, within a few percent of it). The cone's ratio is far below.
    var_cone, var_area = cone.var(axis=0, ddof=1).mean(-1), area.var(axis=0, ddof=1).mean(-1)
    noisy = var_area > 0
    assert np.count_nonzero(noisy) > 300
    assert np.median(var_cone[noisy] / var_area[noisy]) < 0.5
