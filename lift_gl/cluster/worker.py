"""RenderWorker: what a Ray actor holds on one GPU (or CPU slot): a GL context made in its
own process, and the renderers it made, kept so that the next seeds of the same plugin and
scene reuse the compiled shaders. Plain Python: pool.py makes it a Ray actor."""
from __future__ import annotations

import os
import socket
import time
import traceback
from collections import OrderedDict
from pathlib import Path

import numpy as np

KEPT_RENDERERS = 4   # renderers (plugin x scene) kept per worker, least recently used dropped


class RenderWorker:
    def __init__(self, backend: str = "auto"):
        self.backend = backend
        self.ctx = None
        self.renderers: OrderedDict = OrderedDict()

    def where(self) -> dict:
        """This worker's process and machine (for the log, and for tests that stop one)."""
        return {"pid": os.getpid(), "host": socket.gethostname()}

    def _context(self):
        if self.ctx is None:   # made on the thread that runs the tasks
            from ..gl.context import create_context

            self.ctx = create_context(self.backend)
        return self.ctx

    def _renderer(self, key, make):
        if key in self.renderers:
            self.renderers.move_to_end(key)
            return self.renderers[key]
        renderer = make()
        self.renderers[key] = renderer
        while len(self.renderers) > KEPT_RENDERERS:
            _, old = self.renderers.popitem(last=False)
            old.release()
        return renderer

    # ---- grading: one plugin, one scene, some seeds ----
    def grade_seeds(self, packed_plugin: dict, scene_key: str, scene, spec: dict) -> dict:
        """The renders of spec["seeds"] (K, H, W, 3) and what they said, as the grading worker
        (lift_gl/grade/worker.py) reports them: status ok, or error with its message."""
        from ..errors import LiftError
        from .shipping import digest, unpack_folder

        folder = unpack_folder(packed_plugin)
        key = ("grade", digest(packed_plugin), scene_key, tuple(spec["size"]),
               repr(sorted((spec.get("params") or {}).items())), tuple(spec.get("options") or ()))
        start = time.perf_counter()
        try:
            images, info = self._grade(str(folder), key, scene, spec)
        except LiftError as exc:
            self._forget(key)
            info = {"status": "error", "message": str(exc)}
            images = None
        except Exception as exc:  # noqa: BLE001  (a student's plugin may break anything: say what)
            self._forget(key)
            frame = traceback.extract_tb(exc.__traceback__)[-1]
            info = {"status": "error", "message": f"{type(exc).__name__}: {exc} "
                                                  f"(in lift-gl's {Path(frame.filename).name}:{frame.lineno})"}
            images = None
        info["message"] = info.get("message", "").replace(str(folder), packed_plugin["origin"])
        info["task_seconds"] = time.perf_counter() - start
        return {"images": images, "info": info}

    def _grade(self, folder: str, key, scene, spec: dict):
        from ..image_checks import check_image
        from ..options import parse_options
        from ..renderer import Renderer

        seeds = list(spec["seeds"])
        start = time.perf_counter()
        fresh = key not in self.renderers
        renderer = self._renderer(key, lambda: Renderer(
            scene, size=tuple(spec["size"]), integrator=folder, seed=seeds[0], params=spec.get("params") or {},
            ctx=self._context(), options=parse_options(spec.get("options") or ())))
        compile_seconds = time.perf_counter() - start if fresh else 0.0
        images, dropped, warnings, render_seconds = [], 0, [], 0.0
        for i, seed in enumerate(seeds):
            renderer.reset(seed=seed)
            image = renderer.render(spp=spec["spp"])
            render_seconds += renderer.stats.render_seconds
            dropped += renderer.stats.dropped_samples
            images.append(image)
            if i == 0 and spec.get("check_first", True):
                warnings = [w.as_dict() for w in check_image(image, renderer.stats)]
        w, h = spec["size"]
        samples = spec["spp"] * len(seeds) * w * h
        info = {"status": "ok", "plugin": renderer.plugin.name, "compile_seconds": compile_seconds,
                "render_seconds": render_seconds, "seconds": time.perf_counter() - start, "dropped_samples": dropped,
                "dropped_fraction": dropped / samples if samples else 0.0, "warnings": warnings,
                "spp": spec["spp"], "seeds": seeds, "size": list(spec["size"])}
        return np.stack(images).astype(np.float32), info

    def _forget(self, key) -> None:
        renderer = self.renderers.pop(key, None)
        if renderer is not None:
            try:
                renderer.release()
            except Exception:  # noqa: BLE001  (a broken renderer is dropped either way)
                pass

    # ---- compare: one configuration, one seed ----
    def compare_run(self, session, config, seed: int, reference, keep_images: bool):
        """Session.run (lift_gl/report/compare.py) here, on this worker's context."""
        self._context()
        return session.run(config, seed, reference, keep_images)

    # ---- the denoiser's training data: one scene ----
    def training_example(self, seed: int, size, ref_spp: int, sampling: str) -> dict:
        """One training scene's arrays (lift_gl/denoise/train/render_data.py example_arrays),
        rendered on this worker's context; the driver writes them. {"failed": why} for an
        incomplete render, which the data set leaves out."""
        from ..denoise.train.render_data import SPP_LEVELS, IncompleteRender, example_arrays, render_views
        from ..denoise.train.scenes import random_scene

        try:
            noisy, albedo, normal, reference, dropped = render_views(
                random_scene(seed), tuple(size), SPP_LEVELS, ref_spp, seed, self._context(), sampling=sampling)
        except IncompleteRender as exc:
            return {"failed": str(exc)}
        return {"arrays": example_arrays(noisy, albedo, normal, reference), "dropped": dropped}
