"""The command line under hostile and careless use (issue 32): bad numbers and unwritable
outputs are refused before any work, in one line with exit 2; files appear whole or not at
all, Ctrl-C included (one line, exit 130); warnings are one line each; a corrupt EXR prints
nothing of its own."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from lift_gl.atomic import atomic_path, temporary_name
from lift_gl.cli import main
from lift_gl.image_io import ImageError, read_image, write_image

FURNACE = REPO / "scenes" / "furnace.toml"
TINY = ["--size", "8x8", "--spp", "1"]


def forbid_loading(monkeypatch):
    """The scene must not even be read: the argument was checked first."""
    def called(*args, **kwargs):
        raise AssertionError("the scene was loaded before the arguments were checked")
    monkeypatch.setattr("lift_gl.scene.loader.load_scene", called)


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ---------------------------------------------------------------- numbers
@pytest.mark.parametrize("args, words", [
    (["--seed", "-1"], "a seed is a whole number in [0, 4294967295], not -1"),
    (["--seed", str(2 ** 32)], "a seed is a whole number"),
    (["--spp", "0"], "argument --spp: must be at least 1, not 0"),
    (["--spp", "-3"], "argument --spp: must be at least 1, not -3"),
    (["--time", "nan"], "argument --time: expected a finite number, not 'nan'"),
    (["--time", "inf"], "argument --time: expected a finite number, not 'inf'"),
    (["--time", "0"], "argument --time: must be above 0"),
    (["--exposure", "nan"], "argument --exposure: expected a finite number"),
    (["--size", "0x8"], "size must be positive"),
])
def test_render_refuses_bad_numbers_before_loading_anything(capsys, monkeypatch, tmp_path, args, words):
    forbid_loading(monkeypatch)
    with pytest.raises(SystemExit) as info:
        main(["render", str(FURNACE), "--out", str(tmp_path / "x.png"), *args])
    assert info.value.code == 2
    line = one_error_line(capsys)
    assert line.startswith("lift-gl render: error: ") and words in line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv, words", [
    (["compare", str(FURNACE), "--spp", "0", "--out", "o"], "argument --spp: must be at least 1"),
    (["compare", str(FURNACE), "--time", "inf", "--out", "o"], "argument --time: expected a finite number"),
    (["compare", str(FURNACE), "--spp", "4", "--seeds", "0", "--out", "o"], "argument --seeds: must be at least 1"),
    (["compare", str(FURNACE), "--spp", "4", "--alpha", "1.5", "--out", "o"], "must be between 0 and 1"),
    (["bench", str(FURNACE), "--frames", "0"], "argument --frames: must be at least 1"),
    (["bench", str(FURNACE), "--repeat", "-1"], "argument --repeat: must be at least 1"),
    (["grade", "subs", "--spp", "0", "--out", "o"], "argument --spp: must be at least 1"),
    (["grade", "subs", "--timeout", "nan", "--out", "o"], "argument --timeout: expected a finite number"),
    (["grade", "subs", "--first-seed", "-1", "--out", "o"], "argument --first-seed: a seed is a whole number"),
    (["view", str(FURNACE), "--seed", "-1"], "argument --seed: a seed is a whole number"),
    (["view", str(FURNACE), "--spp-per-frame", "0"], "argument --spp-per-frame: must be at least 1"),
    (["view", str(FURNACE), "--target-time", "inf"], "argument --target-time: expected a finite number"),
    (["warptest", "--sampler", "s", "--domain", "square", "--samples", "0"], "argument --samples: must be at least 1"),
])
def test_every_command_refuses_bad_numbers(capsys, argv, words):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    line = one_error_line(capsys)
    assert line.startswith(f"lift-gl {argv[0]}: error: ") and words in line


# ---------------------------------------------------------------- outputs
def test_render_refuses_outputs_it_cannot_write_before_rendering(capsys, monkeypatch, tmp_path):
    forbid_loading(monkeypatch)
    a_file = tmp_path / "a_file.txt"
    a_file.write_text("x")
    read_only = tmp_path / "read_only"
    read_only.mkdir()
    cases = [(tmp_path, "this is a folder; give a file name"),
             (a_file / "x.png", f"{a_file} is a file, not a folder"),
             (a_file / "deeper" / "x.png", f"{a_file} is a file, not a folder"),
             (tmp_path / "x.jpg", "unknown file type '.jpg'"),
             (tmp_path / "x", "unknown file type '(no extension)'")]
    for out, words in cases:
        assert main(["render", str(FURNACE), *TINY, "--out", str(out)]) == 2
        line = one_error_line(capsys)
        assert line.startswith(f"lift-gl: error: {out}: --out: ") and words in line, line
    assert main(["render", str(FURNACE), *TINY, "--out", str(tmp_path / "ok.png"), "--denoise", "final",
                 "--noisy-out", str(a_file / "n.exr")]) == 2
    assert "--noisy-out" in one_error_line(capsys)
    unwritable = []
    if os.path.isdir("/proc"):
        unwritable.append(Path("/proc"))  # no file can be made there, not even by root
    if os.geteuid() != 0:  # a mode of 0o500 does not stop root
        os.chmod(read_only, 0o500)
        unwritable.append(read_only)
    try:
        for folder in unwritable:
            assert main(["render", str(FURNACE), *TINY, "--out", str(folder / "x.png")]) == 2
            assert f"cannot write in the folder {folder}" in one_error_line(capsys)
    finally:
        os.chmod(read_only, 0o700)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file.txt", "read_only"]  # no probe left behind


def test_a_sequence_under_a_file_is_refused_before_rendering(capsys, monkeypatch, tmp_path):
    forbid_loading(monkeypatch)
    a_file = tmp_path / "frames"
    a_file.write_text("x")
    path = tmp_path / "path.toml"
    path.write_text("[[keyframe]]\ntime = 0.0\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n")
    assert main(["render", str(FURNACE), "--camera-path", str(path), "--frames", "2", "--out", str(a_file)]) == 2
    assert f"{a_file} is a file, not a folder" in one_error_line(capsys)


def test_compare_and_grade_refuse_a_file_as_their_folder(capsys, tmp_path):
    a_file = tmp_path / "report"
    a_file.write_text("x")
    (tmp_path / "subs").mkdir()
    for argv in (["compare", str(FURNACE), "--spp", "2", "--out", str(a_file)],
                 ["grade", str(tmp_path / "subs"), "--out", str(a_file)],
                 ["bench", str(FURNACE), "--json", str(tmp_path)]):
        assert main(argv) == 2
        line = one_error_line(capsys)
        assert "this is a file, not a folder" in line or "this is a folder; give a file name" in line


# ---------------------------------------------------------------- atomic writes
@pytest.mark.parametrize("suffix", [".png", ".exr", ".pfm", ".npy"])
def test_every_image_writer_leaves_no_file_when_interrupted(monkeypatch, tmp_path, suffix):
    image = np.full((4, 5, 3), 0.5, np.float32)
    out = tmp_path / f"x{suffix}"
    write_image(out, image)
    before = out.read_bytes()

    def interrupted(path, *args, **kwargs):
        with open(path, "wb") as f:
            f.write(b"half a file")
        raise KeyboardInterrupt
    target = {".png": "lift_gl.image_io._write_png", ".exr": "lift_gl.image_io._write_exr",
              ".pfm": "lift_gl.image_io._write_pfm", ".npy": "numpy.save"}[suffix]
    monkeypatch.setattr(target, interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_image(out, image * 2)
    assert out.read_bytes() == before  # the earlier file is as it was
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # and no temporary file stays


def test_atomic_path_keeps_the_extension_and_removes_the_temporary_on_error(tmp_path):
    out = tmp_path / "sub" / "r.json"
    assert temporary_name(out).suffix == ".json" and temporary_name(out).parent == out.parent
    with pytest.raises(ValueError):
        with atomic_path(out) as tmp:
            tmp.write_text("partial")
            raise ValueError("disk full")
    assert not out.exists() and list(out.parent.iterdir()) == []


def test_ctrl_c_while_the_png_is_written_leaves_no_file_and_prints_one_line(capsys, monkeypatch, tmp_path):
    from PIL import Image

    real_save = Image.Image.save

    def interrupted_save(self, fp, *args, **kwargs):
        real_save(self, fp, *args, **kwargs)  # a whole file under the temporary name, then Ctrl-C
        raise KeyboardInterrupt
    monkeypatch.setattr(Image.Image, "save", interrupted_save)
    out = tmp_path / "x.png"
    assert main(["render", str(FURNACE), *TINY, "--out", str(out)]) == 130
    assert one_error_line(capsys) == "lift-gl: interrupted"
    assert list(tmp_path.iterdir()) == []


def test_sigint_during_a_render_exits_130_with_one_line(tmp_path):
    """A real Ctrl-C (SIGINT) sent once the render has started (--explain prints first)."""
    out = tmp_path / "x.png"
    process = subprocess.Popen([sys.executable, "-m", "lift_gl", "render", str(FURNACE), "--size", "8x8",
                                "--time", "120", "--explain", "--out", str(out)], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert process.stdout.readline()  # the explanation: the renderer exists, frames follow
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 130
    assert err.strip() == "lift-gl: interrupted"
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- messages
def test_warnings_are_one_line_naming_the_scene_file(tmp_path):
    scene = tmp_path / "lost.toml"
    scene.write_text('[materials.m]\ntexture = "nowhere.png"\n\n[[objects]]\ntype = "sphere"\nmaterial = "m"\n')
    result = subprocess.run([sys.executable, "-m", "lift_gl", "render", str(scene), *TINY, "--out",
                             str(tmp_path / "x.png")], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert f"lift-gl: warning: {scene}:2: texture file not found: " in lines[0]
    assert all(line.startswith("lift-gl: warning: ") for line in lines), lines
    assert "SceneWarning" not in result.stderr and ".py:" not in result.stderr


def test_numpy_warnings_from_a_loader_do_not_leak(tmp_path):
    scene = tmp_path / "huge.pbrt"
    scene.write_text('Scale 1e200 1e200 1e200\nLookAt 0 0 5  0 0 0  0 1 0\nCamera "perspective"\n'
                     'WorldBegin\nShape "sphere"\n')
    result = subprocess.run([sys.executable, "-m", "lift_gl", "render", str(scene), *TINY, "--out",
                             str(tmp_path / "x.png")], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2
    assert "RuntimeWarning" not in result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_a_corrupt_exr_prints_nothing_and_is_one_error_naming_it(capfd, tmp_path):
    good = tmp_path / "good.exr"
    write_image(good, np.ones((4, 6, 3), np.float32))
    data = bytearray(good.read_bytes())
    corrupt = []
    for position in (24, 28, 46, len(data) - 20):  # header fields, the offset table, the pixel data
        bad = bytearray(data)
        bad[position] = 0xFF if position != 46 else 0x00
        path = tmp_path / f"bad{position}.exr"
        path.write_bytes(bad)
        corrupt.append(path)
    truncated = tmp_path / "truncated.exr"
    truncated.write_bytes(data[:12])
    for path in corrupt + [truncated]:
        try:
            image = read_image(path)
        except ImageError as exc:
            assert str(exc).startswith(f"{path}: ") and "\n" not in str(exc)
        else:  # a byte that the format does not check (a pixel value): still an image
            assert image.shape == (4, 6, 3)
        printed = capfd.readouterr()
        assert printed.out == "" and printed.err == "", (path, printed)
    with pytest.raises(ImageError, match="not a readable EXR file"):
        read_image(truncated)
