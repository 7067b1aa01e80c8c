"""`Viewer`: a progressive render in a notebook cell, orbit and zoom with the mouse.

    from lift_gl.notebook import Viewer
    Viewer("scenes/cornell.toml", size=(128, 128), spp=64)

The render runs in the kernel (EGL on the GPU server a JupyterHub runs on, llvmpipe
anywhere: lift_gl/notebook/render_thread.py); the browser gets tone-mapped JPEG frames as they
are made and sends back the mouse: drag to orbit about the camera's target, wheel to zoom.
The integrator menu and the spp box restart the accumulation. A widget of anywidget
(pip install 'lift-gl[notebook]'); viewer.js is its front end.
"""
from __future__ import annotations

from pathlib import Path

import anywidget
import traitlets

from .display import jpeg_bytes
from .render_thread import RenderThread, ViewSettings


class Viewer(anywidget.AnyWidget):
    _esm = Path(__file__).with_name("viewer.js")
    _css = Path(__file__).with_name("viewer.css")

    frame = traitlets.Bytes(b"").tag(sync=True)          # the latest frame, JPEG
    width = traitlets.Int(128).tag(sync=True)
    height = traitlets.Int(128).tag(sync=True)
    scale = traitlets.Int(2).tag(sync=True)              # shown this many times larger
    integrator = traitlets.Unicode("pt").tag(sync=True)
    integrators = traitlets.List(traitlets.Unicode()).tag(sync=True)
    spp = traitlets.Int(64).tag(sync=True)               # samples per pixel to render up to
    samples = traitlets.Int(0).tag(sync=True)            # samples per pixel in the frame shown
    frames = traitlets.Int(0).tag(sync=True)             # frames sent so far
    status = traitlets.Unicode("").tag(sync=True)        # an error, or ""

    def __init__(self, scene, size=(128, 128), integrator: str = "pt", spp: int = 64, params=None,
                 integrators=None, backend: str = "auto", plugin_dirs=(), options=None, scale: int = 2,
                 sensitivity: float = 0.4):
        """scene: a path or a loaded Scene. integrators: the menu (default: every plugin found).
        sensitivity: degrees of orbit per pixel dragged."""
        from .. import load_scene
        from ..app.camera_controller import CameraController
        from ..plugins import discover

        if not isinstance(scene, (str, Path)):
            loaded = scene
        else:
            loaded = load_scene(scene)
        size = tuple(int(v) for v in size)
        names = list(integrators) if integrators is not None else sorted(discover(plugin_dirs))
        if integrator not in names:
            names.insert(0, integrator)
        super().__init__(width=size[0], height=size[1], scale=int(scale), integrator=integrator,
                         integrators=names, spp=int(spp))
        self.controller = CameraController(loaded.camera, _scene_size(loaded))
        self.controller.mode = "orbit"
        self.controller.settings.sensitivity = float(sensitivity)
        settings = ViewSettings(integrator=integrator, spp=int(spp), size=size, params=dict(params or {}),
                                backend=backend, plugin_dirs=tuple(plugin_dirs), options=options)
        self.on_msg(self._on_message)
        self.observe(lambda change: self.thread.post_integrator(change["new"]), names="integrator")
        self.observe(lambda change: self.thread.post_spp(change["new"]), names="spp")
        self.thread = RenderThread(loaded, settings, self._on_frame, self._on_status)

    # ---- from the render thread ----
    def _on_frame(self, srgb8, stats) -> None:
        self.frame = jpeg_bytes(srgb8)
        self.samples = int(stats.spp)
        self.frames += 1

    def _on_status(self, text: str) -> None:
        self.status = text

    # ---- from the browser ----
    def _on_message(self, widget, content, buffers) -> None:
        kind = content.get("kind") if isinstance(content, dict) else None
        if kind == "orbit":
            moved = self.controller.look(float(content.get("dx", 0)), float(content.get("dy", 0)))
        elif kind == "zoom":
            moved = self.controller.scroll(float(content.get("amount", 0)))
        else:
            return
        if moved:
            self.thread.post_camera(self.controller.camera())

    # ---- from Python ----
    def orbit(self, dx: float, dy: float) -> None:
        """Turn the camera as a drag of (dx, dy) pixels would."""
        self._on_message(self, {"kind": "orbit", "dx": dx, "dy": dy}, [])

    def zoom(self, amount: float) -> None:
        """Zoom as `amount` clicks of the mouse wheel would (positive: closer)."""
        self._on_message(self, {"kind": "zoom", "amount": amount}, [])

    def close(self) -> None:
        """Stop rendering and free the GL context; the widget goes away."""
        self.thread.close()
        super().close()


def _scene_size(scene) -> float:
    """The diagonal of the scene's bounds, as the viewer takes it (the zoom's smallest step)."""
    import numpy as np

    from ..scene.loader import scene_bounds

    bounds = scene_bounds(scene)
    return float(np.linalg.norm(bounds[1] - bounds[0])) if bounds is not None else 1.0
