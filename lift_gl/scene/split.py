"""Scenes larger than one shader storage buffer: the big arrays in a heap of several buffers.

A GL caps each SSBO at GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on llvmpipe, 2 GiB on
NVIDIA; ../shared/FACTS.md). When any of the per-triangle arrays or the BVH nodes passes that,
all of them (HEAP_ARRAYS) are laid end to end as one array of vec4 rows, the heap, and the heap
is cut into chunks of 2^shift rows, one buffer each, bound from HEAP_FIRST_BINDING on.
shaders/lift/scene_data.glsl then reads them through its accessors (tri_pos_row, bvh_node_row,
...) with LIFT_SPLIT_SCENE defined; the row where each array starts is a uniform, so an edit
that keeps the chunk count needs no recompilation.

One heap rather than chunks per array: a compute shader may use only 16 storage blocks on
llvmpipe (GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS), and chunks per array would round every array
up to whole buffers. Scenes that fit stay unsplit: the accessors are then plain array reads.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..bindings import HEAP_FIRST_BINDING, MAX_HEAP_CHUNKS  # the heap's buffers, declared in scene_data.glsl

# Arrays that go into the heap, in heap order; tri_info (uvec2) takes two triangles a row.
HEAP_ARRAYS = ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info")
ROW_BYTES = 16
HEAP_UNIFORMS = {"bvh_nodes": "u_heap_nodes", "tri_pos": "u_heap_pos", "tri_normal": "u_heap_normal",
                 "tri_uv": "u_heap_uv", "tri_info": "u_heap_info"}
# Each array's first and last chunk are compiled in (LIFT_HEAP_<NAME>_LO/_HI), so that its
# accessor tests only the chunks it spans: a single load when it lies in one chunk.
HEAP_DEFINE_NAMES = {"bvh_nodes": "NODES", "tri_pos": "POS", "tri_normal": "NORMAL", "tri_uv": "UV",
                     "tri_info": "INFO"}


def heap_rows_of(array: np.ndarray) -> np.ndarray:
    """One of HEAP_ARRAYS as float32 (rows, 4) (uint data as its bit pattern)."""
    flat = np.ascontiguousarray(array).reshape(-1).view(np.float32)
    if flat.size % 4:
        flat = np.concatenate([flat, np.zeros(4 - flat.size % 4, np.float32)])
    return flat.reshape(-1, 4)


@dataclass(frozen=True)
class BufferPlan:
    """How the scene's arrays map to buffers. chunks == 0: no heap, one buffer an array."""
    shift: int = 0                 # log2 of rows per heap chunk
    chunks: int = 0
    bases: dict = field(default_factory=dict)   # first heap row of each HEAP_ARRAYS array
    spans: dict = field(default_factory=dict)   # first and last chunk of each
    heap_rows: int = 0

    @property
    def split(self) -> bool:
        return self.chunks > 0

    @property
    def chunk_rows(self) -> int:
        return 1 << self.shift

    def defines(self) -> dict:
        if not self.split:
            return {}
        out = {"LIFT_SPLIT_SCENE": True, "LIFT_HEAP_CHUNKS": self.chunks, "LIFT_HEAP_SHIFT": self.shift}
        for name, (lo, hi) in self.spans.items():
            out[f"LIFT_HEAP_{HEAP_DEFINE_NAMES[name]}_LO"] = f"{lo}u"
            out[f"LIFT_HEAP_{HEAP_DEFINE_NAMES[name]}_HI"] = f"{hi}u"
        return out

    def uniforms(self) -> dict:
        return {HEAP_UNIFORMS[name]: int(base) for name, base in self.bases.items()}

    def chunk_ranges(self) -> list[tuple[int, int]]:
        """Heap rows [start, stop) of each chunk."""
        return [(k << self.shift, min((k + 1) << self.shift, self.heap_rows)) for k in range(self.chunks)]


def plan_buffers(packed, max_buffer_bytes: int) -> BufferPlan:
    """Split when any HEAP_ARRAYS array passes max_buffer_bytes; chunks as large as allowed
    (a power of two of rows, so the shader finds a row's chunk with one shift)."""
    sizes = {name: int(getattr(packed, name).nbytes) for name in HEAP_ARRAYS}
    if max(sizes.values()) <= max_buffer_bytes:
        return BufferPlan()
    rows_allowed = max(int(max_buffer_bytes) // ROW_BYTES, 1)
    shift = rows_allowed.bit_length() - 1
    bases, spans, row = {}, {}, 0
    for name in HEAP_ARRAYS:
        rows = -(-sizes[name] // ROW_BYTES)
        bases[name] = row
        spans[name] = (row >> shift, (row + max(rows, 1) - 1) >> shift)
        row += rows
    return BufferPlan(shift=shift, chunks=-(-row // (1 << shift)), bases=bases, spans=spans, heap_rows=row)


def heap_chunks(packed, plan: BufferPlan):
    """The heap's chunks as float32 (rows, 4) arrays, built one chunk at a time (the whole heap
    is never held twice)."""
    if not plan.split:
        return
    parts = [(plan.bases[name], heap_rows_of(getattr(packed, name))) for name in HEAP_ARRAYS]
    for start, stop in plan.chunk_ranges():
        out = np.zeros((stop - start, 4), np.float32)
        for base, rows in parts:
            lo, hi = max(start, base), min(stop, base + len(rows))
            if lo < hi:
                out[lo - start:hi - start] = rows[lo - base:hi - base]
        yield out
