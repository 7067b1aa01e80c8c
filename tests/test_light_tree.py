"""The light tree (lift_gl/scene/light_tree.py, shaders/lift/light_tree.glsl): next event
estimation picks an emitter by its importance at the shading point. Checked against things
the sampler does not compute:
  - the probabilities of the walk, computed in numpy from the tree's rows (an independent
    implementation of the importance), sum to one and reach every light;
  - the lights the shader picks at fixed points match those probabilities (chi-square), and
    each pick's probability equals both numpy's and light_tree_pdf's (what MIS uses) exactly;
  - a sampled direction, traced, hits a light where light_pdf gives the sample's own pdf;
  - pt renders the same image with the tree and with the power selection, within noise, and
    with less variance.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from image_stats import assert_same_image
from lift_gl.chi2 import pearson_chi2
from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene.light_tree import LEAF, NODE_ROWS, light_probabilities
from lift_gl.scene.loader import load_scene
from lift_gl.scene.pack import pack_scene

SCENE = REPO / "scenes" / "many_lights.toml"
SIGNIFICANCE = 0.01
# World points of the hall: near the camera, under the far panels, by the low panel, in a corner.
POINTS = ((0.0, 0.5, 0.0), (1.5, 0.2, -7.5), (2.8, 1.0, -1.2), (-3.9, 3.5, -9.9))

MANIFEST = """name = "light_tree_checks"
entry = "main.glsl"
primary = "gbuffer"
[params.mode]
type = "int"
default = 0
[params.px]
type = "float"
default = 0.0
[params.py]
type = "float"
default = 0.0
[params.pz]
type = "float"
default = 0.0
"""

SHADER = """
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    if (mode == 0) {
        // At the fixed point: the light picked, the pick's probability, and whether
        // light_tree_pdf (MIS's) gives that probability exactly (-1: no pick).
        vec3 p = vec3(px, py, pz);
        uint index;
        float pdf;
        if (!light_tree_pick(p, rng_next(rng), index, pdf)) return vec3(-1.0);
        float again = light_tree_pdf(p, floatBitsToUint(lights[index].x));
        return vec3(float(index), pdf, again == pdf ? 1.0 : 0.0);
    }
    // mode 1: from a surface point, the sampled direction, traced, hits an emitter at the
    // claimed distance where light_pdf gives the sample's pdf (x: 1 if so, y: 1 for a sample).
    // light_pdf is given the sample's distance: the traced one differs by the ray's offset,
    // and the pdf goes with its square.
    if (hit.prim == NO_HIT) return vec3(-1.0);
    Surface s = surface_at(ray, hit);
    LightSample ls;
    if (!sample_light(s.p, rng_next3(rng), ls)) return vec3(0.0);
    Ray r = spawn_ray(s, ls.wi);
    Hit h;
    if (!trace_closest(r, h)) return vec3(0.0);
    Surface l = surface_at(r, h);
    float t = length(l.p - s.p);
    if (l.light_select_pdf <= 0.0 || abs(t - ls.dist) > 1e-3 * ls.dist) return vec3(0.0);  // occluded
    return vec3(abs(light_pdf(s.p, l, ls.wi, ls.dist) - ls.pdf) < 1e-5 * ls.pdf ? 1.0 : 0.0, 1.0, 0.0);
}
"""


@pytest.fixture(scope="module")
def scene():
    return load_scene(SCENE)


@pytest.fixture(scope="module")
def packed(scene):
    return pack_scene(scene, light_selection="tree")


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plugins") / "light_tree_checks"
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST)
    (folder / "main.glsl").write_text(SHADER)
    return folder


def tree_rows(packed):
    return packed.lights[packed.num_lights:], packed.num_lights


def test_probabilities_sum_to_one_and_reach_every_light(packed):
    rows, count = tree_rows(packed)
    assert packed.light_tree and count == 16  # 7 quads of two triangles, 2 spheres
    leaves = rows[: NODE_ROWS * (2 * count - 1)].view(np.uint32)[1::NODE_ROWS, 3]
    assert sorted(int(v) & ~LEAF for v in leaves if v & LEAF) == list(range(count))
    reached = np.zeros(count)
    for world in POINTS + ((0.0, 3.5, -4.0), (-2.0, 0.0, 1.0), (3.9, 3.0, -9.9)):
        prob = light_probabilities(rows, count, np.array(world) - packed.origin)
        assert abs(prob.sum() - 1.0) < 1e-9, (world, prob)
        reached += prob
    assert np.all(reached > 0), reached


def test_picks_match_the_tree_probabilities(scene, packed, plugin):
    rows, count = tree_rows(packed)
    significance = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / len(POINTS))  # Sidak, over the points
    for world in POINTS:
        p = np.array(world) - packed.origin
        expected = light_probabilities(rows, count, p)
        samples = []
        for seed in range(4):
            r = Renderer(scene, size=(64, 64), integrator=str(plugin), seed=seed, params={"mode": 0},
                         options=Options(light_selection="tree"))
            assert np.allclose(r.packed.origin, packed.origin)
            r.set_params(px=float(p[0]), py=float(p[1]), pz=float(p[2]))
            samples.append(r.render(spp=1).reshape(-1, 3).astype(np.float64))
            r.release()
        v = np.concatenate(samples)
        assert np.all(v[:, 0] >= 0), "a pick failed where lights face the point"
        index = v[:, 0].astype(int)
        assert np.all(v[:, 2] == 1.0), "light_tree_pdf differs from the pick's probability"
        assert np.allclose(v[:, 1], expected[index], rtol=1e-4, atol=1e-6), world  # float32 against float64
        counts = np.bincount(index, minlength=count)
        _, dof, p_value = pearson_chi2(counts, len(v) * expected)
        assert p_value > significance, (world, counts, np.round(len(v) * expected, 1), p_value)


def test_sampled_direction_has_the_pdf_light_pdf_gives(scene, plugin):
    r = Renderer(scene, size=(48, 48), integrator=str(plugin), seed=7, params={"mode": 1},
                 options=Options(light_selection="tree"))
    v = r.render(spp=8).reshape(-1, 3).astype(np.float64)
    r.release()
    v = v[v[:, 0] >= 0]
    # Each pixel is the mean over its samples: every unoccluded sample agreed where x = y.
    assert v[:, 1].sum() > 200
    assert np.all(np.abs(v[:, 0] - v[:, 1]) < 1e-6), (v[:, 0].sum(), v[:, 1].sum())


def test_pt_tree_and_power_converge_to_the_same_image_with_less_noise(scene):
    def renders(selection, seeds):
        out = []
        for seed in seeds:
            r = Renderer(scene, size=(32, 32), integrator="pt", seed=seed, options=Options(light_selection=selection))
            out.append(r.render(spp=4).astype(np.float64)[..., :3])
            assert r.stats.dropped_samples == 0
            r.release()
        return np.stack(out)

    tree = renders("tree", range(16))
    power = renders("power", range(100, 116))
    assert_same_image(tree, power, block=8, label="pt tree vs power")
    # Same spp: with equal variance the pixels' ratio of sample variances would have median ~1.
    var_tree, var_power = tree.var(axis=0, ddof=1).mean(-1), power.var(axis=0, ddof=1).mean(-1)
    noisy = var_power > 0
    assert np.median(var_tree[noisy] / var_power[noisy]) < 0.8


def test_auto_uses_the_tree_for_many_lights_and_power_for_one_flat_emitter(scene):
    from lift_gl.scene.light_choice import one_flat_emitter
    assert not one_flat_emitter(scene)
    cornell = load_scene(REPO / "scenes" / "cornell.toml")
    assert one_flat_emitter(cornell)
    r = Renderer(cornell, size=(8, 8))
    assert r.choices["light_selection"] == "power" and not r.packed.light_tree
    assert "LIFT_LIGHT_TREE" not in r.defines
    r.release()


def test_pt_with_the_tree_agrees_with_bdpt(scene):
    """bdpt starts its light subpaths by power (emission.glsl), not by the tree: an estimator
    that shares nothing with the tree's choice converges to pt's image."""
    def renders(integrator, seeds):
        out = []
        for seed in seeds:
            r = Renderer(scene, size=(32, 32), integrator=integrator, seed=seed)
            out.append(r.render(spp=4).astype(np.float64)[..., :3])
            r.release()
        return np.stack(out)

    assert_same_image(renders("pt", range(16)), renders("bdpt", range(200, 216)), block=8, label="pt tree vs bdpt")
