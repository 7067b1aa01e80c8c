"""A child process that renders one plugin on grading scenes, seed after seed.

    python -m lift_gl.grade.worker JOB.json

The job names the plugin, the scenes (path, size, spp, seeds, params, the renderer's options as
KEY=VALUE) and an output folder.
For each scene the worker writes NAME.started (the parent's clock for the timeout starts
there), then NAME.npz (the renders: float32 K x H x W x 3) and NAME.json (status "ok", or
"error" with the message naming the student's file and line). A crash of the GL driver or an
endless shader takes only this process down: the parent marks the scene and goes on. The
plugin's shaders are compiled once per scene; each seed after the first only restarts the
accumulation.
"""
from __future__ import annotations

import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np


def render_scene(plugin: str, spec: dict, ctx=None) -> tuple[np.ndarray, dict]:
    """The seeds' images (K, H, W, 3) and what the renders said (time, dropped samples,
    warnings about the images)."""
    from ..image_checks import check_image
    from ..options import parse_options
    from ..renderer import Renderer
    from ..scene.loader import load_scene

    scene = load_scene(spec["path"])
    size = tuple(spec["size"])
    seeds = list(spec["seeds"])
    start = time.perf_counter()
    renderer = Renderer(scene, size=size, integrator=plugin, seed=seeds[0], params=spec.get("params") or {}, ctx=ctx,
                        options=parse_options(spec.get("options") or ()))
    compile_seconds = time.perf_counter() - start
    images, dropped, warnings = [], 0, []
    render_seconds = 0.0
    try:
        for i, seed in enumerate(seeds):
            if i:
                renderer.reset(seed=seed)
            image = renderer.render(spp=spec["spp"])
            render_seconds += renderer.stats.render_seconds
            dropped += renderer.stats.dropped_samples
            images.append(image)
            if i == 0:  # the first seed speaks for all: the checks look at one render
                warnings = [w.as_dict() for w in check_image(image, renderer.stats)]
        name = renderer.plugin.name
    finally:
        renderer.release()
    samples = spec["spp"] * len(seeds) * size[0] * size[1]
    info = {"status": "ok", "plugin": name, "compile_seconds": compile_seconds, "render_seconds": render_seconds,
            "seconds": time.perf_counter() - start, "dropped_samples": dropped,
            "dropped_fraction": dropped / samples if samples else 0.0, "warnings": warnings,
            "spp": spec["spp"], "seeds": seeds, "size": list(size)}
    return np.stack(images).astype(np.float32), info


def run_job(job: dict) -> None:
    from ..errors import LiftError

    out = Path(job["out"])
    out.mkdir(parents=True, exist_ok=True)
    for spec in job["scenes"]:
        name = spec["name"]
        (out / f"{name}.started").write_text(str(time.time()))
        try:
            images, info = render_scene(job["plugin"], spec)
        except LiftError as exc:
            info = {"status": "error", "message": str(exc)}
        except Exception as exc:  # a student's plugin may break anything: say what, go on
            frame = traceback.extract_tb(exc.__traceback__)[-1]
            info = {"status": "error", "message": f"{type(exc).__name__}: {exc} "
                                                  f"(in lift-gl's {Path(frame.filename).name}:{frame.lineno})"}
        else:
            tmp = out / f"{name}.tmp.npz"
            np.savez(tmp, images=images)
            tmp.replace(out / f"{name}.npz")
        (out / f"{name}.json.tmp").write_text(json.dumps(info))
        (out / f"{name}.json.tmp").replace(out / f"{name}.json")


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    job = json.loads(Path(argv[0]).read_text())
    run_job(job)
    return 0


if __name__ == "__main__":
    sys.exit(main())
