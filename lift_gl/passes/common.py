"""What every pass shares: the scene's GPU buffers, uniform setting, and GPU timers."""
from __future__ import annotations

import time

import numpy as np

from ..scene.pack import PackedScene, still_motion

# Binding points declared in shaders/lift/scene_data.glsl.
SCENE_BINDINGS = {
    "bvh_nodes": 0, "tri_pos": 1, "tri_normal": 2, "tri_uv": 3, "tri_info": 4,
    "materials": 5, "lights": 6, "spheres": 7, "images": 9,
}
STATS_BINDING = 8
MOTION_BINDING = 16  # `motion`, declared (and bound) only with HAS_MOTION
STAT_DROPPED = 0
STAT_DROPPED_SPLATS = 1  # splats dropped as NaN/Inf (plugins with splats = true)
STAT_RAYS_LOW, STAT_RAYS_HIGH = 2, 3  # rays traced (LIFT_COUNT_RAYS), a 64-bit count in two words
STAT_LOOP_LIMITED = 4  # pixel-frames cut short by the driver's loop limit (passes/trace.py)
NUM_STATS = 5
LOCAL_SIZE = 8  # compute passes run 8x8 work groups


def groups(width: int, height: int) -> tuple[int, int, int]:
    return ((width + LOCAL_SIZE - 1) // LOCAL_SIZE, (height + LOCAL_SIZE - 1) // LOCAL_SIZE, 1)


def set_uniforms(program, values: dict) -> None:
    """Set the uniforms a program kept; the compiler drops unused ones, so skip those."""
    for name, value in values.items():
        if name not in program:
            continue
        member = program[name]
        if isinstance(value, np.ndarray) and value.dtype in (np.float32, np.uint32, np.int32):
            # Arrays and matrices as raw bytes (column-major for matrices, as GLSL reads
            # them); an array's unused tail may have been optimised away.
            data = np.ascontiguousarray(value).tobytes()
            member.write(data[:member.array_length * member.element_size])
            continue
        if isinstance(value, (list, tuple, np.ndarray)):
            value = tuple(float(v) for v in np.asarray(value).ravel()) if not isinstance(value, tuple) else value
            if len(value) == 16:
                member.write(np.asarray(value, np.float32).tobytes())
                continue
        member.value = value


class SceneBuffers:
    """The packed scene uploaded as SSBOs, plus the statistics counters.

    `motion`: the shaders are compiled with HAS_MOTION (default: when the scene moves), so
    they read `motion`. A still scene compiled with every feature gets still_motion()."""

    def __init__(self, ctx, packed: PackedScene, motion: bool | None = None):
        self.ctx = ctx
        self.packed = packed
        self.buffers = {name: ctx.buffer(np.ascontiguousarray(getattr(packed, name)).tobytes())
                        for name in SCENE_BINDINGS}
        self.motion = None
        if packed.has_motion if motion is None else motion:
            rows = packed.motion if packed.has_motion else still_motion(packed)
            self.motion = ctx.buffer(np.ascontiguousarray(rows).tobytes())
        self.stats = ctx.buffer(reserve=4 * NUM_STATS)
        self.reset_stats()

    def upload(self, packed: PackedScene) -> list[str]:
        """Take an edited scene's arrays: rewrite the buffers whose contents changed (in place
        when the size is the same) and return their names. The motion buffer follows only
        if the scene moves."""
        written = []
        for name in SCENE_BINDINGS:
            new = np.ascontiguousarray(getattr(packed, name))
            old = getattr(self.packed, name)
            if new.shape == old.shape and np.array_equal(new, old):
                continue
            written.append(name)
            data = new.tobytes()
            if len(data) == self.buffers[name].size:
                self.buffers[name].write(data)
            else:
                self.buffers[name].release()
                self.buffers[name] = self.ctx.buffer(data)
        if self.motion is not None:
            rows = packed.motion if packed.has_motion else still_motion(packed)
            data = np.ascontiguousarray(rows).tobytes()
            if len(data) == self.motion.size:
                self.motion.write(data)
            else:
                self.motion.release()
                self.motion = self.ctx.buffer(data)
        self.packed = packed
        return written

    def bind(self) -> None:
        for name, binding in SCENE_BINDINGS.items():
            self.buffers[name].bind_to_storage_buffer(binding)
        if self.motion is not None:
            self.motion.bind_to_storage_buffer(MOTION_BINDING)
        self.stats.bind_to_storage_buffer(STATS_BINDING)

    def uniforms(self, environment_radiance) -> dict:
        p = self.packed
        centre = (p.bounds[0] + p.bounds[1]) / 2
        radius = float(np.linalg.norm(p.bounds[1] - p.bounds[0])) / 2
        return {"u_num_triangles": p.num_triangles, "u_num_spheres": p.num_spheres,
                "u_num_lights": p.num_lights, "u_env_radiance": tuple(float(x) for x in environment_radiance),
                **p.uniforms,

                # bounding sphere, for light leaving the environment (shaders/lift/emission.glsl)
                "u_scene_center": tuple(float(x) for x in centre), "u_scene_radius": max(radius, 1e-6)}

    def reset_stats(self) -> None:
        self.stats.write(np.zeros(NUM_STATS, np.uint32).tobytes())

    def read_stats(self) -> np.ndarray:
        return np.frombuffer(self.stats.read(), np.uint32).copy()

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()
        if self.motion is not None:
            self.motion.release()
        self.stats.release()


class GpuTimer:
    """Accumulated GPU time of one pass, from timer queries (ns).

    On a CPU rasterizer (`cpu_clock=True`, e.g. Mesa llvmpipe, whose GL_TIME_ELAPSED reads 0
    for some compute dispatches) the pass is timed by the wall clock between two glFinish
    calls instead: there the "GPU" is the CPU, so this is the pass's real cost.
    """

    def __init__(self, ctx, cpu_clock: bool = False):
        self.ctx = ctx
        self.cpu_clock = cpu_clock
        self.query = None if cpu_clock else ctx.query(time=True)
        self.total_ns = 0
        self.last_ns = 0
        self.count = 0
        self._start = 0

    def __enter__(self):
        if self.cpu_clock:
            self.ctx.finish()
            self._start = time.perf_counter_ns()
        else:
            self.query.__enter__()
        return self

    def __exit__(self, *exc):
        if self.cpu_clock:
            self.ctx.finish()
            self.last_ns = time.perf_counter_ns() - self._start
        else:
            self.query.__exit__(*exc)
            self.last_ns = self.query.elapsed
        self.total_ns += self.last_ns
        self.count += 1

    @property
    def mean_ms(self) -> float:
        return self.total_ns / max(self.count, 1) / 1e6

    @property
    def last_ms(self) -> float:
        return self.last_ns / 1e6
