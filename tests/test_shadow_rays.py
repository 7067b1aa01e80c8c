"""Shadow rays between points close together at grazing angles: the cover's top, 0.1 below
the Covered Dragon's light, lit from the side. Next event estimation (pt; bdpt's s = 1 and
its joins) must agree with pure BSDF sampling (bdpt with only_s = 0), which casts no shadow
ray at all. A shadow ray that starts from the offset origin but keeps the direction from the
surface point crosses the light's plane before its end, and reports the light occluded:
pt then lost a quarter of the light in this view."""
from __future__ import annotations

from conftest import REPO
from image_stats import assert_same_image
from lift_gl.scene.loader import load_scene
from test_bdpt import RUNS, renders

GAP = REPO / "tests" / "data" / "covered_box_gap.toml"  # max_depth 1: direct light only


def test_next_event_estimation_near_a_light_matches_bsdf_sampling():
    scene = load_scene(GAP)
    bsdf_only = renders(scene, "bdpt", 16, range(1, RUNS + 1), only_s=0)
    assert_same_image(renders(scene, "pt", 4, range(101, RUNS + 101)), bsdf_only, label="pt vs BSDF sampling")
    assert_same_image(renders(scene, "bdpt", 4, range(201, RUNS + 201)), bsdf_only, label="bdpt vs BSDF sampling")
