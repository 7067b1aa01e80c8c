"""Grade a folder of plugins: each renders each scene with independent seeds, and its
expectation is tested against the reference's (and the analytic image where there is one).

Verdicts, per submission and scene:
- pass: consistent with the reference (it may be far noisier: the variance ratio says how much);
- biased: the expectation differs; z is the signed size of the difference in standard errors
  (z > 0 too bright), the picture shows where;
- error: the plugin does not compile, or its render crashed (the message names the file and line);
- timeout: no result within the timeout.

Each scene's tests run at alpha / (number of scenes), halved again where an analytic image
is tested too, so that a correct submission fails anywhere with probability at most alpha.
"""
from __future__ import annotations

import csv
import hashlib
import json
import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import LiftError
from .runner import SceneRun, run_plugin, scene_spec
from .scenes import GradeScene, analytic_image, resolve_scene
from .settings import GradeSettings

VERDICTS = ("pass", "biased", "error", "timeout")
CSV_COLUMNS = ("submission", "scene", "verdict", "z", "variance_ratio", "seconds", "message", "bias_percent",
               "resolution_percent", "dropped_fraction", "spp", "seeds")
REPO = Path(__file__).resolve().parent.parent.parent
CACHE_FORMAT = "1"


@dataclass
class Grade:
    submission: str
    scene: str
    verdict: str
    z: float = math.nan
    variance_ratio: float = math.nan
    seconds: float = 0.0
    message: str = ""
    bias: float = math.nan          # relative difference of the image's mean luminance
    resolution: float = math.nan    # relative bias the test would have seen
    dropped_fraction: float = 0.0
    picture: str | None = None      # relative to the output folder
    warnings: list = field(default_factory=list)

    def row(self, settings: GradeSettings) -> dict:
        def number(v, spec=".4g"):
            return "" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)

        return {"submission": self.submission, "scene": self.scene, "verdict": self.verdict, "z": number(self.z, ".3f"),
                "variance_ratio": number(self.variance_ratio, ".3g"), "seconds": number(self.seconds, ".2f"),
                "message": self.message, "bias_percent": number(100 * self.bias, ".3f"),
                "resolution_percent": number(100 * self.resolution, ".3f"),
                "dropped_fraction": number(self.dropped_fraction, ".3g"), "spp": settings.spp, "seeds": settings.seeds}


@dataclass
class ReferenceRun:
    """The reference's renders of one scene, and the analytic image if the scene has one."""
    scene: GradeScene
    images: np.ndarray            # (K, H, W, 3)
    analytic: np.ndarray | None
    info: dict
    analytic_check: object = None  # the reference itself against the analytic image


def find_submissions(folder) -> list[Path]:
    """Folders holding a plugin.toml: the folder's subfolders, or their subfolders (a student's
    folder holding their plugin)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise LiftError("the submissions folder does not exist", folder)
    found = sorted(p.parent for p in folder.glob("*/plugin.toml"))
    found += sorted(p.parent for p in folder.glob("*/*/plugin.toml") if p.parent.parent not in found)
    return sorted(set(found))


# ---- the reference, cached ----
def _digest(h, value) -> None:
    """Feed a scene's dataclasses, arrays and numbers into a hash, deterministically."""
    import dataclasses

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(type(value).__name__.encode())
        for f in dataclasses.fields(value):
            if f.name in ("path", "source"):
                continue  # where it was read from does not change the image
            h.update(f.name.encode())
            _digest(h, getattr(value, f.name))
    elif isinstance(value, np.ndarray):
        h.update(f"{value.dtype}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        h.update(f"[{len(value)}".encode())
        for v in value:
            _digest(h, v)
    elif isinstance(value, dict):
        for k in sorted(value, key=str):
            h.update(str(k).encode())
            _digest(h, value[k])
    else:
        h.update(repr(value).encode())


def _files_digest(h, folder: Path, pattern: str = "**/*") -> None:
    for path in sorted(p for p in folder.glob(pattern) if p.is_file() and "__pycache__" not in p.parts):
        h.update(str(path.relative_to(folder)).encode())
        h.update(path.read_bytes())


def reference_key(settings: GradeSettings, scene: GradeScene, plugin: str) -> str:
    """What the reference's renders depend on: the scene as loaded, the reference plugin's
    files, the shader library and trace host, and the settings."""
    from ..plugins import find_plugin
    from ..scene.loader import load_scene

    h = hashlib.sha256(f"lift-gl grade reference {CACHE_FORMAT}\n".encode())
    _digest(h, load_scene(scene.path))
    _files_digest(h, find_plugin(plugin).folder)
    _files_digest(h, REPO / "shaders")
    _files_digest(h, REPO / "lift_gl" / "passes", "*.py")
    h.update(json.dumps({"size": list(settings.size), "spp": settings.spp,
                         "seeds": settings.reference_seed_list, "params": settings.params,
                         **({"options": list(settings.options)} if settings.options else {})}, sort_keys=True).encode())
    return h.hexdigest()[:32]


def _cache_dir(settings: GradeSettings) -> Path:
    from ..accel.cache import default_cache_dir

    return Path(settings.cache_dir) if settings.cache_dir is not None else default_cache_dir().parent / "grade"


def reference_runs(settings: GradeSettings, scenes: list[GradeScene], log=print, cluster=None) -> dict[str, ReferenceRun]:
    """The reference's renders of every scene: from the cache, or rendered now (in a child
    process, as a submission, or on the cluster). A reference that fails stops the grading:
    nothing can be judged."""
    plugin = settings.reference_plugin()
    folder = _cache_dir(settings)
    out, missing = {}, []
    for scene in scenes:
        key = reference_key(settings, scene, plugin)
        cached = _load_cached(folder, key, settings)
        if cached is not None:
            out[scene.name] = ReferenceRun(scene, cached[0], None, dict(cached[1], cached=True))
        else:
            missing.append((scene, key))
    if missing:
        log(f"rendering the reference ({plugin}) on {', '.join(s.name for s, _ in missing)}: "
            f"{settings.reference_seeds} seeds x {settings.spp} spp (cached afterwards)")
        specs = [scene_spec(s.name, s.path, settings.size, settings.spp, settings.reference_seed_list,
                            settings.params, settings.options) for s, _ in missing]
        timeout = settings.timeout * settings.reference_seeds / settings.seeds
        if cluster is None:
            runs = run_plugin(plugin, specs, timeout=timeout)
        else:  # tasks of a few seeds each: a task's time limit is a submission's scene's
            got = {}
            cluster.run_plugins([("reference", plugin, specs)], settings.timeout, lambda _, r: got.update(r))
            runs = got
        for scene, key in missing:
            run = runs[scene.name]
            if run.status != "ok":
                raise LiftError(f"the reference {plugin!r} failed on {scene.name} ({run.status}): {run.message}")
            if run.info.get("dropped_fraction", 0) > 1e-3 or not np.isfinite(run.images).all():
                raise LiftError(f"the reference {plugin!r} dropped {100 * run.info['dropped_fraction']:.2f}% of "
                                f"its samples on {scene.name}: it cannot be the reference")
            info = dict(run.info, key=key, created=time.strftime("%Y-%m-%d %H:%M:%S"), cached=False)
            _store(folder, key, run.images, info)
            out[scene.name] = ReferenceRun(scene, run.images, None, info)
    from ..scene.loader import load_scene

    for run in out.values():
        # A plugin setting (only_bounce, max_depth=0, ...) may change the expected image: then
        # the analytic one does not apply, and the reference alone is the answer.
        run.analytic = None if settings.params else analytic_image(load_scene(run.scene.path), settings.size)
    return out


def _store(folder: Path, key: str, images: np.ndarray, info: dict) -> None:
    import os
    import tempfile

    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".npz")
        with os.fdopen(fd, "wb") as f:
            np.savez(f, images=images, info=json.dumps(info))
        os.replace(tmp, folder / f"{key}.npz")
    except OSError:
        pass  # a cache that cannot be written only costs time


def _load_cached(folder: Path, key: str, settings: GradeSettings):
    try:
        with np.load(folder / f"{key}.npz", allow_pickle=False) as data:
            images, info = data["images"], json.loads(str(data["info"]))
    except (OSError, ValueError, KeyError):
        return None
    w, h = settings.size
    if images.shape != (settings.reference_seeds, h, w, 3) or not np.isfinite(images).all():
        return None
    return images, info


# ---- one verdict ----
def judge(name: str, scene: str, run: SceneRun, reference: ReferenceRun, settings: GradeSettings,
          alpha: float) -> tuple[Grade, dict]:
    """The verdict of one submission's renders of one scene, and what its picture needs."""
    from ..consistency import Blocks, Estimate, compare_estimates

    if run.status != "ok":
        return Grade(name, scene, run.status, seconds=run.seconds, message=run.message), {}
    images = run.images
    info = run.info or {}
    warnings = [w["message"] for w in info.get("warnings", [])]
    dropped = float(info.get("dropped_fraction", 0.0))
    if not np.isfinite(images).all():
        return Grade(name, scene, "error", seconds=run.seconds, dropped_fraction=dropped, warnings=warnings,
                     message="the image holds NaN or infinite values"), {}
    h, w = images.shape[1:3]
    blocks = Blocks.grid(h, w, settings.block)
    spp = settings.spp
    estimate = Estimate.from_seeds(images, blocks, spp)
    ref_estimate = Estimate.from_seeds(reference.images, blocks, spp)
    level = alpha / 2.0 if reference.analytic is not None else alpha
    against_ref = compare_estimates(estimate, ref_estimate, level, settings.tolerance, settings.block_tolerance)
    checks = [("the reference", against_ref)]
    if reference.analytic is not None:
        known = Blocks.grid(h, w, settings.block, mask=np.isfinite(reference.analytic).all(axis=-1))
        exact = Estimate.exact(reference.analytic, known)
        checks.append(("the analytic answer", compare_estimates(Estimate.from_seeds(images, known, spp), exact,
                                                                 level, settings.tolerance, settings.block_tolerance)))
    failed = [(what, c) for what, c in checks if not c.consistent]
    shown_what, shown = max(failed, key=lambda wc: abs(wc[1].z)) if failed else checks[0]
    if failed:
        verdict = "biased"
        message = f"against {shown_what}: {shown.sentence()}"
        if len(failed) > 1:
            message += f"; also against {failed[1 - failed.index((shown_what, shown))][0]}"
    else:
        verdict = "pass"
        message = (f"consistent with {' and '.join(what for what, _ in checks)}: a bias of "
                   f"{100 * shown.resolution:.2g}% or more would have been seen; "
                   f"{against_ref.variance_ratio:.3g}x the reference's variance per sample")
    if warnings:
        message += "; " + "; ".join(warnings)
    grade = Grade(name, scene, verdict, z=shown.z, variance_ratio=against_ref.variance_ratio, seconds=run.seconds,
                  message=message, bias=shown.bias, resolution=against_ref.resolution, dropped_fraction=dropped,
                  warnings=warnings)
    picture = {"mean": images.mean(axis=0), "reference": reference.images.mean(axis=0),
               "block_z": shown.block_z, "block_bias": shown.block_bias, "block": settings.block, "title": f"{name} on {scene}: {verdict}",
               "z": shown.z, "bias": shown.bias}
    return grade, picture


def check_reference(reference: ReferenceRun, settings: GradeSettings, alpha: float):
    """The reference against the analytic image: a reference that fails here is wrong itself."""
    from ..consistency import Blocks, Estimate, compare_estimates

    if reference.analytic is None:
        return None
    h, w = reference.images.shape[1:3]
    known = Blocks.grid(h, w, settings.block, mask=np.isfinite(reference.analytic).all(axis=-1))
    return compare_estimates(Estimate.from_seeds(reference.images, known, settings.spp),
                             Estimate.exact(reference.analytic, known), alpha, settings.tolerance,
                             settings.block_tolerance)


# ---- the whole class ----
def grade(submissions, settings: GradeSettings | None = None, out=None, log=print, executor=None) -> list[Grade]:
    """Grade every plugin folder under `submissions`; writes OUT/grades.csv (as results
    arrive), OUT/report.md and OUT/pictures/ when `out` is given. Returns the grades.
    executor: lift_gl.cluster.options.ExecutorSettings (None: this machine; "ray": a Ray
    cluster's workers, lift_gl/cluster/)."""
    settings = settings or GradeSettings()
    cluster = None
    if executor is not None and executor.kind == "ray":
        from ..cluster.grade_tasks import GradePool
        from ..cluster.pool import Pool

        cluster = GradePool(Pool(executor, backend="auto", log=log), executor.seeds_per_task)
    try:
        return _grade(submissions, settings, out, log, cluster)
    finally:
        if cluster is not None:
            cluster.pool.close()


def _grade(submissions, settings: GradeSettings, out, log, cluster) -> list[Grade]:
    from . import report

    folders = find_submissions(submissions)
    if not folders:
        raise LiftError("no submissions: no subfolder holds a plugin.toml", submissions)
    scenes = [resolve_scene(s, settings.base) for s in settings.scenes]
    names = [s.name for s in scenes]
    if len(set(names)) != len(names):
        raise LiftError(f"two grading scenes share a name: {', '.join(names)}")
    started = time.time()
    references = reference_runs(settings, scenes, log=log, cluster=cluster)
    alpha_scene = settings.alpha / len(scenes)
    for ref in references.values():
        ref.analytic_check = check_reference(ref, settings, alpha_scene)
    out = Path(out) if out is not None else None
    writer = report.Writer(out, settings) if out is not None else None
    lock = threading.Lock()
    root = Path(submissions)
    grades: list[Grade] = []
    timings: dict[str, float] = {}

    specs = [scene_spec(s.name, s.path, settings.size, settings.spp, settings.submission_seeds, settings.params,
                        settings.options) for s in scenes]

    def one(folder: Path):
        name = str(folder.relative_to(root))
        start = time.perf_counter()
        runs = run_plugin(str(folder.resolve()), specs, settings.timeout)
        timings[name] = time.perf_counter() - start
        judged(name, runs)

    def judged(name: str, runs: dict[str, SceneRun]):
        timings.setdefault(name, sum(r.seconds for r in runs.values()))
        results = []
        for s in scenes:
            grade_, picture = judge(name, s.name, runs[s.name], references[s.name], settings, alpha_scene)
            if writer is not None and picture:
                grade_.picture = writer.picture(grade_, picture)
            results.append(grade_)
        with lock:
            grades.extend(results)
            if writer is not None:
                writer.rows(results)
            log(f"{name}: " + ", ".join(f"{g.scene} {g.verdict}" + (f" (z = {g.z:+.1f})" if g.verdict == "biased" else "")
                                        for g in results) + f"  [{timings[name]:.1f} s]")

    if cluster is not None:
        cluster.run_plugins([(str(f.relative_to(root)), str(f.resolve()), specs) for f in folders], settings.timeout,
                            judged)
    else:
        with ThreadPoolExecutor(max_workers=settings.jobs) as pool:
            for f in [pool.submit(one, folder) for folder in folders]:
                f.result()
    order = {str(f.relative_to(root)): i for i, f in enumerate(folders)}
    grades.sort(key=lambda g: (order[g.submission], names.index(g.scene)))
    if writer is not None:
        writer.finish(grades, references, timings, time.time() - started, submissions)
    return grades
