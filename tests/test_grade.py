"""lift-gl grade end to end on a small class: verdicts, files, isolation of bad submissions.

Small settings (32x32, 8 seeds of 4 spp, the reference 32 seeds) keep it to about a minute
here; the statistics are those of the full grader (tests/test_consistency.py tests them on
synthetic estimators with a known truth).
"""
from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from lift_gl.grade import GradeSettings, grade
from lift_gl.grade.scenes import analytic_image
from lift_gl.scene.loader import load_scene

REPO = Path(__file__).resolve().parent.parent
CLASS = REPO / "examples" / "grading" / "class"


def small(tmp, **changes) -> GradeSettings:
    settings = dict(scenes=("furnace", "cornell"), size=(32, 32), spp=4, seeds=8, reference_seeds=32, timeout=60.0,
                    cache_dir=tmp / "cache")
    settings.update(changes)
    return GradeSettings(**settings)


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("grade")
    submissions = tmp / "class"
    submissions.mkdir()
    for name in ("alice", "bob", "leo"):
        shutil.copytree(CLASS / name, submissions / name)
    (submissions / "notes.txt").write_text("not a plugin")       # left alone
    (submissions / "empty").mkdir()                              # no plugin.toml: not a submission
    broken = submissions / "nina"
    broken.mkdir()
    (broken / "plugin.toml").write_text('name = "nina"\nentry = "missing.glsl"\n')
    out = tmp / "out"
    grades = grade(submissions, small(tmp), out, log=lambda *a: None)
    return grades, out


def by(grades, submission, scene):
    return next(g for g in grades if g.submission == submission and g.scene == scene)


def test_verdicts(graded):
    grades, _ = graded
    assert {g.submission for g in grades} == {"alice", "bob", "leo", "nina"}
    for scene in ("furnace", "cornell"):
        assert by(grades, "alice", scene).verdict == "pass"
    # bob counts direct light twice: too bright in the box, right in the furnace (no emitter there)
    assert by(grades, "bob", "furnace").verdict == "pass"
    cornell = by(grades, "bob", "cornell")
    assert cornell.verdict == "biased" and cornell.z > 0 and cornell.bias > 0.2
    leo = by(grades, "leo", "cornell")
    assert leo.verdict == "error" and "leo/pt.glsl:48" in leo.message
    assert by(grades, "nina", "furnace").verdict == "error" and "missing.glsl" in by(grades, "nina", "furnace").message


def test_files(graded):
    grades, out = graded
    with open(out / "grades.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(grades) == 8
    for column in ("submission", "scene", "verdict", "z", "variance_ratio", "seconds", "message"):
        assert column in rows[0]
    alice = next(r for r in rows if r["submission"] == "alice" and r["scene"] == "cornell")
    assert math.isfinite(float(alice["z"])) and float(alice["variance_ratio"]) > 0
    report = (out / "report.md").read_text()
    assert "| bob |" in report and "**biased**" in report and "**error**" in report
    picture = by(grades, "bob", "cornell").picture
    assert picture and (out / picture).is_file() and f"]({picture})" in report


def test_a_lost_render_is_a_timeout_and_the_rest_goes_on(tmp_path):
    submissions = tmp_path / "class"
    slow = submissions / "slow"
    slow.mkdir(parents=True)
    (slow / "plugin.toml").write_text('name = "slow"\nentry = "slow.glsl"\n')
    # A long loop of transcendentals a sample (one loop: llvmpipe's limit of 65535 iterations
    # a loop holds): minutes a frame on a CPU.
    body = "".join(f"        x = sin(x * 1.{k}3 + 0.{k});\n" for k in range(10))
    (slow / "slow.glsl").write_text(
        "vec3 radiance(Ray ray, Hit hit, inout Rng rng) {\n    float x = rng_next(rng);\n"
        "    for (int i = 0; i < 65000; ++i) {\n" + body + "    }\n    return vec3(x * 1e-20);\n}\n")
    shutil.copytree(CLASS / "alice", submissions / "alice")
    grades = grade(submissions, small(tmp_path, scenes=("furnace",), timeout=15.0), tmp_path / "out",
                   log=lambda *a: None)
    assert by(grades, "slow", "furnace").verdict == "timeout"
    assert by(grades, "alice", "furnace").verdict == "pass"


def test_cli_exits_0_whatever_the_verdicts(tmp_path, capsys):
    from lift_gl.cli import main

    submissions = tmp_path / "class"
    shutil.copytree(CLASS / "leo", submissions / "leo")
    code = main(["grade", str(submissions), "--scenes", "furnace", "--size", "16x16", "--spp", "2", "--seeds", "4",
                 "--reference-seeds", "8", "--cache-dir", str(tmp_path / "cache"), "--out", str(tmp_path / "out")])
    assert code == 0
    assert "1 error" in capsys.readouterr().out
    assert main(["grade", str(tmp_path / "nothing"), "--out", str(tmp_path / "o2")]) == 2


def test_furnace_analytic_image_against_supersampled_coverage():
    """Pixels called inside (outside) the sphere must be wholly so: checked with 24x24 rays
    through each pixel, traced against the sphere in numpy."""
    scene = load_scene(REPO / "scenes" / "furnace.toml")
    size = (48, 40)
    image = analytic_image(scene, size)
    cam = scene.camera
    right, up, forward = cam.basis()
    t = math.tan(math.radians(cam.fov_deg) / 2)
    n = 24
    sub = (np.arange(n) + 0.5) / n
    h, w = size[1], size[0]
    px = (np.arange(w)[:, None] + sub[None, :]).ravel()
    py = (np.arange(h)[:, None] + sub[None, :]).ravel()
    nx, ny = np.meshgrid(px / w * 2 - 1, py / h * 2 - 1)
    d = forward + (nx * t * w / h)[..., None] * right + (ny * t)[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    sphere = scene.spheres[0]
    oc = np.asarray(cam.position) - sphere.center
    b = d @ oc
    hit = b * b - (oc @ oc - sphere.radius ** 2) > 0
    # rows of positions go up; the image's row 0 is the top
    hit = hit[::-1].reshape(h, n, w, n).transpose(0, 2, 1, 3).reshape(h, w, n * n)
    inside = image[..., 0] == 0.8
    outside = image[..., 0] == 1.0
    assert hit[inside].all() and not hit[outside].any()
    assert inside.sum() > 200 and outside.sum() > 800   # most pixels are known
    assert np.isnan(image[~inside & ~outside]).all()


def test_not_a_furnace_has_no_analytic_image():
    assert analytic_image(load_scene(REPO / "scenes" / "cornell.toml"), (16, 16)) is None


def test_lab_settings(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "lab.toml").write_text('name = "x"\n[grade]\nreference = "solution/mine"\nscenes = ["furnace", '
                                  '"scenes/a.toml"]\nspp = 8\nseeds = 12\nsize = [48, 32]\n')
    s = GradeSettings.from_lab(lab)
    assert (s.spp, s.seeds, s.size, s.scenes) == (8, 12, (48, 32), ("furnace", "scenes/a.toml"))
    assert s.base == lab.resolve()
    (lab / "lab.toml").write_text('[grade]\nsamples = 8\n')
    with pytest.raises(Exception, match="unknown keys samples"):
        GradeSettings.from_lab(lab)
