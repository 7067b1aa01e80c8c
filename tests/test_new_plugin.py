"""`lift-gl new-plugin`: the scaffolded plugin is found, renders, and its generated test passes
(and fails when the plugin is wrong); a copy of pt renders exactly what pt renders."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO
from lift_gl import load_scene
from lift_gl.cli import main
from lift_gl.plugins import discover, load_manifest
from lift_gl.renderer import Renderer
from lift_gl.testing import cornell_scene, require_opencl

CORNELL = str(REPO / "scenes" / "cornell.toml")


def cli(capsys, *args):
    try:
        code = main(list(args))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def run_generated_tests(folder, *args):
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(folder), *args],
                          capture_output=True, text=True, timeout=300, cwd=folder.parent)


def test_scaffold_from_template_renders_and_its_test_passes(capsys, tmp_path):
    code, out, _ = cli(capsys, "new-plugin", "mine", "--dir", str(tmp_path))
    assert code == 0
    folder = tmp_path / "mine"
    assert sorted(p.name for p in folder.iterdir()) == ["mine.glsl", "plugin.toml", "test_mine.py"]
    plugin = load_manifest(folder)
    assert (plugin.name, plugin.entry, plugin.language) == ("mine", "mine.glsl", "glsl")
    assert plugin.params.keys() == load_manifest(REPO / "plugins" / "template").params.keys()
    assert "YOUR TURN" in (folder / "mine.glsl").read_text()
    assert f"--plugins {tmp_path}" in out  # the folder is not on the search path: say how to add it
    # the suggested render names a small size: the scene's own film size takes minutes on a CPU
    hint = next(line for line in out.splitlines() if "lift-gl render" in line)
    width, height = (int(v) for v in hint.split("--size ")[1].split()[0].split("x"))
    film = load_scene(CORNELL).film_size
    assert width * height <= 128 * 128 < film[0] * film[1], hint

    # Found by name through --plugins and LIFT_GL_PLUGIN_PATH; listed with its parameters.
    code, out, _ = cli(capsys, "plugins", "--plugins", str(tmp_path))
    assert "mine  [glsl, primary=gbuffer]" in out and "--set mine.max_depth=" in out
    npy = tmp_path / "mine.npy"
    code, out, _ = cli(capsys, "render", CORNELL, "--plugins", str(tmp_path), "--integrator", "mine",
                       "--spp", "2", "--size", "16x16", "--out", str(npy))
    assert code == 0 and "dropped NaN/Inf samples: 0" in out
    assert np.load(npy).mean() > 0

    result = run_generated_tests(folder)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "3 passed, 1 skipped" in result.stdout  # the golden test waits for --update-golden


def test_the_generated_test_catches_a_wrong_integrator(capsys, tmp_path):
    cli(capsys, "new-plugin", "wrong", "--dir", str(tmp_path))
    shader = tmp_path / "wrong" / "wrong.glsl"
    text = shader.read_text()
    # A classic mistake: light from the sky is forgotten.
    sky = "if (counted) L += throughput * env_radiance(ray.dir);"
    assert sky in text
    shader.write_text(text.replace(sky, ""))
    result = run_generated_tests(tmp_path / "wrong", "-k", "furnace")
    assert result.returncode == 1 and "1 failed" in result.stdout, result.stdout + result.stderr


def test_the_generated_golden_test_keeps_the_image_once_it_is_right(capsys, tmp_path):
    """--update-golden writes golden/cornell.exr; then the test passes; a change to the
    shader fails it through lift_gl.testing.assert_image_close, which saves the images."""
    cli(capsys, "new-plugin", "kept", "--dir", str(tmp_path))
    folder = tmp_path / "kept"
    result = run_generated_tests(folder, "-k", "unchanged", "--update-golden")
    assert result.returncode == 0 and (folder / "golden" / "cornell.exr").is_file(), result.stdout + result.stderr
    result = run_generated_tests(folder, "-k", "unchanged")
    assert result.returncode == 0 and "1 passed" in result.stdout, result.stdout + result.stderr
    shader = folder / "kept.glsl"
    shader.write_text(shader.read_text().replace("throughput *= bs.weight;", "throughput *= 0.9 * bs.weight;"))
    result = run_generated_tests(folder, "-k", "unchanged")
    assert result.returncode == 1 and "image differs from the golden image" in result.stdout, result.stdout
    saved = sorted(p.name for p in (folder / "golden").iterdir())
    assert saved == ["cornell.actual.exr", "cornell.actual.png", "cornell.diff.png", "cornell.exr"]


def test_a_copy_of_pt_renders_exactly_what_pt_renders(capsys, tmp_path, monkeypatch):
    code, _, _ = cli(capsys, "new-plugin", "my_pt", "--from", "pt", "--dir", str(tmp_path))
    assert code == 0
    assert (tmp_path / "my_pt" / "my_pt.glsl").read_text().startswith("// my_pt:")
    monkeypatch.setenv("LIFT_GL_PLUGIN_PATH", str(tmp_path))
    assert discover()["my_pt"].folder == (tmp_path / "my_pt").resolve()
    images = []
    for name in ("pt", "my_pt"):
        r = Renderer(cornell_scene(), size=(24, 24), integrator=name, seed=3)
        images.append(r.render(spp=4))
        r.release()
    np.testing.assert_array_equal(images[0], images[1])


def test_an_opencl_plugin_can_be_the_start(capsys, tmp_path):
    require_opencl()
    code, _, _ = cli(capsys, "new-plugin", "my_ao", "--from", "ao_cl", "--dir", str(tmp_path))
    assert code == 0
    plugin = load_manifest(tmp_path / "my_ao")
    assert (plugin.language, plugin.entry) == ("opencl", "my_ao.cl")
    r = Renderer(cornell_scene(), size=(8, 8), integrator=str(plugin.folder))
    assert 0 < r.render(spp=2).mean() <= 1
    r.release()


@pytest.mark.parametrize("args, words", [
    (["9lives"], "identifier"),
    (["pt"], "exists already"),
    (["fresh", "--from", "nonexistent"], "no plugin named 'nonexistent'"),
])
def test_bad_requests_are_one_clear_error(capsys, tmp_path, args, words):
    code, _, err = cli(capsys, "new-plugin", *args, "--dir", str(tmp_path))
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and words in lines[0], err
    assert not any(tmp_path.iterdir())


def test_an_existing_folder_is_never_overwritten(capsys, tmp_path):
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "notes.txt").write_text("mine")
    code, _, err = cli(capsys, "new-plugin", "taken", "--dir", str(tmp_path))
    assert code == 2 and "exists already" in err
    assert [p.name for p in (tmp_path / "taken").iterdir()] == ["notes.txt"]
