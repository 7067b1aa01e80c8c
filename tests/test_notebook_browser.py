"""The notebook widget in a real browser: Voila serves examples/notebooks/viewer.ipynb on
127.0.0.1, Debian's Chromium (through playwright) opens it, waits for the progressive render to
finish, drags the camera, and checks that the image changed. Screenshots of before and after are
kept in the test's temporary folder."""
from __future__ import annotations

import io
import shutil
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("voila", reason="voila is not installed (pip install 'lift-gl[test]')")
pytest.importorskip("anywidget", reason="the notebook extra is not installed (pip install 'lift-gl[notebook]')")
playwright = pytest.importorskip("playwright.sync_api", reason="playwright is not installed "
                                                              "(pip install 'lift-gl[test]')")

NOTEBOOKS = Path(__file__).resolve().parent.parent / "examples" / "notebooks"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SPP = 32   # viewer.ipynb's


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def voila(tmp_path_factory):
    port = free_port()
    log = open(tmp_path_factory.mktemp("voila") / "voila.log", "wb")
    process = subprocess.Popen([sys.executable, "-m", "voila", str(NOTEBOOKS / "viewer.ipynb"), "--no-browser",
                                f"--port={port}", "--Voila.ip=127.0.0.1", "--show_tracebacks=True"],
                               stdout=log, stderr=subprocess.STDOUT, cwd=NOTEBOOKS)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        try:
            urllib.request.urlopen(url, timeout=5).close()   # the server answers (it runs the notebook then)
            break
        except OSError:
            time.sleep(0.5)
    yield url
    process.terminate()
    process.wait(timeout=30)
    log.close()


def frame_state(page) -> tuple[int, int]:
    return page.evaluate("() => { const i = document.querySelector('img.lift-gl-frame');"
                         " return i ? [Number(i.dataset.frames || 0), Number(i.dataset.samples || 0)] : [0, 0]; }")


def wait_for_full_frame(page, after_frames: int = 0, timeout: float = 180) -> None:
    page.wait_for_function(f"() => {{ const i = document.querySelector('img.lift-gl-frame');"
                           f" return i && Number(i.dataset.frames) > {after_frames} &&"
                           f" Number(i.dataset.samples) >= {SPP} && i.complete && i.naturalWidth > 0; }}",
                           timeout=timeout * 1000)


def picture(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.float64)


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium (Debian package chromium: make system)")
def test_drag_in_the_browser_moves_the_camera(voila, tmp_path):
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 900, "height": 700})
        page.goto(voila, timeout=120_000)
        page.wait_for_selector("img.lift-gl-frame", timeout=120_000)
        wait_for_full_frame(page)
        image = page.locator("img.lift-gl-frame")
        before = image.screenshot(path=str(tmp_path / "before.png"))
        frames = frame_state(page)[0]
        box = image.bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(x, y)
        page.mouse.down()
        for step in range(1, 11):
            page.mouse.move(x + 8 * step, y + 2 * step)
            page.wait_for_timeout(30)
        page.mouse.up()
        wait_for_full_frame(page, after_frames=frames)
        after = image.screenshot(path=str(tmp_path / "after.png"))
        page.screenshot(path=str(tmp_path / "page.png"))
        browser.close()
    a, b = picture(before), picture(after)
    assert a.shape == b.shape and a.shape[0] >= 96
    assert a.std() > 10 and b.std() > 10                      # a render, not a blank box
    assert np.abs(a - b).mean() > 5, "the image did not change after the drag"
