"""`lift-gl view` on bad input: one line naming what is wrong, exit status 2, no traceback."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from conftest import REPO

FURNACE = str(REPO / "scenes" / "furnace.toml")


def _view(*args, env=None):
    proc = subprocess.run([sys.executable, "-m", "lift_gl", "view", *args], capture_output=True, text=True,
                          timeout=120, env=env)
    return proc.returncode, proc.stderr


@pytest.mark.parametrize("args, message", [
    (["missing.toml"], "missing.toml: scene file not found"),
    ([FURNACE, "--screenshot", "a.png"], "--screenshot needs --frames N"),
    ([FURNACE, "--frames", "2", "--screenshot", "a.jpg"], "--screenshot writes a PNG"),
    ([FURNACE, "--scale", "2"], "--scale must be in (0, 1]"),
])
def test_bad_arguments(args, message):
    rc, err = _view(*args)
    assert rc == 2 and message in err and "Traceback" not in err


def test_no_display_says_what_to_do():
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    rc, err = _view(FURNACE, "--frames", "1", env=env)
    assert rc == 2 and "Traceback" not in err
    assert "cannot open a pyglet window" in err and "xvfb-run" in err


def test_view_needs_no_gui_library_to_be_listed():
    """`lift-gl --help` and `render` must not import the viewer's toolkits."""
    code = ("import sys, lift_gl.cli; lift_gl.cli.main(['plugins']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('imgui_bundle', 'moderngl_window', 'pyglet')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert out.returncode == 0 and out.stdout.strip().endswith("[]")
