"""`lift-gl render` on bad input: one clear error line that names the file (and line where
there is one), exit code 2, no traceback."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO
from lift_gl.cli import main

DATA = REPO / "tests" / "data"
FURNACE = str(REPO / "scenes" / "furnace.toml")


def run_cli(capsys, *args):
    """main() in-process; argparse errors exit through SystemExit. Returns (code, stderr)."""
    try:
        code = main(list(args))
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


def error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("name, line, words", [
    ("malformed.toml", 4, "TOML"),
    ("missing_mesh.toml", 11, "no_such_mesh.ply"),
    ("unknown_material.toml", 11, "'gray'"),
    ("bad_material_type.toml", 6, "plastik"),
    ("bad_value.toml", 6, "color"),
])
def test_bad_scene_names_file_and_line(capsys, tmp_path, name, line, words):
    path = DATA / name
    code, err = run_cli(capsys, "render", str(path), "--spp", "1", "--size", "8x8", "--out", str(tmp_path / "x.npy"))
    assert code == 2
    message = error_line(err)
    assert f"{path}:{line}:" in message, message
    assert words in message
    assert not (tmp_path / "x.npy").exists()


def test_missing_scene_file(capsys, tmp_path):
    code, err = run_cli(capsys, "render", str(tmp_path / "nowhere.toml"), "--out", str(tmp_path / "x.npy"))
    assert code == 2
    message = error_line(err)
    assert "nowhere.toml" in message and "not found" in message


SHADER = """// a student's plugin with a typo
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);
    return L * undefined_gain;
}
"""


def test_plugin_shader_compile_error_names_glsl_file_and_line(capsys, tmp_path):
    folder = tmp_path / "plugins" / "broken"
    folder.mkdir(parents=True)
    (folder / "plugin.toml").write_text('name = "broken"\nlanguage = "glsl"\nentry = "broken.glsl"\n'
                                        'primary = "gbuffer"\n')
    (folder / "broken.glsl").write_text(SHADER)
    code, err = run_cli(capsys, "render", FURNACE, "--plugins", str(tmp_path / "plugins"), "--integrator", "broken",
                        "--spp", "1", "--size", "8x8", "--out", str(tmp_path / "x.npy"))
    assert code == 2
    message = error_line(err)
    assert f"{(folder / 'broken.glsl').resolve()}:4:" in message, message
    assert "undefined_gain" in message


def test_unknown_set_parameter(capsys, tmp_path):
    code, err = run_cli(capsys, "render", FURNACE, "--set", "max_dept=3", "--size", "8x8",
                        "--out", str(tmp_path / "x.npy"))
    assert code == 2
    message = error_line(err)
    # Names the parameter, the plugin manifest it is missing from, and the ones there are.
    assert "'max_dept'" in message and "plugin.toml" in message and "max_depth" in message


def test_bad_parameter_value(capsys, tmp_path):
    code, err = run_cli(capsys, "render", FURNACE, "--set", "max_depth=deep", "--size", "8x8",
                        "--out", str(tmp_path / "x.npy"))
    assert code == 2
    assert "max_depth" in error_line(err) and "deep" in error_line(err)


@pytest.mark.parametrize("size", ["8by8", "0x8", "8x-2", "x", "8x8x8"])
def test_bad_size(capsys, tmp_path, size):
    code, err = run_cli(capsys, "render", FURNACE, "--size", size, "--out", str(tmp_path / "x.npy"))
    assert code == 2
    message = error_line(err)
    assert "--size" in message and repr(size) in message


def test_subprocess_error_has_no_traceback():
    """The installed entry point too: exit status 2, one error line on stderr."""
    proc = subprocess.run([sys.executable, "-m", "lift_gl", "render", str(DATA / "malformed.toml"), "--out", "x.npy"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines() == [error_line(proc.stderr)]
    assert "malformed.toml:4:" in proc.stderr
