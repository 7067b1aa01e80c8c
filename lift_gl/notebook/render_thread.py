"""The notebook widget's renderer, on a thread of its own.

A GL context belongs to the thread that made it, and the kernel's main thread must stay free
to answer the browser (mouse drags arrive as messages there). So one thread makes the Renderer
(EGL on a GPU server, llvmpipe anywhere), owns it for its whole life, and renders progressively
towards the asked spp, a few samples at a time; between batches it takes the commands the main
thread posted (a new camera, integrator or spp) and hands each new frame, tone-mapped, to
`on_frame`. A command that fails (a plugin that does not compile) is reported through
`on_status` and the last good renderer goes on.
"""
from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass, field

BATCH_SECONDS = 0.1      # aim of one batch of samples: the view answers a drag within about this
FRAME_INTERVAL = 0.1     # at most this many seconds between frames sent while rendering


@dataclass
class ViewSettings:
    """What the widget renders: the Renderer's arguments that the user can change."""
    integrator: str = "pt"
    spp: int = 64
    size: tuple = (128, 128)
    params: dict = field(default_factory=dict)
    backend: str = "auto"
    plugin_dirs: tuple = ()
    options: object = None   # lift_gl.options.Options or None


class RenderThread:
    """Renders `scene` on its own thread; `post_*` from any thread; `close()` to stop."""

    def __init__(self, scene, settings: ViewSettings, on_frame, on_status=lambda text: None):
        self.scene, self.settings = scene, settings
        self.on_frame, self.on_status = on_frame, on_status
        self.commands: queue.Queue = queue.Queue()
        self.ready = threading.Event()
        self.error: Exception | None = None   # the renderer could not be made at all
        self.frames = 0
        self.ctx = None   # made on the render thread
        self._thread = threading.Thread(target=self._run, name="lift-gl-notebook-render", daemon=True)
        self._thread.start()

    # ---- from the main thread ----
    def post_camera(self, camera) -> None:
        self.commands.put(("camera", camera))

    def post_integrator(self, integrator: str) -> None:
        self.commands.put(("integrator", integrator))

    def post_spp(self, spp: int) -> None:
        self.commands.put(("spp", int(spp)))

    def close(self, timeout: float = 10.0) -> None:
        self.commands.put(("stop", None))
        self._thread.join(timeout)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    # ---- on the render thread ----
    def _make(self, integrator: str):
        from ..gl.context import new_context
        from ..renderer import Renderer

        s = self.settings
        if self.ctx is None:   # this thread's own: the process's shared one is the main thread's
            self.ctx = new_context(s.backend)
        return Renderer(self.scene, size=s.size, integrator=integrator, params=s.params,
                        plugin_dirs=s.plugin_dirs, options=s.options, ctx=self.ctx)

    def _run(self) -> None:
        try:
            renderer = self._make(self.settings.integrator)
        except Exception as exc:  # noqa: BLE001  (shown in the widget; nothing to render)
            self.error = exc
            self.on_status(f"error: {exc}")
            self.ready.set()
            return
        self.ready.set()
        batch, last_sent = 1, 0.0
        try:
            while True:
                # Every command waiting is applied before the next batch (a drag sends many);
                # with nothing left to render, the thread sleeps until one comes.
                commands = [] if self._busy(renderer) else [self.commands.get()]
                while True:
                    try:
                        commands.append(self.commands.get_nowait())
                    except queue.Empty:
                        break
                for command in commands:
                    renderer, stop = self._apply(renderer, *command)
                    if stop:
                        return
                if commands:
                    batch, last_sent = 1, 0.0   # the first frame after a change goes out at once
                    continue
                n = min(batch, self.settings.spp - renderer.stats.spp)
                start = time.perf_counter()
                renderer.render(spp=n, readback=False)
                took = time.perf_counter() - start
                batch = max(1, min(64, int(batch * BATCH_SECONDS / max(took, 1e-4))))
                now = time.perf_counter()
                if now - last_sent >= FRAME_INTERVAL or not self._busy(renderer):
                    self.frames += 1
                    self.on_frame(renderer.display(), renderer.stats)
                    last_sent = now
        finally:
            renderer.release()
            self.ctx.release()

    def _busy(self, renderer) -> bool:
        return renderer.stats.spp < self.settings.spp

    def _apply(self, renderer, kind: str, value):
        """One command; the renderer to go on with, and whether to stop."""
        if kind == "stop":
            return renderer, True
        if kind == "camera":
            renderer.set_camera(value)
        elif kind == "spp":
            self.settings.spp = max(1, value)
            if renderer.stats.spp > self.settings.spp:   # fewer than rendered: start again
                renderer.reset()
        elif kind == "integrator":
            try:
                made = self._make(value)
            except Exception as exc:  # noqa: BLE001  (a student's plugin may fail any way)
                self.on_status(f"error: {value}: {exc}")
                return renderer, False
            made.set_camera(renderer.scene.camera)
            renderer.release()
            renderer = made
            self.settings.integrator = value
        self.on_status("")
        return renderer, False
