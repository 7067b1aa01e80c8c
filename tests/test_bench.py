"""`lift-gl bench`: the ray counter against an analytic count, and the command's outputs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import REPO
from lift_gl.cli import main
from lift_gl.report.bench import bench_case
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Environment, Material, Scene, Sphere

# |z| below 4: two-sided p ~ 6e-5 for a binomial count this large (normal approximation).
Z_CRIT = 4.0


def sphere_filling_the_view():
    """Camera 1.5 from the centre of a unit diffuse sphere: every pixel sees the sphere
    (angular radius asin(1/1.5) = 42 degrees > the 21-degree half-diagonal of the view)."""
    camera = Camera(position=[0.0, 0.0, 1.5], target=[0.0, 0.0, 0.0], fov_deg=30.0)
    return Scene(camera=camera, materials=[Material("grey", "diffuse", base_color=[0.5] * 3)],
                 spheres=[Sphere(center=[0, 0, 0], radius=1.0, material=0)],
                 environment=Environment(radiance=[1.0] * 3), film_size=(24, 24))


def test_ray_count_matches_pt_on_a_convex_sphere():
    """pt on a convex diffuse sphere in a constant environment, first hit from the raster:
    every path traces one BSDF ray (it escapes: convex), plus one shadow ray when the
    uniformly sampled environment direction lies above the surface (probability 1/2; below
    it the BSDF is 0 and no ray is traced). So rays = paths + Binomial(paths, 1/2)."""
    r = Renderer(sphere_filling_the_view(), size=(24, 24), count_rays=True, seed=3)
    r.render(spp=20)
    paths = 24 * 24 * 20
    assert r.stats.dropped_samples == 0
    z = (r.stats.rays - 1.5 * paths) / (0.5 * np.sqrt(paths))
    assert abs(z) < Z_CRIT, (r.stats.rays / paths, z)
    r.release()
    # Without the counter the statistics words stay 0.
    plain = Renderer(sphere_filling_the_view(), size=(24, 24), seed=3)
    plain.render(spp=2)
    assert plain.stats.rays == 0
    plain.release()


def test_bench_case_reports_passes_and_rates():
    result = bench_case(sphere_filling_the_view(), (16, 16), frames=3, repeat=2)
    assert set(result["pass_ms_sync"]) == {"gbuffer", "trace", "accumulate"}
    assert set(result["pass_ms_query"]) == set(result["pass_ms_sync"])
    assert all(v >= 0 for v in result["pass_ms_sync"].values())
    assert result["frame_ms"] == min(result["frame_ms_all"]) > 0
    assert result["paths_per_second"] == pytest.approx(16 * 16 / (result["frame_ms"] / 1e3))
    z = (result["rays_per_path"] - 1.5) / (0.5 / np.sqrt(result["counted_paths"]))
    assert abs(z) < Z_CRIT
    assert result["dropped_samples"] == 0


def test_bench_command_writes_json_and_table(capsys, tmp_path):
    out = tmp_path / "bench.json"
    scene = REPO / "scenes" / "cornell.toml"
    assert main(["bench", str(scene), "--sizes", "16x16,24x16", "--frames", "2", "--repeat", "1", "--json", str(out),
                 "--option", "bvh_width=4"]) == 0
    stdout = capsys.readouterr().out
    assert "| scene | size | triangles | BVH build s | gbuffer ms | trace ms | accumulate ms |" in stdout
    assert "| cornell | 24x16 |" in stdout and "machine:" in stdout
    assert "denoise atrous ms |" in stdout  # the default denoiser is timed
    data = json.loads(out.read_text())
    assert data["results"][0]["denoise_ms"]["atrous"] > 0
    assert [r["size"] for r in data["results"]] == [[16, 16], [24, 16]]
    assert data["results"][0]["triangles"] > 0 and data["results"][0]["bvh_build_seconds"] > 0
    assert "cores" in data["machine"] and "gl" in data["machine"]
    # the options it ran with: the one asked for, and every other one's choice for this device
    assert data["options"] == {"bvh_width": "4"}
    assert data["results"][0]["options"]["bvh_width"] == {"value": "4", "asked": "4"}
    assert data["results"][0]["bvh"]["width"] == 4 and not data["results"][0]["bvh"]["quantized"]
    assert data["results"][0]["options"]["bvh_slot_order"]["asked"] == "auto"


def test_timed_runs_go_on_until_one_reads_at_full_clock(monkeypatch):
    """A GPU whose clock stays down through the warm-up (short runs of a small scene): more
    runs are timed until one reads within 5% of the maximum, and only such runs give the frame
    time; without readings (no NVML: llvmpipe) the runs asked for are all."""
    from lift_gl.report import bench

    class FakeClock:
        readings = iter([1200, 1300, 1980])

        def __init__(self, name=None):
            pass

        def max_sm_mhz(self):
            return 1980

        def sm_mhz(self):
            return next(self.readings, 1980)

        def reasons(self):
            return None

    monkeypatch.setattr(bench, "ClockReader", FakeClock)
    monkeypatch.setattr(bench, "warm_up", lambda step, clock: {})
    result = bench_case(sphere_filling_the_view(), (16, 16), frames=2, repeat=1)
    assert result["sm_clock"]["frames_mhz"] == [1200, 1300, 1980]
    assert len(result["frame_ms_all"]) == 3 and result["frame_ms"] == result["frame_ms_all"][2]
    # the rule alone: at most EXTRA_RUNS more; none without readings
    assert bench.more_runs([1200] * 2, 1980, 2) and not bench.more_runs([1200] * (2 + bench.EXTRA_RUNS), 1980, 2)
    assert not bench.more_runs([None, None], None, 2) and not bench.more_runs([1900], 1980, 1)
    assert bench.at_full_clock([1.0, 2.0], [1200, 1980], 1980) == [2.0]
    assert bench.at_full_clock([1.0, 2.0], [1200, 1300], 1980) == [1.0, 2.0]


def test_warm_up_steps_grow_until_they_keep_the_gpu_busy():
    """Each warm-up step renders twice the frames of the last while a step takes less than
    WARM_STEP_S (a fake clock: 1 ms a frame), up to its cap."""
    from lift_gl.report.bench import growing_step

    t, rendered = [0.0], []

    def render(n):
        rendered.append(n)
        t[0] += n * 1e-3

    step = growing_step(render, first=16, most=256, seconds=0.1, now=lambda: t[0])
    for _ in range(6):
        step()
    assert rendered == [16, 32, 64, 128, 128, 128]   # 128 frames take 0.128 s: no longer short
    capped = growing_step(render, first=16, most=32, seconds=10.0, now=lambda: t[0])
    rendered.clear()
    for _ in range(3):
        capped()
    assert rendered == [16, 32, 32]
