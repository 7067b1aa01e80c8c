"""What every pass shares: the scene's GPU buffers, uniform setting, and GPU timers."""
from __future__ import annotations

import numpy as np

from ..scene.pack import PackedScene

# Binding points declared in shaders/lift/scene_data.glsl.
SCENE_BINDINGS = {
    "bvh_nodes": 0, "tri_pos": 1, "tri_normal": 2, "tri_uv": 3, "tri_info": 4,
    "materials": 5, "lights": 6, "spheres": 7,
}
STATS_BINDING = 8
STAT_DROPPED = 0
STAT_LOOP_LIMITED = 1  # pixel-frames cut short by the driver's loop limit (passes/trace.py)
NUM_STATS = 4
LOCAL_SIZE = 8  # compute passes run 8x8 work groups


def groups(width: int, height: int) -> tuple[int, int, int]:
    return ((width + LOCAL_SIZE - 1) // LOCAL_SIZE, (height + LOCAL_SIZE - 1) // LOCAL_SIZE, 1)


def set_uniforms(program, values: dict) -> None:
    """Set the uniforms a program kept; the compiler drops unused ones, so skip those."""
    for name, value in values.items():
        if name not in program:
            continue
        member = program[name]
        if isinstance(value, (list, tuple, np.ndarray)):
            value = tuple(float(v) for v in np.asarray(value).ravel()) if not isinstance(value, tuple) else value
            if len(value) == 16:
                member.write(np.asarray(value, np.float32).tobytes())
                continue
        member.value = value


class SceneBuffers:
    """The packed scene uploaded as SSBOs, plus the statistics counters."""

    def __init__(self, ctx, packed: PackedScene):
        self.packed = packed
        self.buffers = {name: ctx.buffer(np.ascontiguousarray(getattr(packed, name)).tobytes())
                        for name in SCENE_BINDINGS}
        self.stats = ctx.buffer(reserve=4 * NUM_STATS)
        self.reset_stats()

    def bind(self) -> None:
        for name, binding in SCENE_BINDINGS.items():
            self.buffers[name].bind_to_storage_buffer(binding)
        self.stats.bind_to_storage_buffer(STATS_BINDING)

    def uniforms(self, environment_radiance) -> dict:
        p = self.packed
        return {"u_num_triangles": p.num_triangles, "u_num_spheres": p.num_spheres,
                "u_num_lights": p.num_lights, "u_env_radiance": tuple(float(x) for x in environment_radiance)}

    def reset_stats(self) -> None:
        self.stats.write(np.zeros(NUM_STATS, np.uint32).tobytes())

    def read_stats(self) -> np.ndarray:
        return np.frombuffer(self.stats.read(), np.uint32).copy()

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()
        self.stats.release()


class GpuTimer:
    """Accumulated GPU time of one pass, from timer queries (ns)."""

    def __init__(self, ctx):
        self.query = ctx.query(time=True)
        self.total_ns = 0
        self.count = 0

    def __enter__(self):
        self.query.__enter__()
        return self

    def __exit__(self, *exc):
        self.query.__exit__(*exc)
        self.total_ns += self.query.elapsed
        self.count += 1

    @property
    def mean_ms(self) -> float:
        return self.total_ns / max(self.count, 1) / 1e6
