"""Render a plugin on the grading scenes in a child process, with a timeout per scene.

One process per submission (lift_gl/grade/worker.py) renders its scenes one after the other.
The parent watches its files: a scene that runs past the timeout gets the process killed and
the verdict `timeout`; a process that dies (a driver crash, out of memory) gives the scene it
was on an `error`; either way a new process goes on with the scenes left. Nothing a plugin
does can stop the grading of the others.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

POLL_SECONDS = 0.05


@dataclass
class SceneRun:
    status: str                     # ok, error, timeout
    images: np.ndarray | None = None  # (K, H, W, 3) float32
    info: dict | None = None
    message: str = ""
    seconds: float = 0.0            # wall time of the scene in the child, compiling included


def scene_spec(name: str, path, size, spp: int, seeds: list[int], params: dict, options=()) -> dict:
    """A child's job for one scene (grade/worker.py); `options`: KEY=VALUE (lift_gl/options.py)."""
    return {"name": name, "path": str(path), "size": list(size), "spp": int(spp), "seeds": list(seeds),
            "params": dict(params), "options": list(options)}


def _kill(process: subprocess.Popen) -> None:
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    process.wait()


def _tail(path: Path, lines: int = 6) -> str:
    try:
        text = path.read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    return " | ".join(text[-lines:])


def _died(code: int) -> str:
    if code < 0:
        try:
            return f"the render process was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"the render process was killed by signal {-code}"
    return f"the render process exited with code {code}"


def run_plugin(plugin: str, specs: list[dict], timeout: float, workdir=None) -> dict[str, SceneRun]:
    """Each spec's scene rendered by `plugin` (a name or folder); results by scene name."""
    results: dict[str, SceneRun] = {}
    pending = list(specs)
    with tempfile.TemporaryDirectory(prefix="lift-gl-grade-", dir=workdir) as tmp:
        attempt = 0
        while pending:
            attempt += 1
            out = Path(tmp) / f"run{attempt}"
            out.mkdir()
            job = out / "job.json"
            job.write_text(json.dumps({"plugin": plugin, "scenes": pending, "out": str(out)}))
            stderr = out / "stderr.txt"
            with open(stderr, "wb") as err:
                process = subprocess.Popen([sys.executable, "-m", "lift_gl.grade.worker", str(job)],
                                           stdout=subprocess.DEVNULL, stderr=err, start_new_session=True,
                                           env=dict(os.environ, PYTHONWARNINGS="ignore"))
            started = time.monotonic()  # the first scene's clock includes the process's start
            current = 0
            while True:
                code = process.poll()
                # collect the scenes the child has finished
                while current < len(pending) and (out / f"{pending[current]['name']}.json").is_file():
                    name = pending[current]["name"]
                    results[name] = _collect(out, name, time.monotonic() - started)
                    current += 1
                    started = time.monotonic()
                if current == len(pending):
                    if code is None:
                        process.wait()
                    pending = []
                    break
                if code is not None:  # died before finishing its scene
                    name = pending[current]["name"]
                    detail = _tail(stderr)
                    results[name] = SceneRun("error", message=_died(code) + (f": {detail}" if detail else ""),
                                             seconds=time.monotonic() - started)
                    pending = pending[current + 1:]
                    break
                if time.monotonic() - started > timeout:
                    _kill(process)
                    name = pending[current]["name"]
                    results[name] = SceneRun("timeout", message=f"no result after {timeout:g} s",
                                             seconds=time.monotonic() - started)
                    pending = pending[current + 1:]
                    break
                time.sleep(POLL_SECONDS)
    return results


def _collect(out: Path, name: str, seconds: float) -> SceneRun:
    info = json.loads((out / f"{name}.json").read_text())
    if info["status"] != "ok":
        return SceneRun("error", info=info, message=info.get("message", ""), seconds=seconds)
    with np.load(out / f"{name}.npz") as data:
        images = data["images"]
    return SceneRun("ok", images=images, info=info, seconds=seconds)
