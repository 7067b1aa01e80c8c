"""Grading on the pool: each submission x scene x group of seeds is one task; the groups'
renders are put back together, seed order kept, into the SceneRun that one process would have
made (lift_gl/grade/runner.py), so the verdicts are computed the same way from the same images.
"""
from __future__ import annotations

from ..grade.runner import SceneRun
from .pool import Pool, Task
from .shipping import pack_folder


class _Scene:
    """The pieces of one submission's scene as they come back."""

    def __init__(self, parts: int):
        self.parts = [None] * parts
        self.failed: SceneRun | None = None

    @property
    def done(self) -> bool:
        return self.failed is not None or all(p is not None for p in self.parts)

    def run(self) -> SceneRun:
        if self.failed is not None:
            return self.failed
        import numpy as np

        infos = [p["info"] for p in self.parts]
        images = np.concatenate([p["images"] for p in self.parts])
        first = infos[0]
        dropped = sum(i["dropped_samples"] for i in infos)
        w, h = first["size"]
        samples = first["spp"] * images.shape[0] * w * h
        info = dict(first, seeds=[s for i in infos for s in i["seeds"]], dropped_samples=dropped,
                    dropped_fraction=dropped / samples if samples else 0.0,
                    render_seconds=sum(i["render_seconds"] for i in infos),
                    compile_seconds=sum(i["compile_seconds"] for i in infos),
                    seconds=sum(i["seconds"] for i in infos))
        return SceneRun("ok", images=images, info=info, seconds=sum(i["task_seconds"] for i in infos))


class GradePool:
    """`run_plugins` as lift_gl/grade/grading.py calls it, on a Ray pool."""

    def __init__(self, pool: Pool, seeds_per_task: int):
        self.pool, self.seeds_per_task = pool, seeds_per_task
        self._scenes = {}   # scene path -> (key, object ref of the loaded Scene)

    def _scene(self, path):
        from ..scene.loader import load_scene

        path = str(path)
        if path not in self._scenes:
            # Loaded here and sent once: the workers need not have the scene's files.
            self._scenes[path] = (path, self.pool.ray.put(load_scene(path)))
        return self._scenes[path]

    def run_plugins(self, jobs: list[tuple[str, str, list[dict]]], timeout: float, on_done) -> None:
        """jobs: (name, plugin folder or name, scene specs); on_done(name, {scene: SceneRun})
        once all of a job's scenes are back."""
        from ..plugins import find_plugin

        tasks, state = [], {}
        for name, plugin, specs in jobs:
            packed = pack_folder(find_plugin(plugin).folder)
            state[name] = {}
            for spec in specs:
                seeds = spec["seeds"]
                groups = [seeds[i:i + self.seeds_per_task] for i in range(0, len(seeds), self.seeds_per_task)]
                state[name][spec["name"]] = _Scene(len(groups))
                scene_key, scene_ref = self._scene(spec["path"])
                for index, group in enumerate(groups):
                    part = dict(spec, seeds=group, check_first=index == 0)
                    tasks.append(Task("grade_seeds", (packed, scene_key, scene_ref, part), limit=timeout,
                                      key=(name, spec["name"], index), affinity=(name, spec["name"])))
        finished = set()

        def on_result(task, outcome):
            name, scene, index = task.key
            piece = state[name][scene]
            if piece.done:
                return
            if outcome.status == "timeout":
                piece.failed = SceneRun("timeout", message=outcome.message, seconds=outcome.seconds)
            elif outcome.status == "lost":
                piece.failed = SceneRun("error", message=outcome.message, seconds=outcome.seconds)
            elif outcome.value["info"]["status"] != "ok":
                info = outcome.value["info"]
                piece.failed = SceneRun("error", info=info, message=info.get("message", ""),
                                        seconds=info.get("task_seconds", outcome.seconds))
            else:
                piece.parts[index] = outcome.value
            if name not in finished and all(p.done for p in state[name].values()):
                finished.add(name)
                on_done(name, {scene: p.run() for scene, p in state[name].items()})

        # Tasks of a scene that already failed still run (the pool does not take tasks back):
        # their results are ignored.
        self.pool.run(tasks, on_result)
