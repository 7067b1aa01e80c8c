"""benchmarks/gpu_ray_queue.py: the bounce rays cast with a queue inside the traversal loop give
the answers of gpu.py's ray-kind shader, ray for ray (on llvmpipe, at a size where no invocation
takes enough rays to reach its loop limit)."""
from __future__ import annotations

import sys

import pytest

from conftest import REPO, SHARED

sys.path.insert(0, str(REPO / "benchmarks"))
import gpu_ray_queue  # noqa: E402


def test_queued_bounce_rays_answer_as_the_plain_ones():
    scene = SHARED / "scenes_lift" / "cornell-box" / "scene.pbrt"
    if not scene.exists():
        pytest.skip(f"{scene} is absent (Lift's cornell-box: a scene of triangles only; CI has it)")
    r = gpu_ray_queue.measure(str(scene), (40, 24), reps=2)
    assert r is not None and r["rays"] > 300
    assert r["mismatched_answers"] == 0
    assert r["plain"]["median_ms"] > 0 and r["queue"]["median_ms"] > 0


def test_scenes_with_spheres_are_skipped():
    assert gpu_ray_queue.measure(str(REPO / "scenes" / "cornell.toml"), (16, 8), reps=1) is None
