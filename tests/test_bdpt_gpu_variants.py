"""benchmarks/gpu_pt_variants.py's bdpt diagnostics (docs/bdpt.md "On the GPU"): every edit still
finds its place in today's bdpt, the counting variant counts what the host's own ray counter
counts, and the warp estimate matches a lane-by-lane walk of bdpt's loops."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
_SPEC = importlib.util.spec_from_file_location("gpu_pt_variants", REPO / "benchmarks" / "gpu_pt_variants.py")
variants = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(variants)

CORNELL = REPO / "scenes" / "cornell.toml"
BDPT_EDITS = ["bdpt_no_lt", "bdpt_no_connect", "bdpt_light_only", "bdpt_camera_only", "bdpt_splat_plain",
              "count_rays", "bdpt_count_paths"]


@pytest.fixture(scope="module")
def renderer():
    r = Renderer(load_scene(CORNELL), size=(24, 16), integrator="bdpt", seed=3, params={"max_depth": 6})
    yield r
    r.release()


@pytest.mark.parametrize("name", BDPT_EDITS)
def test_each_bdpt_edit_finds_its_place(renderer, name):
    source = renderer.trace.source.text
    edit = variants.VARIANTS[name][0]
    assert edit(source) != source  # _sub raises where an anchor is gone


def test_counted_rays_are_the_rays_the_host_counts():
    """count_rays' per-pixel closest-hit and shadow rays, summed, against the host's own counter
    (LIFT_COUNT_RAYS, lift/bvh.glsl) of the same dispatches. The prepass (the light subpaths)
    is rebuilt without the counter, and its splats (light tracing) are kept out of the image:
    the variant counts the trace pass's rays."""
    r = Renderer(load_scene(CORNELL), size=(24, 16), integrator="bdpt", seed=3, params={"max_depth": 6},
                 count_rays=True)
    assert "#define LIFT_COUNT_RAYS\n" in r.prepass.source.text
    r.prepass.program.release()
    r.prepass.program = r.ctx.compute_shader(r.prepass.source.text.replace("#define LIFT_COUNT_RAYS\n", ""))
    r.trace.program.release()
    r.trace.program = r.ctx.compute_shader(variants.count_rays(r.trace.source.text))
    r.trace.splats.add_to = lambda frame: None
    counts = r.render(spp=2)  # per pixel, the mean over the samples of the counts
    w, h = r.size
    closest, shadow = counts[..., 0].sum() * 2, counts[..., 1].sum() * 2
    assert closest > w * h * 2 and shadow > 0.0  # bounces and shadow rays happen
    assert closest + shadow == pytest.approx(r.stats.rays, rel=1e-6)
    r.release()


def _warp_walk(L, C, depth):
    """bdpt's loops run by one warp, iteration by iteration: camera vertex t = 2.. (lanes whose
    camera subpath has at least t - 1 vertices take part) joins s = 0..last_s of each lane."""
    lane = np.zeros(len(L))
    warp = 0
    t = 2
    while True:
        alive = [k for k in range(len(L)) if C[k] >= t - 1]
        if not alive:
            return lane, warp
        s = 0
        while True:
            busy = [k for k in alive if s <= min(max(L[k], 1), depth + 2 - t)]
            if not busy:
                break
            for k in busy:
                lane[k] += 1
            warp += 1
            s += 1
        t += 1


def test_warp_costs_match_a_lane_by_lane_walk():
    rng = np.random.default_rng(5)
    depth = 6
    light = rng.geometric(0.35, size=(8, 16)).astype(np.float32)  # 8 rows x 16 columns: 4 warps of 8x4
    camera = rng.geometric(0.45, size=(8, 16)).astype(np.float32)
    got = variants.warp_costs(light, camera, depth)
    lanes, warps = [], []
    for wy in range(2):
        for wx in range(2):
            L = light[4 * wy:4 * wy + 4, 8 * wx:8 * wx + 8].ravel()
            C = camera[4 * wy:4 * wy + 4, 8 * wx:8 * wx + 8].ravel()
            lane, warp = _warp_walk(L, C, depth)
            lanes.append(lane)
            warps.append(warp)
    assert got["join_iterations_lane"] == pytest.approx(np.concatenate(lanes).mean())
    assert got["join_iterations_warp"] == pytest.approx(np.mean(warps))
    assert got["join_iterations_warp"] > got["join_iterations_lane"]


def test_coherent_bdpt_variants_compile_and_the_kept_one_is_the_parameter():
    """bdpt_own_light (what `coherent_sampling` does), bdpt_shared (its first version: light
    subpaths shared by the tile too) and bdpt_own_camera compile on today's bdpt (a variant that
    declared the host's lift_own_rng a second time failed only on the GPU machine); the first
    gives the image of bdpt's coherent_tiles, and the other two other images. bdpt_shared edits
    only the light subpath: its image differs only if the harness edits the prepass too."""
    from lift_gl.gl.context import create_context

    names = ["base", "coherent_tiles", "bdpt_own_light", "bdpt_shared", "bdpt_own_camera"]
    res = variants.run_scene(create_context(), str(CORNELL), (24, 16), 6, names, 1, None, integrator="bdpt")
    v = res["variants"]
    assert list(v) == names and all(x["finite"] for x in v.values())
    assert v["bdpt_own_light"]["max_abs_diff_vs_first"] == v["coherent_tiles"]["max_abs_diff_vs_first"] > 0
    assert v["bdpt_own_light"]["mean_rgb"] == v["coherent_tiles"]["mean_rgb"]
    for name in ("bdpt_shared", "bdpt_own_camera"):
        assert v[name]["mean_rgb"] != v["coherent_tiles"]["mean_rgb"], name


def test_prepass_storage_is_numbered_for_a_coherent_variants_wider_dispatch():
    """A variant that turns coherent sampling on by its edit dispatches whole blocks over the
    moved image: more invocations than the renderer's own prepass layout counts. Left so, its
    invocations past the count wrote into other pixels' entries (a race: the coherent variants'
    images changed from run to run); the harness numbers the storage for the widest dispatch."""
    from lift_gl.passes.common import COHERENT_DEFINE

    r = Renderer(load_scene(CORNELL), size=(24, 16), integrator="bdpt", seed=3, params={"max_depth": 2})
    own = r.prepass.layout.invocations
    assert own == variants.dispatch_invocations({}, r.size, r.trace.local_size) == 24 * 16
    lx, ly = r.trace.local_size
    wide = variants.dispatch_invocations({COHERENT_DEFINE: 1}, r.size, (lx, ly))
    # whole tiles over the image moved by up to one tile less a pixel
    assert wide == -(-(24 + lx - 1) // lx) * lx * -(-(16 + ly - 1) // ly) * ly > own
    variants.widen_prepass(r, own)   # no wider: nothing changes
    assert r.prepass.layout.invocations == own
    variants.widen_prepass(r, wide)
    assert r.prepass.uniforms(1) == {"u_prepass_invocations": wide, "u_prepass_stride": wide}
    r.render(spp=1)   # the next run allocates for the new numbering
    assert all(b.size == r.prepass.layout.buffer_bytes(1) for b in r.prepass.buffers)
    r.release()
