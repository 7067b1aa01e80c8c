"""benchmarks/bvh_visits.py: its per-ray emulation of the GLSL 4-wide traversal finds the same
closest hits as the level-by-level numpy traversal (accel/wide.intersect_wide_numpy), never visits
fewer nodes than a closest-hit query must, and answers any-hit queries alike."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import REPO, skip_without_shared
from lift_gl.accel.wide import intersect_wide_numpy
from lift_gl.scene.loader import load_scene
from lift_gl.scene.pack import pack_scene

sys.path.insert(0, str(REPO / "benchmarks"))
import bvh_visits  # noqa: E402


@pytest.mark.parametrize("name", ["cornell.toml", "covered_dragon.toml"])
def test_emulated_traversal_finds_the_closest_hits(name):
    skip_without_shared(REPO / "scenes" / name)
    scene = load_scene(REPO / "scenes" / name)
    packed = pack_scene(scene, bvh_width=4)
    tree = bvh_visits.WideTree(packed)
    rays = bvh_visits.scene_rays(scene, packed, tree, 120, np.random.default_rng(3))
    o, d, _ = rays["bounce"]
    o, d = np.concatenate([rays["camera"][0], o]), np.concatenate([rays["camera"][1], d])
    from lift_gl.accel.wide import WideBVH
    wide = WideBVH(rows=packed.bvh_nodes, width=4, stack_bound=packed.bvh_stack, levels=packed.bvh_levels)
    t_ref, _ = intersect_wide_numpy(wide, tree.tris, o, d, tmin=bvh_visits.T_EPS)
    runs = [bvh_visits.traverse(tree, o[i], d[i]) for i in range(len(o))]
    t = np.array([r["t"] for r in runs])
    assert np.isfinite(t).mean() > 0.5
    np.testing.assert_allclose(t, t_ref, rtol=1e-12)
    fewest = np.array([bvh_visits.fewest_nodes(tree, o[i], d[i], t[i]) for i in range(len(o))])
    nodes = np.array([r["nodes"] for r in runs])
    assert (nodes >= fewest).all() and (fewest >= 1).all()
    # any hit: found exactly where a closest hit exists, never nearer than it
    for i in range(0, len(o), 7):
        a = bvh_visits.traverse(tree, o[i], d[i], any_hit=True)
        assert (a["row"] >= 0) == np.isfinite(t[i]) and a["t"] >= t[i] and a["nodes"] <= runs[i]["nodes"]


def test_measure_reports_every_ray_kind():
    r = bvh_visits.measure(str(REPO / "scenes" / "cornell.toml"), 60)
    assert set(r["kinds"]) == {"camera", "bounce", "shadow"} and r["wide_nodes"] > 0
    for k in r["kinds"].values():
        assert k["rays"] > 0 and k["nodes_mean"] >= 1 and k["nodes_max"] >= k["nodes_p90"] > 0
        assert k["nodes_mean"] <= k["warp_nodes"] <= k["nodes_max"]


def test_lockstep_counts_steps_busy_lanes_and_shared_fetches():
    same = [[("node", 0), ("node", 3), ("leaf", 8)]] * 32
    assert bvh_visits.lockstep(same) == {"steps": 3, "busy_per_step": 32.0, "fetches_per_step": 1.0}
    apart = [[("node", 100 * i + k) for k in range(i + 1)] for i in range(4)]   # 1, 2, 3, 4 visits
    assert bvh_visits.lockstep(apart) == {"steps": 4, "busy_per_step": 10 / 4, "fetches_per_step": 10 / 4}


def test_tile_warps_take_the_steps_of_their_longest_ray():
    skip_without_shared(REPO / "scenes" / "covered_dragon.toml")
    scene = load_scene(REPO / "scenes" / "covered_dragon.toml")
    packed = pack_scene(scene, bvh_width=4)
    tree = bvh_visits.WideTree(packed)
    w = bvh_visits.tile_bounce_warps(scene, packed, tree, 16, np.random.default_rng(2), size=(160, 90))
    assert w["tiles"] >= 3
    assert 1 <= w["fetches_per_step"] <= w["busy_per_step"] <= 32 and w["steps"] >= w["busy_per_step"] / 32


def test_pixel_visits_and_heat_map(tmp_path):
    """Every pixel's camera ray counts what traverse() counts for it; the material shares of the
    bounce rays' leaf visits add up to one; --heatmap writes both halves."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    packed = pack_scene(scene, bvh_width=4)
    tree = bvh_visits.WideTree(packed)
    v = bvh_visits.pixel_visits(scene, packed, tree, (16, 9), np.random.default_rng(2))
    assert v["camera"].shape == v["bounce"].shape == (9, 16)
    camera = packed.to_gpu_camera(scene.camera)
    right, up, forward = camera.basis()
    h = np.tan(np.radians(camera.fov_deg) / 2)
    j, i = 4, 11
    d = forward + ((i + 0.5) / 16 * 2 - 1) * h * 16 / 9 * right + (1 - (j + 0.5) / 9 * 2) * h * up
    assert v["camera"][j, i] == bvh_visits.traverse(tree, camera.position, d / np.linalg.norm(d))["nodes"] >= 1
    assert (v["bounce"][v["camera"] > 0] >= 0).all() and v["bounce"].max() >= 1
    every = [a for a, _ in v["materials"].values()]
    slow = [b for _, b in v["materials"].values()]
    assert abs(sum(every) - 1) < 1e-9 and abs(sum(slow) - 1) < 1e-9
    assert set(v["materials"]) <= {m.name for m in scene.materials}
    image = bvh_visits.heat_image(v)
    assert image.shape == (9, 32, 3) and image.dtype == np.uint8 and image[..., 0].max() == 255
    out = tmp_path / "heat.png"
    assert bvh_visits.main([str(REPO / "scenes" / "cornell.toml"), "--heatmap", str(out), "--heat-size", "8x6"]) == 0
    from lift_gl.image_io import read_image
    assert read_image(out).shape[:2] == (6, 16)


@pytest.mark.parametrize("name", ["cornell.toml", "covered_dragon.toml"])
def test_collapsed_trees_of_any_width(name):
    """CollapsedTree (the largest child opened first, to any width) at widths 2, 4 and 8: rays
    find the renderer's 4-wide tree's hits, visiting fewer nodes the wider the tree."""
    skip_without_shared(REPO / "scenes" / name)
    scene = load_scene(REPO / "scenes" / name)
    binary, wide = pack_scene(scene, bvh_width=2), pack_scene(scene, bvh_width=4)
    renderer_tree = bvh_visits.WideTree(wide)
    trees = {w: bvh_visits.CollapsedTree(binary, w) for w in (2, 4, 8)}
    rays = bvh_visits.scene_rays(scene, wide, renderer_tree, 60, np.random.default_rng(5))
    o, d, _ = rays["bounce"]
    visits = {w: [] for w in trees}
    for i in range(len(o)):
        ref = bvh_visits.traverse(renderer_tree, o[i], d[i])
        for w, tree in trees.items():
            r = bvh_visits.traverse(tree, o[i], d[i])
            assert r["t"] == ref["t"]
            visits[w].append(r["nodes"])
    assert np.mean(visits[2]) > np.mean(visits[4]) > np.mean(visits[8])
    with pytest.raises(ValueError, match="bvh_width=2"):
        bvh_visits.CollapsedTree(wide, 8)


def test_a_tree_in_a_distant_lights_frame_answers_its_shadow_rays_alike():
    """--light-frame: the rotation takes the light's direction to +z, and the second tree, built
    over the turned scene, blocks exactly the shadow rays the renderer's tree blocks."""
    from lift_gl.scene.model import DistantLight

    direction = np.array([0.5, 0.5, 0.7])   # in through the box's open side: some rays blocked, some not
    rotation = bvh_visits.light_frame(direction)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(rotation @ (direction / np.linalg.norm(direction)), [0, 0, 1], atol=1e-12)
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    scene.distant_lights.append(DistantLight(direction=direction / np.linalg.norm(direction),
                                             irradiance=np.ones(3)))
    r = bvh_visits.light_frame_visits(scene, 300)
    assert r["rays"] > 100 and 0.2 < r["world"]["blocked"] < 1.0
    assert r["answers_differ"] == 0 and r["world"]["blocked"] == r["light_frame"]["blocked"]
    assert r["light_frame"]["nodes_mean"] >= 1 and r["world"]["nodes_mean"] >= 1
