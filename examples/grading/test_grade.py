"""Grade a class's integrator plugins headless (docs/grading.md): every submission renders
every scene at SPP samples per pixel and is compared with a golden image that the reference
solution rendered at GOLDEN_SPP, with thresholds measured from the reference solution's own
noise at SPP.

    pytest examples/grading -k reference --update-golden    # (re)make the goldens once
    LIFT_GL_SUBMISSIONS=path/to/class pytest examples/grading -n 2 --junitxml=grades.xml

A submission is a plugin folder (plugin.toml + GLSL) in the class folder; its test id is the
folder's name. Images of failed tests are saved beside the golden as
golden/SCENE.STUDENT.actual.png and SCENE.STUDENT.diff.png (lift_gl.testing).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene
from lift_gl.image_io import read_image
from lift_gl.renderer import Renderer
from lift_gl.testing import assert_image_close, image_metrics

REPO = Path(__file__).resolve().parent.parent.parent
CLASS = Path(os.environ.get("LIFT_GL_SUBMISSIONS", Path(__file__).parent / "class"))
REFERENCE = os.environ.get("LIFT_GL_REFERENCE", "pt")  # the instructor's solution
SCENES = {"cornell": REPO / "scenes" / "cornell.toml", "furnace": REPO / "scenes" / "furnace.toml"}
SIZE, SPP, GOLDEN_SPP = (64, 64), 64, 4096
CALIBRATION_SEEDS = range(100, 104)  # the reference solution's noise at SPP
MARGIN = 1.5  # a submission may be this much worse than the worst calibration render
SUBMISSIONS = sorted(p.parent for p in CLASS.glob("*/plugin.toml"))


def render(scene: str, integrator, spp: int, seed: int):
    r = Renderer(load_scene(SCENES[scene]), size=SIZE, integrator=str(integrator), seed=seed)
    image = r.render(spp=spp)
    dropped = r.stats.dropped_samples
    r.release()
    return image, dropped


@pytest.mark.parametrize("scene", SCENES)
def test_reference_solution(golden, scene, request, thresholds):
    """With --update-golden: render the golden. Without: the reference solution, graded like
    a submission at SPP, must pass its own thresholds (a check of the calibration)."""
    if request.config.getoption("--update-golden"):
        image, dropped = render(scene, REFERENCE, GOLDEN_SPP, seed=1)
        assert dropped == 0
        assert_image_close(image, golden(f"{scene}.exr"))
        return
    image, dropped = render(scene, REFERENCE, SPP, seed=7)
    assert dropped == 0
    assert_image_close(image, golden(f"{scene}.exr"), update=False, label="reference",
                       **thresholds(scene, golden(f"{scene}.exr")))


@pytest.fixture(scope="session")
def thresholds():
    """Per scene: relMSE, SSIM and FLIP limits from CALIBRATION_SEEDS renders of the
    reference solution at SPP (a correct submission is another such render)."""
    cache = {}

    def limits(scene: str, golden_path: Path) -> dict:
        if scene not in cache:
            golden = read_image(golden_path)
            values = [image_metrics(render(scene, REFERENCE, SPP, seed)[0], golden, flip=True)
                      for seed in CALIBRATION_SEEDS]
            cache[scene] = {"relmse": MARGIN * max(v["relmse"] for v in values),
                            "ssim": 1 - MARGIN * (1 - min(v["ssim"] for v in values)),
                            "flip": MARGIN * max(v["flip"] for v in values)}
        return cache[scene]
    return limits


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("submission", SUBMISSIONS, ids=[p.name for p in SUBMISSIONS])
def test_submission(submission, scene, golden, thresholds, record_property):
    golden_path = golden(f"{scene}.exr")
    if not golden_path.is_file():
        pytest.fail(f"no golden {golden_path}: run pytest examples/grading -k reference --update-golden first")
    image, dropped = render(scene, submission, SPP, seed=7)
    record_property("dropped_samples", dropped)
    assert dropped == 0, f"{dropped} samples were NaN or infinite (the host dropped them)"
    limits = thresholds(scene, golden_path)
    for name, value in image_metrics(image, read_image(golden_path), flip=True).items():
        record_property(name, value)  # in the JUnit report, passed or failed
    assert_image_close(image, golden_path, update=False, label=submission.name, **limits)
