"""The viewer in a real window (Xvfb, GLX on Mesa llvmpipe): a scripted run of
`lift-gl view scenes/furnace.toml --frames N --screenshot FILE`, checked for its GUI panels and
for an image that agrees, within Monte Carlo noise, with headless renders of the same frames.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from conftest import REPO
from lift_gl import load_scene
from lift_gl.renderer import Renderer

FURNACE = REPO / "scenes" / "furnace.toml"
WINDOW = (800, 480)
SCALE = 2  # --scale 0.5: each render pixel is a 2x2 block of the window
RENDER = (WINDOW[0] // SCALE, WINDOW[1] // SCALE)
SPP_PER_FRAME, FRAMES = 2, 4
K = 4  # independent headless renders, for the noise of each pixel
# ImGui's default dark style: title bars of the focused and the other windows, and text.
TITLE_COLOURS = ((41, 74, 122), (10, 10, 10))


@pytest.fixture(scope="module")
def display():
    """A private Xvfb server; -displayfd lets it pick a free display number (no xauth needed)."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (Debian package xvfb; scripts/setup_system.sh installs it)")
    read_fd, write_fd = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                              pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    with os.fdopen(read_fd) as pipe:
        number = pipe.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def _run_viewer(display, out, *extra):
    env = dict(os.environ, DISPLAY=display)
    cmd = [sys.executable, "-m", "lift_gl", "view", str(FURNACE), "--size", f"{WINDOW[0]}x{WINDOW[1]}",
           "--scale", str(1 / SCALE), "--spp-per-frame", str(SPP_PER_FRAME), "--frames", str(FRAMES),
           "--tonemap", "clamp", "--exposure", "-1", "--seed", "0", "--screenshot", str(out), *extra]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return np.asarray(Image.open(out).convert("RGB")), json.loads(out.with_suffix(".json").read_text())


def _headless_displays(seeds) -> np.ndarray:
    """The same frames rendered headless, tone-mapped by the same GPU pass: uint8 (K, H, W, 3)."""
    out = []
    for seed in seeds:
        r = Renderer(load_scene(FURNACE), size=RENDER, seed=seed, samples_per_frame=SPP_PER_FRAME)
        r.render(spp=SPP_PER_FRAME * FRAMES)
        out.append(r.display(exposure=-1.0, operator="clamp"))
        r.release()
    return np.stack(out)


def _pooled_variance(images: np.ndarray, block: int = 4) -> np.ndarray:
    """Per-pixel variance across runs, averaged over block x block neighbourhoods
    (K - 1 degrees of freedom per pixel are too few for a z-score; the blocks give 16 (K - 1))."""
    var = images.astype(np.float64).var(axis=0, ddof=1)
    h, w = var.shape[:2]
    pooled = var.reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))
    return np.repeat(np.repeat(pooled, block, axis=0), block, axis=1)


def test_scripted_viewer_run_shows_the_panels_and_the_headless_image(display, tmp_path):
    shot, report = _run_viewer(display, tmp_path / "furnace.png")
    assert shot.shape == (WINDOW[1], WINDOW[0], 3)
    assert report["render_size"] == list(RENDER) and report["window_size"] == list(WINDOW)
    assert (report["spp"], report["frames"]) == (SPP_PER_FRAME * FRAMES, FRAMES)
    assert report["dropped_samples"] == 0 and report["errors"] == []
    assert report["image_rect"] == [0, 0, *WINDOW]

    # ---- the GUI panels: where ImGui says they are, with title bars and text ----
    assert {"Settings", "Statistics"} <= set(report["panels"])
    covered = np.zeros(shot.shape[:2], bool)
    for name, (x, y, w, h) in report["panels"].items():
        assert w > 100 and h > 100 and x >= 0 and y >= 0 and x + w <= WINDOW[0] and y + h <= WINDOW[1], name
        title = shot[y + 4:y + 14, x + 30:x + w - 30].reshape(-1, 3)
        in_title = np.any([np.all(title == c, axis=1) for c in TITLE_COLOURS], axis=0)
        assert in_title.mean() > 0.5, f"{name}: no ImGui title bar at its rectangle"
        body = shot[y + 20:y + h, x:x + w]
        assert (body.min(axis=-1) > 220).mean() > 0.01, f"{name}: no text drawn"
        covered[max(0, y - 2):y + h + 2, max(0, x - 2):x + w + 2] = True

    # ---- the image: nearest-neighbour blocks of the render, equal to headless renders within noise ----
    blocks = shot.reshape(RENDER[1], SCALE, RENDER[0], SCALE, 3).astype(int)
    free = ~covered.reshape(RENDER[1], SCALE, RENDER[0], SCALE).any(axis=(1, 3))
    assert free.sum() > 0.2 * free.size  # enough of the image is not under a panel
    assert np.all(blocks.max(axis=(1, 3))[free] == blocks.min(axis=(1, 3))[free])  # one colour a block
    viewer = blocks[:, 0, :, 0, :].astype(np.float64)
    headless = _headless_displays(range(1, K + 1))
    mean = headless.mean(axis=0)
    # Var(viewer - mean of K) = sigma^2 (1 + 1/K); the viewer's own rounding to 8 bits is in
    # sigma^2 already (the headless images are rounded the same way), and pixels with no noise
    # (the background: exactly the sky) must then agree exactly.
    variance = _pooled_variance(headless) * (1 + 1 / K)
    diff = viewer - mean
    noiseless = variance == 0
    assert np.all(diff[noiseless & free[..., None]] == 0)
    noisy = ~noiseless & free[..., None]
    assert noisy.sum() > 1000  # the sphere's right side is in view
    z2 = diff[noisy] ** 2 / variance[noisy]
    # E[z^2] = 1 (a little more: the variance is estimated with 48 degrees of freedom); a wrong
    # camera, exposure, orientation or sample count gives z^2 in the tens at edges and background.
    assert z2.mean() < 1.5, f"mean z^2 = {z2.mean():.2f}"
    assert (z2 > 25).mean() < 0.002
