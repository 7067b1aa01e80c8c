"""The viewer in a real window (Xvfb, GLX on Mesa llvmpipe): a scripted run of
`lift-gl view scenes/furnace.toml --frames N --screenshot FILE`, checked for its GUI panels and
for an image that agrees, within Monte Carlo noise, with headless renders of the same frames;
and the docked layout (ImGui's own window rectangles and content widths): no panel over the
image, the image's aspect ratio, no clipped label, at several window sizes and with every
panel open; a drag or a wheel turn on a panel leaves the camera alone, on the image moves it.
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
CORNELL = REPO / "scenes" / "cornell.toml"
WINDOW = (800, 480)
SCALE = 2  # --scale 0.5: each render pixel is a 2x2 block of the window
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
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1920x1080x24", "-nolisten", "tcp"],
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


def _run_viewer(display, out, *args):
    env = dict(os.environ, DISPLAY=display)
    cmd = [sys.executable, "-m", "lift_gl", "view", *args, "--screenshot", str(out)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return np.asarray(Image.open(out).convert("RGB")), json.loads(out.with_suffix(".json").read_text())


def _run_furnace(display, out):
    return _run_viewer(display, out, str(FURNACE), "--size", f"{WINDOW[0]}x{WINDOW[1]}", "--scale", str(1 / SCALE),
                       "--spp-per-frame", str(SPP_PER_FRAME), "--frames", str(FRAMES), "--tonemap", "clamp",
                       "--exposure", "-1", "--seed", "0")


def _headless_displays(seeds, size) -> np.ndarray:
    """The same frames rendered headless, tone-mapped by the same GPU pass: uint8 (K, H, W, 3)."""
    out = []
    for seed in seeds:
        r = Renderer(load_scene(FURNACE), size=size, seed=seed, samples_per_frame=SPP_PER_FRAME)
        r.render(spp=SPP_PER_FRAME * FRAMES)
        out.append(r.display(exposure=-1.0, operator="clamp"))
        r.release()
    return np.stack(out)


SILHOUETTE_RING = 3  # render pixels


def _near(mask: np.ndarray, radius: int) -> np.ndarray:
    """Pixels within `radius` (a square's half-width) of a True one, per channel: (H, W, C)."""
    h, w = mask.shape[:2]
    padded = np.pad(mask, ((radius, radius), (radius, radius), (0, 0)))
    out = np.zeros_like(mask)
    for dy in range(2 * radius + 1):
        for dx in range(2 * radius + 1):
            out |= padded[dy:dy + h, dx:dx + w]
    return out


def _pooled_variance(images: np.ndarray, block: int = 4) -> np.ndarray:
    """Per-pixel variance across runs, averaged over block x block neighbourhoods
    (K - 1 degrees of freedom per pixel are too few for a z-score; the blocks give 16 (K - 1))."""
    var = images.astype(np.float64).var(axis=0, ddof=1)
    h, w = var.shape[:2]
    pooled = var.reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))
    return np.repeat(np.repeat(pooled, block, axis=0), block, axis=1)


def test_scripted_viewer_run_shows_the_panels_and_the_headless_image(display, tmp_path):
    shot, report = _run_furnace(display, tmp_path / "furnace.png")
    assert shot.shape == (WINDOW[1], WINDOW[0], 3)
    assert report["window_size"] == list(WINDOW)
    assert (report["spp"], report["frames"]) == (SPP_PER_FRAME * FRAMES, FRAMES)
    assert report["dropped_samples"] == 0 and report["errors"] == []
    assert_docked_layout(report, "furnace 800x480", scale=1 / SCALE)

    # ---- the GUI panels: where ImGui says they are, with title bars and text ----
    assert {"Settings", "Statistics"} <= set(report["panels"])
    for name, (x, y, w, h) in report["panels"].items():
        assert w > 100 and h > 100 and x >= 0 and y >= 0 and x + w <= WINDOW[0] and y + h <= WINDOW[1], name
        title = shot[y + 4:y + 14, x + 30:x + w - 30].reshape(-1, 3)
        in_title = np.any([np.all(title == c, axis=1) for c in TITLE_COLOURS], axis=0)
        assert in_title.mean() > 0.5, f"{name}: no ImGui title bar at its rectangle"
        body = shot[y + 20:y + h, x:x + w]
        assert (body.min(axis=-1) > 220).mean() > 0.01, f"{name}: no text drawn"

    # ---- the image: nearest-neighbour blocks of the render, equal to headless renders within noise ----
    render = tuple(report["render_size"])
    x, y, w, h = report["image_rect"]
    assert (w, h) == (SCALE * render[0], SCALE * render[1])  # this window's image area is a whole multiple
    blocks = shot[y:y + h, x:x + w].reshape(render[1], SCALE, render[0], SCALE, 3).astype(int)
    assert np.all(blocks.max(axis=(1, 3)) == blocks.min(axis=(1, 3)))  # one colour a block: no panel over it
    viewer = blocks[:, 0, :, 0, :].astype(np.float64)
    headless = _headless_displays(range(1, K + 1), render)
    rows, cols = render[1] // 4 * 4, render[0] // 4 * 4  # whole blocks of _pooled_variance
    viewer, headless = viewer[:rows, :cols], headless[:, :rows, :cols]
    mean = headless.mean(axis=0)
    # Var(viewer - mean of K) = sigma^2 (1 + 1/K); the viewer's own rounding to 8 bits is in
    # sigma^2 already (the headless images are rounded the same way), and pixels with no noise
    # (the background: exactly the sky) must then agree exactly. Not so next to the sphere's
    # silhouette: a pixel that the sphere barely covers can be missed by all K renders' samples
    # (no noise seen) and hit by the viewer's; those pixels, a few wide, take neither test.
    variance = _pooled_variance(headless) * (1 + 1 / K)
    diff = viewer - mean
    noiseless = variance == 0
    assert np.all(diff[noiseless & ~_near(~noiseless, SILHOUETTE_RING)] == 0)
    noisy = ~noiseless
    assert noisy.sum() > 1000  # the sphere's right side is in view
    z2 = diff[noisy] ** 2 / variance[noisy]
    # E[z^2] = 1 (a little more: the variance is estimated with 48 degrees of freedom); a wrong
    # camera, exposure, orientation or sample count gives z^2 in the tens at edges and background.
    assert z2.mean() < 1.5, f"mean z^2 = {z2.mean():.2f}"
    assert (z2 > 25).mean() < 0.002


# ---- the docked layout ---------------------------------------------------------------------------
def _overlap(a, b) -> int:
    """Pixels shared by two rectangles (x, y, w, h)."""
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(0, w) * max(0, h)


def assert_docked_layout(record: dict, where: str, scale: float | None = None) -> None:
    """ViewerWindow.layout_report() (also in a scripted screenshot's JSON) describes a layout in
    which no panel covers the image, the image has the render's aspect ratio and fills its area
    one way to within one render pixel's block (letterboxed the other), every panel drawn in
    front fits its lines in its width, and (with `scale`) the render resolution is the area's
    times the render scale, rounded down."""
    window = (0, 0, *record["window_size"])
    image, area = record["image_rect"], record["image_area"]
    render_w, render_h = record["render_size"]
    x, y, w, h = image
    assert w > 0 and h > 0 and _overlap(image, area) == w * h and _overlap(area, window) == area[2] * area[3], where
    assert area[2] - w < w / render_w + 1 or area[3] - h < h / render_h + 1, \
        f"{where}: the image {image} leaves room both ways in {area}"
    # Each side of the rectangle is rounded to a whole pixel: at most half a pixel of error on each.
    assert abs(w * render_h - h * render_w) <= 0.5 * (render_w + render_h), \
        f"{where}: image {w}x{h} for a {render_w}x{render_h} render"
    if scale is not None:
        assert (render_w, render_h) == (int(area[2] * scale), int(area[3] * scale)), where
    for name, rect in record["panels"].items():
        assert _overlap(rect, image) == 0, f"{where}: {name} {rect} covers the image {image}"
    for name, (reach, room) in record["panel_fit"].items():
        assert reach <= room + 0.5, f"{where}: a line of {name} reaches x = {reach}, past its room (x = {room})"


def test_panels_dock_beside_the_image_at_1280x720(display, tmp_path):
    """`lift-gl view` at 1280x720 with its default panels: ImGui's rectangles from the
    screenshot's JSON, and the image drawn where the JSON says (the letterbox bars are empty)."""
    shot, report = _run_viewer(display, tmp_path / "cornell.png", str(CORNELL), "--size", "1280x720",
                               "--scale", "0.125", "--frames", "1")
    assert report["window_size"] == [1280, 720] and shot.shape == (720, 1280, 3)
    assert set(report["panel_fit"]) == {"Settings", "Statistics"}  # both drawn, both checked
    assert_docked_layout(report, "1280x720", scale=0.125)
    x, y, w, h = report["image_rect"]
    assert w * h >= 0.6 * 1280 * 720  # the panels keep to a column
    background = np.array([20, 20, 23])  # the clear colour, 0.08 0.08 0.09 in sRGB8
    assert not np.all(shot[y:y + h, x:x + w] == background, axis=-1).all()
    ax, ay, aw, ah = report["image_area"]
    bars = np.ones((720, 1280), bool)
    bars[y:y + h, x:x + w] = False
    bars_in_area = bars[ay:ay + ah, ax:ax + aw]
    assert np.all(shot[ay:ay + ah, ax:ax + aw][bars_in_area] == background)


PROBE = """
import json, sys
sys.path.insert(0, sys.argv[1])
import test_viewer_window
print(json.dumps(test_viewer_window.probe_viewer(sys.argv[2], sys.argv[3])))
"""


def probe_viewer(scene: str, work_dir: str) -> dict:
    """Run in a subprocess under Xvfb: a ViewerWindow at 1280x720 driven through its own input
    handlers (the mouse on a panel, then on the image), then every panel open with every
    Settings section expanded, each tab brought to the front in turn, at three window sizes."""
    from pathlib import Path

    from imgui_bundle import imgui

    from lift_gl.app.window import ViewerWindow, ViewOptions

    window = ViewerWindow(ViewOptions(scene=scene, window_size=(1280, 720), render_scale=0.125))
    session = window.session

    def frames(n):
        for _ in range(n):
            window.frame()
            window.wnd.swap_buffers()

    def pose():
        c = session.controller
        return [*map(float, c.position), *map(float, c.forward)]

    def moves_camera(point, action) -> bool:
        window.on_mouse_position(*point, 0, 0)
        frames(1)  # ImGui learns what is under the mouse
        before = pose()
        action(*point)
        frames(1)
        return pose() != before

    def drag(x, y):
        window.on_mouse_press(x, y, window.wnd.mouse.left)
        window.on_mouse_drag(x + 40, y + 10, 40, 10)
        window.on_mouse_release(x + 40, y + 10, window.wnd.mouse.left)

    def wheel(x, y):
        window.on_mouse_scroll(0, 2)

    out = {"records": [], "mouse": {}}
    frames(2)
    session.controller.mode = "orbit"  # the wheel zooms
    sx, sy, sw, sh = window.ui.panel_rects["Statistics"]  # plain text: a drag there changes no widget
    on_panel = (sx + sw // 2, sy + sh // 2)
    ix, iy, iw, ih = window.ui.image_rect
    on_image = (ix + iw // 2, iy + ih // 2)
    out["mouse"] = {"drag on a panel": moves_camera(on_panel, drag), "wheel on a panel": moves_camera(on_panel, wheel),
                    "drag on the image": moves_camera(on_image, drag), "wheel on the image": moves_camera(on_image, wheel)}

    # ---- every panel, every section ----
    original_header = imgui.collapsing_header
    imgui.collapsing_header = lambda label, flags=0: original_header(label, flags | imgui.TreeNodeFlags_.default_open)
    session.screenshot(Path(work_dir) / "reference")
    session.load_reference(Path(work_dir) / "reference.exr")  # fixes the render's size: letterboxed
    session.set_compare("debug")
    session.set_denoise(mode="every")
    session.editor.select(session.editor.emitters()[0])
    session.errors.add("a shader error, long enough to wrap: " + "plugins/pt/pt.glsl:12: 'radiance' undeclared; " * 4)
    window.ui.inspector = True
    for panel in window.panels:
        panel.visible = True
    by_title = {panel.title: panel for panel in window.panels}
    rounds = (("Settings", "Statistics", "Convergence"), ("Denoiser", "Pixel", "Errors"), ("Edit",), ("Keys",))
    for size in ((1280, 720), (960, 540), (1920, 1080)):
        window.wnd._window.set_size(*size)
        frames(2)
        for front in rounds:
            for title in front:
                by_title[title].focus_next = True
            frames(2)
            out["records"].append(dict(window.layout_report(), where=f"{size[0]}x{size[1]}, {', '.join(front)} in front"))
    imgui.collapsing_header = original_header
    window.close()
    return out


def test_layout_with_every_panel_and_the_mouse_over_panels_and_image(display, tmp_path):
    env = dict(os.environ, DISPLAY=display)
    proc = subprocess.run([sys.executable, "-c", PROBE, str(REPO / "tests"), str(CORNELL), str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["mouse"] == {"drag on a panel": False, "wheel on a panel": False,
                            "drag on the image": True, "wheel on the image": True}
    checked = set()
    for record in out["records"]:
        assert_docked_layout(record, record["where"])
        checked |= set(record["panel_fit"])
    assert checked == {"Settings", "Statistics", "Denoiser", "Edit", "Keys", "Pixel", "Convergence", "Errors"}
    sizes = {tuple(r["window_size"]): r for r in out["records"]}
    assert set(sizes) == {(1280, 720), (960, 540), (1920, 1080)}  # the window was resized, and laid out again
    assert len({tuple(r["image_area"]) for r in sizes.values()}) == 3
