"""Grade a class's integrator plugins as a pytest suite (docs/grading.md): one test per
submission and scene, passing when `lift-gl grade`'s verdict is pass, so that a CI system or a
spreadsheet reads the JUnit report.

    LIFT_GL_SUBMISSIONS=path/to/class pytest examples/grading -o junit_family=xunit1 --junitxml=grades.xml

The verdicts are statistical (lift_gl.grade): each submission renders each scene with
independent seeds and its expectation is tested against the reference's, so a correct but noisy
plugin passes and a biased one fails with the size and place of its bias. The grades, the
report and the pictures go to examples/grading/out/ (or $LIFT_GL_GRADES).
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from lift_gl.grade import GradeSettings, find_submissions, grade

HERE = Path(__file__).resolve().parent
CLASS = Path(os.environ.get("LIFT_GL_SUBMISSIONS", HERE / "class"))
OUT = Path(os.environ.get("LIFT_GL_GRADES", HERE / "out"))
SETTINGS = GradeSettings(reference=os.environ.get("LIFT_GL_REFERENCE", "pt"))  # the defaults of lift-gl grade
SUBMISSIONS = [str(p.relative_to(CLASS)) for p in find_submissions(CLASS)] if CLASS.is_dir() else []


@pytest.fixture(scope="session")
def grades():
    """The whole class graded once (grades.csv and report.md written as it goes)."""
    return {(g.submission, g.scene): g for g in grade(CLASS, SETTINGS, OUT)}


@pytest.mark.parametrize("scene", SETTINGS.scenes)
@pytest.mark.parametrize("submission", SUBMISSIONS)
def test_submission(grades, submission, scene, record_property):
    g = grades[(submission, scene)]
    for name in ("verdict", "z", "variance_ratio", "seconds"):
        record_property(name, getattr(g, name))  # in the JUnit report, passed or failed
    assert g.verdict == "pass", f"{g.verdict}: {g.message}" + (f" (picture: {OUT / g.picture})" if g.picture else "")
