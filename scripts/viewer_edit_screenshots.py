"""Screenshots of a live light edit in the viewer (docs/teaching.md), made through the window's
own input handlers: the mouse presses on the Cornell box's ceiling light and drags it,
then the light's colour, radiance and size are set as the Edit panel's widgets set them,
and the edited scene is saved as .toml.

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python scripts/viewer_edit_screenshots.py [OUT_DIR]

Writes OUT_DIR (default docs/teaching/) edit-before.png, edit-after.png (windows with their
GUI), cornell-edited.toml, and prints where the light went.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from lift_gl.app.window import ViewerWindow, ViewOptions
from lift_gl.image_io import write_srgb8
from lift_gl.scene import edit

REPO = Path(__file__).resolve().parent.parent
LIGHT = edit.ObjectRef("mesh", 5)  # scenes/cornell.toml's ceiling light
FRAMES = 24


def window_point(window, point) -> tuple[float, float]:
    """Window coordinates of the render pixel that sees world `point`."""
    renderer = window.session.renderer
    camera, (w, h) = renderer.scene.camera, renderer.size
    right, up, forward = camera.basis()
    d = np.asarray(point, np.float64) - camera.position
    t = np.tan(np.radians(camera.fov_deg) / 2)
    x = ((d @ right) / (d @ forward) / (t * w / h) + 1) / 2 * w
    y = h - ((d @ up) / (d @ forward) / t + 1) / 2 * h
    rx, ry, rw, rh = window.ui.image_rect
    return rx + x * rw / w, ry + y * rh / h


def frames(window, n) -> None:
    for _ in range(n):
        window.frame()
        window.wnd.swap_buffers()


def main(out_dir: Path) -> int:
    out_dir.mkdir(parents=True, exist_ok=True)
    window = ViewerWindow(ViewOptions(scene=str(REPO / "scenes" / "cornell.toml"), window_size=(960, 540),
                                      render_scale=0.5, samples_per_frame=2, panels=("edit", "statistics")))
    session, editor = window.session, window.session.editor
    editor.save_path = Path("scenes") / "cornell-edited.toml"  # as a user's own clone shows it, not this machine's path
    frames(window, FRAMES)
    before = edit.object_center(session.scene, LIGHT)
    x, y = window_point(window, before)
    window.on_mouse_position(x, y, 0, 0)
    frames(window, 1)  # ImGui learns where the mouse is (over the image, not a panel)
    write_srgb8(out_dir / "edit-before.png", window.read_window())

    # ---- drag the light along the ceiling: right and towards the camera ----
    window.on_mouse_press(x, y, 1)
    for step in range(1, 5):
        window.on_mouse_drag(x - 20 * step, y + 3 * step, -20, 3)
        frames(window, 1)
    window.on_mouse_release(x - 80, y + 12, 1)
    # ---- what the Edit panel's widgets do: colour, radiance, size ----
    editor.set_light(9.0, [0.45, 0.6, 1.0])
    editor.scale(0.6)
    frames(window, FRAMES)
    after = edit.object_center(session.scene, LIGHT)
    write_srgb8(out_dir / "edit-after.png", window.read_window())
    saved = editor.save(out_dir / "cornell-edited.toml")
    print(f"light moved from {np.round(before, 3).tolist()} to {np.round(after, 3).tolist()}, "
          f"emission {session.scene.materials[session.scene.meshes[LIGHT.index].material].emission.tolist()}; "
          f"saved {saved}; errors: {session.errors.entries or 'none'}")
    window.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "teaching"))
