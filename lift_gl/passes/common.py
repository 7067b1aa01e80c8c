"""What every pass shares: the scene's GPU buffers, uniform setting, and GPU timers."""
from __future__ import annotations

import time

import numpy as np

from ..bindings import HEAP_FIRST_BINDING, SCENE_BINDINGS, STORAGE_BUFFERS
from ..scene.pack import PackedScene, still_motion
from ..scene.split import HEAP_ARRAYS, BufferPlan, heap_chunks, plan_buffers

# Arrays that may go into a uniform block on a CPU rasterizer (shaders/lift/scene_data.glsl):
# name -> (the define that switches it over and holds its length, vec4 rows per GLSL element).
UNIFORM_ARRAYS = {
    "bvh_nodes": ("LIFT_UBO_BVH_NODES", 1), "tri_pos": ("LIFT_UBO_TRI_POS", 1),
    "tri_normal": ("LIFT_UBO_TRI_NORMAL", 1), "tri_uv": ("LIFT_UBO_TRI_UV", 1),
    "tri_info": ("LIFT_UBO_TRI_INFO", 1), "materials": ("LIFT_UBO_MATERIALS", 4),
    "lights": ("LIFT_UBO_LIGHTS", 1), "spheres": ("LIFT_UBO_SPHERES", 1),
    "instances": ("LIFT_UBO_INSTANCES", 1),
}
NO_INSTANCES = np.zeros((2, 4), np.float32)  # an empty TLAS, for shaders compiled with HAS_INSTANCES anyway
STATS_BINDING = STORAGE_BUFFERS["stats"]
MOTION_BINDING = STORAGE_BUFFERS["motion"]  # declared (and bound) only with HAS_MOTION
STAT_DROPPED = 0
STAT_DROPPED_SPLATS = 1  # splats dropped as NaN/Inf (plugins with splats = true)
STAT_RAYS_LOW, STAT_RAYS_HIGH = 2, 3  # rays traced (LIFT_COUNT_RAYS), a 64-bit count in two words
STAT_LOOP_LIMITED = 4  # pixel-frames cut short by the driver's loop limit (passes/trace.py)
NUM_STATS = 5
LOCAL_SIZE = 8  # compute passes run 8x8 work groups
# Coherent sampling (the options coherent_sampling and coherent_interleave, lift_gl/options.py):
# the trace programs are compiled with these (shaders/lift/host_tiles.glsl).
COHERENT_DEFINE = "LIFT_COHERENT_SAMPLING"
INTERLEAVE_DEFINE = "LIFT_COHERENT_INTERLEAVE"


def coherent_defines(coherent_sampling: str, interleave: int) -> dict:
    """The trace programs' defines for the options coherent_sampling (on, off) and
    coherent_interleave: none when off (a compile-time switch: off costs nothing)."""
    if coherent_sampling != "on":
        return {}
    return {COHERENT_DEFINE: 1, INTERLEAVE_DEFINE: max(1, int(interleave))}


def groups(width: int, height: int, local=(LOCAL_SIZE, LOCAL_SIZE)) -> tuple[int, int, int]:
    """Work groups of `local` (x, y) invocations that cover width x height."""
    lx, ly = local
    return ((width + lx - 1) // lx, (height + ly - 1) // ly, 1)


def set_uniforms(program, values: dict) -> None:
    """Set the uniforms a program kept; the compiler drops unused ones, so skip those."""
    for name, value in values.items():
        # (get, not `in`: moderngl's programs have no __contains__, so `in` walks every member)
        member = program.get(name, None)
        if member is None:
            continue
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


def glsl_length(name: str, array: np.ndarray) -> int:
    """Elements of the GLSL array `name` that the packed `array` fills (vec4, uvec2 or Material)."""
    return array.shape[0] if name == "tri_info" else array.size // (4 * UNIFORM_ARRAYS[name][1])


class SceneBuffers:
    """The packed scene uploaded as SSBOs, plus the statistics counters.

    `motion`: the shaders are compiled with HAS_MOTION (default: when the scene moves), so
    they read `motion`. A still scene compiled with every feature gets still_motion().

    `max_buffer_bytes`: the GL's limit per buffer; a scene whose big arrays pass it is split
    (lift_gl/scene/split.py), and `plan.defines()` must then be compiled into the shaders.

    `uniform_block_bytes` > 0 (CPU rasterizers): each of the UNIFORM_ARRAYS that fits in that
    many bytes goes into a uniform block rather than a storage buffer, which Mesa's llvmpipe
    reads far faster (shaders/lift/scene_data.glsl says why); defines() tells the shaders which.
    A split scene is far too big for that: none of its arrays go into uniform blocks.
    """

    def __init__(self, ctx, packed: PackedScene, motion: bool | None = None, uniform_block_bytes: int = 0,
                 max_buffer_bytes: int | None = None, instances: bool | None = None):
        self.ctx = ctx
        self.packed = packed
        # `instances`: the shaders are compiled with HAS_INSTANCES (default: when the scene
        # traces instances); only then is there an `instances` buffer.
        self.instances = packed.instances is not None if instances is None else instances
        self.uniform_block_bytes = uniform_block_bytes
        self.max_buffer_bytes = max_buffer_bytes if max_buffer_bytes is not None else 1 << 62
        self.plan = plan_buffers(packed, self.max_buffer_bytes)
        self.in_uniform_block = self._uniform_arrays(packed, self.plan)
        self.buffers = {name: ctx.buffer(self._bytes(name, _array(packed, name)))
                        for name in self._own_buffers(self.plan)}
        self.heap = [ctx.buffer(chunk.tobytes()) for chunk in heap_chunks(packed, self.plan)]
        self.motion = None
        if packed.has_motion if motion is None else motion:
            rows = packed.motion if packed.has_motion else still_motion(packed)
            self.motion = ctx.buffer(np.ascontiguousarray(rows).tobytes())
        self.stats = ctx.buffer(reserve=4 * NUM_STATS)
        self.reset_stats()

    def _uniform_arrays(self, packed: PackedScene, plan: BufferPlan) -> set:
        if plan.split:
            return set()
        return {name for name in UNIFORM_ARRAYS
                if (name != "instances" or self.instances) and 0 < _array(packed, name).shape[0] and
                glsl_length(name, _array(packed, name)) * 16 * UNIFORM_ARRAYS[name][1] <= self.uniform_block_bytes}

    def _uniform_length(self, name: str, array: np.ndarray) -> int:
        """The GLSL length a uniform block declares for `array`: its length rounded up to a
        power of two, at least 64 (at most what uniform_block_bytes holds), so that an edit
        that adds or drops a few nodes, triangles or lights keeps the shaders' defines and
        recompiles nothing; the buffer is padded with zeros to it."""
        length = glsl_length(name, array)
        most = self.uniform_block_bytes // (16 * UNIFORM_ARRAYS[name][1])
        return max(length, min(max(64, 1 << (length - 1).bit_length()), most))

    def _bytes(self, name: str, array: np.ndarray) -> bytes:
        array = np.ascontiguousarray(array)
        if name not in self.in_uniform_block:
            return array.tobytes()
        size = self._uniform_length(name, array) * 16 * UNIFORM_ARRAYS[name][1]
        if name == "tri_info":  # std140: uvec2 elements 16 bytes apart
            padded = np.zeros((array.shape[0], 4), np.uint32)
            padded[:, :2] = array
            array = padded
        data = array.tobytes()
        return data + bytes(size - len(data))

    def defines(self) -> dict:
        """The shader defines of the arrays in uniform blocks (their GLSL lengths, _uniform_length)."""
        return {UNIFORM_ARRAYS[name][0]: self._uniform_length(name, _array(self.packed, name))
                for name in sorted(self.in_uniform_block)}

    def _own_buffers(self, plan: BufferPlan) -> list[str]:
        """The arrays that get a buffer of their own: all, unless the heap holds some
        (`instances` only for shaders compiled with HAS_INSTANCES)."""
        return [name for name in SCENE_BINDINGS if not (plan.split and name in HEAP_ARRAYS)
                and (name != "instances" or self.instances)]

    def upload(self, packed: PackedScene) -> list[str]:
        """Take an edited scene's arrays: rewrite the buffers whose contents changed (in place
        when the size is the same) and return their names. The motion buffer follows only
        if the scene moves. The split plan, and which arrays sit in uniform blocks, may change
        with the scene: `plan.defines()` and `defines()` are then different, and the caller
        recompiles its shaders."""
        written = []
        plan = plan_buffers(packed, self.max_buffer_bytes)
        old_uniform, self.in_uniform_block = self.in_uniform_block, self._uniform_arrays(packed, plan)
        changed = {name for name in SCENE_BINDINGS
                   if not _same_bits(_array(packed, name), _array(self.packed, name))}
        own = self._own_buffers(plan)
        for name in list(self.buffers):
            if name not in own:   # now in the heap
                self.buffers.pop(name).release()
        for name in own:
            if name in self.buffers and name not in changed \
                    and (name in old_uniform) == (name in self.in_uniform_block):
                continue
            written.append(name)
            data = self._bytes(name, _array(packed, name))
            if name in self.buffers and len(data) == self.buffers[name].size:
                self.buffers[name].write(data)
            else:
                if name in self.buffers:
                    self.buffers[name].release()
                self.buffers[name] = self.ctx.buffer(data)
        if plan != self.plan or (plan.split and changed & set(HEAP_ARRAYS)):
            for b in self.heap:
                b.release()
            self.heap = [self.ctx.buffer(chunk.tobytes()) for chunk in heap_chunks(packed, plan)]
            written += [name for name in HEAP_ARRAYS if plan.split and name in changed]
        self.plan = plan
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
        for name, buffer in self.buffers.items():
            if name in self.in_uniform_block:
                buffer.bind_to_uniform_block(SCENE_BINDINGS[name])
            else:
                buffer.bind_to_storage_buffer(SCENE_BINDINGS[name])
        for k, buffer in enumerate(self.heap):
            buffer.bind_to_storage_buffer(HEAP_FIRST_BINDING + k)
        if self.motion is not None:
            self.motion.bind_to_storage_buffer(MOTION_BINDING)
        self.stats.bind_to_storage_buffer(STATS_BINDING)

    def memory(self) -> list[tuple[str, int, int]]:
        """(name, binding, bytes) of every storage buffer the scene occupies."""
        out = [(name, SCENE_BINDINGS[name], b.size) for name, b in self.buffers.items()]
        for k, b in enumerate(self.heap):
            held = [name for name in HEAP_ARRAYS
                    if _overlaps(self.plan, name, k, getattr(self.packed, name).nbytes)]
            out.append((f"heap[{k}] ({', '.join(held)})", HEAP_FIRST_BINDING + k, b.size))
        if self.motion is not None:
            out.append(("motion", MOTION_BINDING, self.motion.size))
        out.append(("stats", STATS_BINDING, self.stats.size))
        return out

    def uniforms(self, environment_radiance) -> dict:
        p = self.packed
        centre = (p.bounds[0] + p.bounds[1]) / 2
        radius = float(np.linalg.norm(p.bounds[1] - p.bounds[0])) / 2
        return {"u_num_triangles": p.num_triangles, "u_num_spheres": p.num_spheres, **self.plan.uniforms(),
                "u_world_triangles": p.num_triangles if p.world_triangles < 0 else p.world_triangles,
                "u_num_instances": p.num_instances,
                "u_instance_records": 0 if p.instance_table is None else p.instance_table.record_base,
                "u_num_lights": p.num_lights, "u_env_radiance": tuple(float(x) for x in environment_radiance),
                **p.uniforms,

                # bounding sphere, for light leaving the environment (shaders/lift/emission.glsl)
                "u_scene_center": tuple(float(x) for x in centre), "u_scene_radius": max(radius, 1e-6)}

    def reset_stats(self) -> None:
        self.stats.write(np.zeros(NUM_STATS, np.uint32).tobytes())

    def read_stats(self) -> np.ndarray:
        return np.frombuffer(self.stats.read(), np.uint32).copy()

    def release(self) -> None:
        for b in [*self.buffers.values(), *self.heap]:
            b.release()
        if self.motion is not None:
            self.motion.release()
        self.stats.release()


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays hold the same bytes: uint data stored as float32 (node entries of
    the 4-wide BVH, accel/wide.py) may read as NaN, which never equals itself as a float."""
    return a.shape == b.shape and a.dtype == b.dtype and \
        np.array_equal(np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8))


def _array(packed: PackedScene, name: str) -> np.ndarray:
    array = getattr(packed, name)
    return NO_INSTANCES if array is None else array


def _overlaps(plan: BufferPlan, name: str, chunk: int, nbytes: int) -> bool:
    start, stop = plan.chunk_ranges()[chunk]
    base = plan.bases[name]
    return base < stop and base + -(-nbytes // 16) > start


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


def tile_dispatch_size(defines: dict, size, tile) -> tuple[int, int]:
    """The invocations a trace dispatch covers: the image; with coherent sampling, whole blocks
    (interleave x tile) over the image moved by the largest offset (lift_tile_groups)."""
    if COHERENT_DEFINE not in defines:
        return tuple(size)
    k = int(defines.get(INTERLEAVE_DEFINE, 1))
    return tuple(-(-(n + k * t - 1) // (k * t)) * k * t for n, t in zip(size, tile))
