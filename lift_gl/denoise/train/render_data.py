"""Training pairs rendered with the project's own `pt` through lift_gl.renderer.Renderer.

For one scene: noisy radiance at each of SPP_LEVELS (snapshots of one accumulation, one sample
a frame so that each sample has its own subpixel jitter), the albedo and normal guides
(Renderer.aov), and a high-spp target from an independent seed. Everything is stored already
in the network's terms (lift_gl/denoise/model_io.py): demodulated colour without the exposure
(the exposure of each level is stored beside it), the demodulated target, and the divisor
that remodulates (so that the loss can compare radiance).

A scene's noisy inputs come from one of SAMPLINGS: `pt`'s independent random numbers (the
default), or its coherent sampling, whose noise is correlated in blocks (tiles of adjacent
pixels, or with interleave 2 every other pixel): a denoiser trained on independent noise only
takes such a block for a feature of the image (docs/denoiser.md, "Coherent noise"). The target
is the same for all.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..demodulate import safe_albedo
from ..model_io import autoexposure, clean, network_input
from .scenes import random_scene

SPP_LEVELS = (1, 2, 4, 8, 16, 32, 64)
# the renderer's options of each sampling of the noisy inputs (lift_gl/options.py)
SAMPLINGS = {"independent": (),
             "coherent": ("coherent_sampling=on", "coherent_interleave=1"),
             "interleave2": ("coherent_sampling=on", "coherent_interleave=2")}
F16_MAX = 60000.0  # stored as float16: clip the rare brighter pixel (an emitter seen directly)


class IncompleteRender(RuntimeError):
    """Some pixel's accumulated sample count is not the number of samples asked for."""


def _checked(r, spp: int, label: str) -> np.ndarray:
    """The mean so far, after checking that every pixel holds spp valid samples (on the H200 a
    reference once came back with no samples in any pixel: such an image must not be a target)."""
    count = r.accumulate.read_totals()[..., 3]
    dropped = r.buffers.read_stats()[0]
    if not np.all(np.abs(count - spp) <= 0.5 + dropped):
        raise IncompleteRender(f"{label}: sample count {count.min():.0f}..{count.max():.0f}, expected {spp}")
    return r.image()


def render_views(scene, size, spp_levels, ref_spp: int, seed: int, ctx=None, ref_spp_per_frame: int = 8,
                 sampling: str = "independent"):
    """Noisy radiance at each spp level (drawn by `sampling`, one of SAMPLINGS), albedo, normal
    and the reference radiance (float32 H x W x 3; None where ref_spp is 0)."""
    from ...options import parse_options
    from ...renderer import Renderer
    r = Renderer(scene, size=size, integrator="pt", seed=2 * seed, samples_per_frame=1, ctx=ctx,
                 options=parse_options(SAMPLINGS[sampling]))
    finish = lambda renderer, done: None  # a progress callback: the renderer then waits for each frame
    try:
        noisy, done = [], 0
        for spp in spp_levels:
            r.render(spp=spp - done, progress=finish, readback=False)
            noisy.append(_checked(r, spp, f"{spp} spp input"))
            done = spp
        albedo, normal = r.aov("albedo"), r.aov("normal")
        dropped = r.stats.dropped_samples
    finally:
        r.release()
    if ref_spp <= 0:  # the caller has the target already
        return noisy, albedo, normal, None, dropped
    # The target: a renderer of its own with an independent seed.
    ref = Renderer(scene, size=size, integrator="pt", seed=2 * seed + 1,
                   samples_per_frame=min(ref_spp_per_frame, ref_spp), ctx=ctx)
    try:
        ref.render(spp=ref_spp, progress=finish, readback=False)
        reference = _checked(ref, ref_spp, "reference")
        dropped += ref.stats.dropped_samples
    finally:
        ref.release()
    return noisy, albedo, normal, reference, dropped


def example_arrays(noisy, albedo, normal, reference) -> dict:
    """One example in the network's terms (see the module docstring), float16 C x H x W."""
    inputs, exposures = [], []
    for color in noisy:
        x, exposure = network_input(color, albedo, normal)
        inputs.append(x[0, :3] / np.float32(exposure))
        exposures.append(exposure)
    guides = x[0, 3:9]
    albedo_used = np.clip(clean(albedo), 0.0, 1.0)
    divisor = safe_albedo(albedo_used).transpose(2, 0, 1)
    target = clean(reference).transpose(2, 0, 1) / divisor
    f16 = lambda a: np.clip(a, -F16_MAX, F16_MAX).astype(np.float16)
    return {"noisy": f16(np.stack(inputs)), "guides": f16(guides), "target": f16(target),
            "divisor": f16(divisor), "exposure": np.asarray(exposures, np.float32)}


def render_example(path: Path, seed: int, size, ref_spp: int, backend: str, ctx=None,
                   sampling: str = "independent") -> str:
    """Render one scene into `path` (kept if it exists); returns a line for the log."""
    if path.exists():
        return f"scene {seed}: kept"
    if ctx is None:
        ctx = _worker_context(backend)
    noisy, albedo, normal, reference, dropped = render_views(random_scene(seed), size, SPP_LEVELS, ref_spp, seed, ctx,
                                                             sampling=sampling)
    save_example(path, example_arrays(noisy, albedo, normal, reference))
    return f"scene {seed}: {dropped} NaN/Inf samples dropped"


_CONTEXT = {}


def _worker_context(backend: str):
    """One headless GL context per process, made on first use."""
    if backend not in _CONTEXT:
        from ...gl.context import create_context
        _CONTEXT[backend] = create_context(backend)
    return _CONTEXT[backend]


def _task(args):
    path, seed, size, ref_spp, backend, deadline, sampling, render = args
    if deadline is not None and time.time() > deadline:
        return None
    try:
        return render(path, seed, size, ref_spp, backend, sampling=sampling)
    except IncompleteRender as e:  # left out of the data set, and said so
        path.with_suffix(".failed").write_text(str(e) + "\n")
        return f"scene {seed}: LEFT OUT, {e}"


def sampling_of(index: int, samplings) -> str:
    """The sampling of the index-th scene of a set: `samplings` in turn."""
    return samplings[index % len(samplings)]


def sampling_suffix(sampling: str) -> str:
    """What names a file or array of this sampling's inputs: _SAMPLING, nothing for independent
    (the shipped model's files and the benchmark's older arrays keep their names)."""
    return "" if sampling == "independent" else f"_{sampling}"


def example_path(out_dir: Path, seed: int, sampling: str) -> Path:
    """out_dir/scene_SEED[_SAMPLING].npz (sampling_suffix)."""
    return Path(out_dir) / f"scene_{seed:07d}{sampling_suffix(sampling)}.npz"


def save_example(path: Path, arrays: dict) -> None:
    """Written under a temporary name and renamed: a run cut short leaves no half file."""
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(path)


def generate(out_dir: Path, seeds, size=(256, 256), ref_spp: int = 2048, backend: str = "auto",
             log=print, workers: int = 1, minutes: float | None = None,
             samplings=("independent",), executor=None, render=render_example) -> list[Path]:
    """Render each seed's scene into out_dir/scene_SEED[_SAMPLING].npz (existing files are kept:
    resumable), the k-th seed's noisy inputs drawn by samplings[k % len(samplings)].

    With `workers` > 1 the scenes render in that many processes (one GL context each); with
    `executor` a lift_gl.cluster ExecutorSettings of kind "ray", on a Ray cluster's workers
    (the arrays come back here and are written here). With `minutes`, rendering stops after
    that long and the longest prefix of `seeds` that was rendered is returned (so that
    `--scenes len(result)` reproduces the same set). `render(path, seed, size, ref_spp, backend,
    sampling=...)` writes one file (render_example; temporal_data.render_pair for frame pairs).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    seeds = list(seeds)
    unknown = set(samplings) - set(SAMPLINGS)
    if unknown or not samplings:
        raise ValueError(f"samplings must be some of {', '.join(SAMPLINGS)}, not {', '.join(sorted(unknown)) or 'none'}")
    kinds = [sampling_of(i, samplings) for i in range(len(seeds))]
    paths = [example_path(out_dir, seed, kind) for seed, kind in zip(seeds, kinds)]
    deadline = None if minutes is None else time.time() + 60 * minutes
    tasks = [(p, seed, tuple(size), ref_spp, backend, deadline, kind, render)
             for p, seed, kind in zip(paths, seeds, kinds)]
    start = time.perf_counter()
    if executor is not None and executor.kind == "ray":
        if render is not render_example:
            raise ValueError("the Ray executor renders single-frame examples only")
        _generate_on_ray(tasks, executor, backend, log, start)
    elif workers > 1:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
            for i, line in enumerate(pool.map(_task, tasks)):
                if line is not None and ((i + 1) % 25 == 0 or i + 1 == len(tasks) or "LEFT OUT" in line):
                    log(f"data: {i + 1}/{len(tasks)} scenes, {time.perf_counter() - start:.0f} s ({line})")
    else:
        for i, task in enumerate(tasks):
            line = _task(task)
            if line is not None and ((i + 1) % 25 == 0 or i + 1 == len(tasks) or "LEFT OUT" in line):
                log(f"data: {i + 1}/{len(tasks)} scenes, {time.perf_counter() - start:.0f} s ({line})")
    done = 0
    while done < len(paths) and (paths[done].exists() or paths[done].with_suffix(".failed").exists()):
        done += 1
    failed = [p for p in paths[:done] if not p.exists()]
    if failed:
        log(f"data: {len(failed)} scenes left out (incomplete renders): {', '.join(p.stem for p in failed)}")
    return [p for p in paths[:done] if p.exists()]


RAY_SCENE_SECONDS = 1800.0   # one scene's time limit on a worker (a 256x256 scene at 2048 spp: about a minute)


def _generate_on_ray(tasks, executor, backend: str, log, start: float) -> None:
    """The scenes not rendered yet, one Ray task each, in batches of twice the workers so that
    a deadline (--data-minutes) stops the run between batches; a lost worker's scene runs again
    elsewhere (lift_gl/cluster/pool.py)."""
    from ...cluster.pool import Pool, Task

    todo = [t for t in tasks if not t[0].exists()]
    if not todo:
        return
    pool = Pool(executor, backend, log)
    done = [len(tasks) - len(todo)]
    try:
        def on_result(task, outcome):
            path = task.key
            done[0] += 1
            if outcome.status != "ok":  # not left out for good: the next (resumed) run renders it again
                log(f"data: {path.stem}: not rendered ({outcome.status}: {outcome.message})")
                return
            if "failed" in outcome.value:
                path.with_suffix(".failed").write_text(outcome.value["failed"] + "\n")
                log(f"data: {path.stem}: LEFT OUT, {outcome.value['failed']}")
                return
            save_example(path, outcome.value["arrays"])
            if done[0] % 25 == 0 or done[0] == len(tasks):
                log(f"data: {done[0]}/{len(tasks)} scenes, {time.perf_counter() - start:.0f} s (ray)")

        batch = 2 * max(1, len(pool.actors))
        for first in range(0, len(todo), batch):
            deadline = todo[first][5]
            if deadline is not None and time.time() > deadline:
                break
            pool.run([Task("training_example", (seed, size, ref_spp, sampling), RAY_SCENE_SECONDS, key=path)
                      for path, seed, size, ref_spp, _backend, _deadline, sampling, _render in todo[first:first + batch]],
                     on_result)
    finally:
        pool.close()
