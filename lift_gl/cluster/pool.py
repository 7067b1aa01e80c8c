"""The Ray side: actors, and the tasks given to them.

One RenderWorker actor per GPU of the cluster (or per CPU where it has none). The pool hands
a task to an idle actor itself rather than queueing them all in Ray, so that it knows when
each started: a task past its time limit gets its actor killed (verdict `timeout`) and a new
actor started. A task whose actor died (its machine lost, its process killed, a driver crash)
runs again on another actor, up to `retries` times; after that it fails with the reason.
Results come back through `on_result` as they arrive, in the order they finish.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

from ..errors import LiftError
from .options import ExecutorSettings

POLL_SECONDS = 0.2
NO_WORKER_SECONDS = 120.0   # no live actor for this long: the cluster is gone


@dataclass
class Task:
    method: str                 # a RenderWorker method
    args: tuple
    limit: float                # seconds, from the moment an actor takes it
    key: object = None          # the caller's name for it
    affinity: object = None     # tasks of equal affinity prefer the actor that ran one (its renderer)
    attempts: int = 0
    lost: list = field(default_factory=list)   # why earlier attempts failed


@dataclass
class Outcome:
    status: str                 # ok, timeout, lost
    value: object = None
    message: str = ""
    seconds: float = 0.0


def connect(settings: ExecutorSettings, log=print):
    """ray.init to the head at settings.address (or a local Ray of this machine's when None)."""
    try:
        import ray
    except ImportError:
        raise LiftError("--executor ray needs Ray: pip install 'lift-gl[cluster]'") from None
    if not ray.is_initialized():
        kwargs = {"address": settings.address} if settings.address else {}
        try:
            ray.init(**kwargs, logging_level="warning", log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise LiftError(f"cannot join the Ray cluster at {settings.address or '(local)'}: {exc}") from None
    return ray


class Pool:
    def __init__(self, settings: ExecutorSettings, backend: str = "auto", log=print):
        from .worker import RenderWorker

        self.ray = ray = connect(settings, log)
        resources = ray.cluster_resources()
        gpus = int(resources.get("GPU", 0))
        self.per_actor = {"num_gpus": 1} if gpus else {"num_cpus": 1}
        count = settings.workers or gpus or int(resources.get("CPU", 1))
        self.actor_class = ray.remote(max_restarts=0)(RenderWorker)
        self.backend, self.settings, self.log = backend, settings, log
        self.actors = {}            # id -> (handle, ready ref or None when ready)
        self.affinity = {}          # id -> affinities it has run
        self._next_id = 0
        for _ in range(max(1, count)):
            self._start_actor()
        log(f"ray: {count} workers, one a {'GPU' if gpus else 'CPU'} ({resources.get('CPU', 0):g} CPUs, "
            f"{gpus} GPUs in the cluster)")

    def _start_actor(self) -> None:
        handle = self.actor_class.options(**self.per_actor).remote(self.backend)
        self.actors[self._next_id] = [handle, handle.where.remote()]
        self.affinity[self._next_id] = set()
        self._next_id += 1

    def _replace(self, actor_id: int, kill: bool) -> None:
        handle = self.actors.pop(actor_id)[0]
        self.affinity.pop(actor_id, None)
        if kill:
            try:
                self.ray.kill(handle, no_restart=True)
            except Exception:  # noqa: BLE001  (already gone)
                pass
        self._start_actor()

    def where(self) -> list[dict]:
        """Where each actor runs (pid, host), once it has started."""
        return [self.ray.get(handle.where.remote()) for handle, _ in self.actors.values()]

    def run(self, tasks: list[Task], on_result) -> None:
        """Every task run once (or given up on); on_result(task, Outcome) as each ends."""
        ray = self.ray
        from ray.exceptions import RayActorError, RayError, RayTaskError

        pending = deque(tasks)
        running = {}                 # ref -> (actor id, task, started)
        busy = set()
        last_alive = time.monotonic()
        while pending or running:
            # actors that finished starting
            for actor_id, entry in list(self.actors.items()):
                if entry[1] is not None:
                    done, _ = ray.wait([entry[1]], timeout=0)
                    if done:
                        try:
                            where = ray.get(done[0])
                            entry[1] = None
                            self.log(f"ray: worker {actor_id} ready on {where['host']} (pid {where['pid']})")
                        except RayError:
                            self._replace(actor_id, kill=True)
            idle = [a for a, e in self.actors.items() if e[1] is None and a not in busy]
            if idle or running:
                last_alive = time.monotonic()
            elif time.monotonic() - last_alive > NO_WORKER_SECONDS:
                raise LiftError(f"no Ray worker has been alive for {NO_WORKER_SECONDS:g} s: the cluster is gone")
            for actor_id in idle:
                if not pending:
                    break
                task = self._pick(pending, actor_id)
                handle = self.actors[actor_id][0]
                ref = getattr(handle, task.method).remote(*task.args)
                running[ref] = (actor_id, task, time.monotonic())
                busy.add(actor_id)
                if task.affinity is not None:
                    self.affinity[actor_id].add(task.affinity)
            if not running:
                time.sleep(POLL_SECONDS)
                continue
            done, _ = ray.wait(list(running), num_returns=1, timeout=POLL_SECONDS)
            for ref in done:
                actor_id, task, started = running.pop(ref)
                busy.discard(actor_id)
                seconds = time.monotonic() - started
                try:
                    value = ray.get(ref)
                except RayTaskError as exc:   # lift-gl's own failure: not the plugin's, not the machine's
                    on_result(task, Outcome("lost", message=f"the task failed: {exc}", seconds=seconds))
                    continue
                except (RayActorError, RayError) as exc:
                    self._replace(actor_id, kill=True)
                    task.attempts += 1
                    task.lost.append(type(exc).__name__)
                    if task.attempts <= self.settings.retries:
                        self.log(f"ray: a worker was lost ({type(exc).__name__}); its task runs again "
                                 f"(attempt {task.attempts + 1})")
                        pending.appendleft(task)
                    else:
                        on_result(task, Outcome("lost", message=f"the render process died {task.attempts} times "
                                                                f"({', '.join(task.lost)})", seconds=seconds))
                    continue
                on_result(task, Outcome("ok", value, seconds=seconds))
            now = time.monotonic()
            for ref, (actor_id, task, started) in list(running.items()):
                if now - started > task.limit:
                    running.pop(ref)
                    busy.discard(actor_id)
                    self._replace(actor_id, kill=True)
                    on_result(task, Outcome("timeout", message=f"no result after {task.limit:g} s",
                                            seconds=now - started))

    def _pick(self, pending: deque, actor_id: int) -> Task:
        """The first task this actor has a renderer for, else the first."""
        mine = self.affinity.get(actor_id, ())
        for i, task in enumerate(pending):
            if task.affinity is not None and task.affinity in mine:
                del pending[i]
                return task
        return pending.popleft()

    def close(self) -> None:
        for handle, _ in self.actors.values():
            try:
                self.ray.kill(handle, no_restart=True)
            except Exception:  # noqa: BLE001
                pass
        self.actors.clear()
