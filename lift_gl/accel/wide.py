"""A 4-wide BVH for GPU traversal, collapsed from the binary SAH tree (accel/bvh.py).

Why: the binary traversal (shaders/lift/bvh.glsl) fetches one node and tests two boxes per
step; a wide node gives the GPU four boxes per 128-byte fetch and half the steps, and leaves
become child entries of their parent, so a leaf is never fetched as a node of its own.

Collapse: by default chosen by cost (accel/wide_sah.py: which binary nodes become wide nodes
and which subtrees one leaf, by dynamic programming). collapse() here is the simple rule
($LIFT_GL_BVH_COLLAPSE=greedy, and where the other cannot hold a tree): top down, level by
level (vectorised: Python work per level, not per node), each binary interior node that
becomes a wide node starts with its two children and repeatedly replaces its largest-area
interior child by that child's two children, until it has 4 (Wald et al. 2008 / Ylitie et
al. 2017's "largest area first"). Either way the leaves are runs of the binary tree's
triangles, so the triangle arrays (and the BVH cache) stay those of the binary tree.

Node layout, 8 vec4 rows (128 bytes) per wide node, children in columns (SoA):
    row 0 min.x[4]  row 1 max.x[4]  row 2 min.y[4]  row 3 max.y[4]  row 4 min.z[4]
    row 5 max.z[4]  row 6 child entries (uint bits)  row 7 unused (zero)
A child entry is the wide node id of an interior child, or for a leaf
LEAF_BIT | (count - 1) << 27 | first (triangles first .. first + count - 1); an empty
slot is EMPTY with the box (+inf, -inf), which no ray's slab test ever enters (the GLSL
takes the near plane by the ray's direction sign, so the planes are never swapped).
Node 0 is the root; nodes are numbered breadth first. quantize() turns the same tree into
64-byte nodes with 8-bit child boxes ($LIFT_GL_BVH_WIDTH=4q). docs/gpu.md has the
measurements behind the defaults below.

Not here (the caller keeps the binary tree): motion blur (per-node boxes at shutter close)
and instances (BLAS roots index the node array); see scene/pack.py.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..env_settings import env_choice
from ..errors import LiftError

WIDTH_ENV_VAR = "LIFT_GL_BVH_WIDTH"
ROWS = 8                    # vec4 rows per 4-wide node
QROWS = 4                   # vec4 rows per 4-wide node with quantized boxes (quantize())
LEAF_BIT = 0x80000000
COUNT_SHIFT = 27
MAX_LEAF_COUNT = 16         # 4 bits of count - 1
MAX_FIRST = 1 << COUNT_SHIFT
EMPTY = 0xFFFFFFFF
# The GLSL stack of the wide traversal (LIFT_BVH_STACK when LIFT_BVH_WIDTH is 4): a node whose
# children are all hit pushes 3 of them, so the stack the tree needs is its largest sum of
# (children - 1) along a root path (WideBVH.stack_bound); a tree that needs more stays binary.
STACK = 64


def stack_size(stack_bound: int) -> int:
    """The traversal stack the shaders declare (LIFT_BVH_STACK_SIZE) for a tree whose
    traversal needs `stack_bound` entries: rounded up to a multiple of 8, so that an edit that
    deepens the tree a little recompiles nothing, and at most STACK. On GPUs the stack lives in
    shared memory, which bounds how many warps an SM holds: a smaller one lets more run
    (docs/gpu.md "A stack as deep as the tree needs")."""
    return min(STACK, max(8, -(-int(stack_bound) // 8) * 8))


STACK_ENV_VAR = "LIFT_GL_BVH_STACK_ENTRIES"
STACKS = ("children", "groups")
# A stack of node groups (shaders/lift/bvh.glsl LIFT_BVH_GROUP_STACK) packs a node id in 24 bits.
GROUP_MAX_NODES = 1 << 24


def resolve_stack(value: str | None = None) -> str:
    """What the 4-wide traversal's stack entries are: `value`, else $LIFT_GL_BVH_STACK_ENTRIES,
    else auto; one of STACKS or "auto" (stack_defines decides per tree and device).
    children: one entry a child left to visit (as deep as stack_bound); groups: one entry a
    node with children left (as deep as the tree has levels, shaders/lift/bvh.glsl)."""
    return env_choice(STACK_ENV_VAR, STACKS, value)


STACK_DEFINES = ("LIFT_BVH_GROUP_STACK", "LIFT_BVH_STACK_SIZE", "LIFT_BVH_SHARED_DEPTH")   # what stack_defines sets


def stack_defines(wide_stack_bound: int, levels: int, num_nodes: int, software: bool, stack: str | None = None,
                  preferred: str = "auto") -> dict:
    """The defines that size a 4-wide tree's traversal stack: LIFT_BVH_STACK_SIZE, with
    LIFT_BVH_GROUP_STACK where its entries are node groups, whose top GROUP_SHARED_DEPTH
    entries then stay in shared memory on GPUs (LIFT_BVH_SHARED_DEPTH) and deeper ones go to a
    local array. auto: groups on GPUs where the stack of children would need more than
    GROUP_STACK_FROM entries, else children; groups need node ids that fit 24 bits and at
    most STACK levels (a tree's levels can pass its stack_bound by one).
    `preferred`: what the plugin's manifest asks for (bvh_stack), taken where `stack` (else
    $LIFT_GL_BVH_STACK_ENTRIES) is auto."""
    mode = resolve_stack(stack)
    if mode == "auto":
        mode = resolve_stack(preferred)
    if mode == "auto":
        mode = "groups" if not software and stack_size(wide_stack_bound) > GROUP_STACK_FROM else "children"
    if mode == "groups" and 0 < levels <= STACK and num_nodes < GROUP_MAX_NODES:
        return {"LIFT_BVH_GROUP_STACK": True, "LIFT_BVH_STACK_SIZE": stack_size(levels),
                "LIFT_BVH_SHARED_DEPTH": GROUP_SHARED_DEPTH}
    return {"LIFT_BVH_STACK_SIZE": stack_size(wide_stack_bound)}


PAIRED_ENV_VAR = "LIFT_GL_TRACE_PAIRED"


def paired_defines(software: bool, levels: int, value: str | None = None) -> dict:
    """LIFT_TRACE_PAIRED where a path vertex's shadow ray and next ray go through one traversal
    loop (shaders/lift/bvh.glsl trace_shadow_and_next): `value`, else $LIFT_GL_TRACE_PAIRED:
    on, off or auto (on GPUs for trees of at least PAIRED_FROM_LEVELS levels, off on CPU
    rasterizers; the comment below says why)."""
    text = env_choice(PAIRED_ENV_VAR, ("on", "off"), value)
    on = text == "on" or (text == "auto" and not software and levels >= PAIRED_FROM_LEVELS)
    return {"LIFT_TRACE_PAIRED": True} if on else {}


# On an H100 at 1920x1080 (docs/gpu.md "Seventh session"), with the megakernel's pixel queue,
# pt's trace with a vertex's two rays in one loop ran 1.11x as fast as with two loops on the
# classroom (16 levels), 1.04x on the dining room (18), 0.99x on the Covered Dragon (15) and
# 0.92x on the cornell-box (4: its traversals are a few nodes long, and the loop's second
# setup, run apart by each lane, costs more than the waits it saves). In the eighth session three
# scenes of Bitterli's of 12, 13 and 15 levels gained 1.30x, 1.09x, 1.09x (H100, the stack local).
# Seven scenes: a rule, not a law. On llvmpipe the one loop cost 5%: CPUs trace the two apart.
PAIRED_FROM_LEVELS = 8

# The width GPUs get by default (resolve_width): on an H100 the 4-wide tree made pt's trace
# pass 1.02-1.19x faster than the binary one on Lift's scenes and the Covered Dragon at
# 1920x1080 (docs/gpu.md, benchmarks/results/gpu_h100/wide_bvh/).
DEFAULT_GPU_WIDTH = "4"
# On llvmpipe (2 cores here) the 4-wide tree made pt 1.10-1.26x faster in CPU time per sample
# than the binary one on Lift's scenes, and its 8-bit boxes (4q) 1.06x more on the classroom
# and the dining room, interleaved (benchmarks/cpu_speed.py; results/cpu_speed/wide_bvh_*):
# on a CPU the smaller nodes pay (on the H100 they cost 7-35%).
DEFAULT_CPU_WIDTH = "4q"
# auto's stack entries (stack_defines). On an H100 at 1920x1080 (docs/gpu.md "A stack of node
# groups"), node groups made the ray-casting shader's rays 1.2-1.7x faster on the dining room,
# the classroom and the Covered Dragon (their stacks of children: 56, 48, 48 entries) and pt's
# trace pass 1.17x (dining room), 1.10x (dragon), 0.98x (classroom); on the cornell-box (16
# entries: occupancy is not held down by shared memory there) pt's trace 0.89x. On llvmpipe
# (no shared memory: stacks are local arrays) its rays 0.78-0.99x: CPUs keep children.
GROUP_STACK_FROM = 32
# Node groups rarely go more than a few levels deep: with only the top 8 in shared memory (1 KiB
# a work group) pt's trace pass ran 1.21x faster again on the dining room than with all 24 there,
# 1.04x on the dragon, 1.02x on the classroom (H100; 12 entries: 1.13 / 0.98 / 0.98x). That was
# pt's plain megakernel; the queued one it runs now keeps its whole stack in a local array on
# GPUs (passes/trace.py trace_layout), and drt, hybrid and ao keep this.
GROUP_SHARED_DEPTH = 8


@dataclass
class WideBVH:
    rows: np.ndarray        # float32 (W, 4 * ROWS) (quantized: (W, 4 * QROWS)), one wide node a row
    width: int
    stack_bound: int        # the deepest the traversal stack can get (see STACK)
    quantized: bool = False
    levels: int = 0         # wide nodes on the longest root path: the deepest a stack of node groups gets

    @property
    def num_nodes(self) -> int:
        return int(self.rows.shape[0])


LAYOUTS = ("2", "4", "4q")   # binary, 4-wide with float boxes, 4-wide with 8-bit boxes (quantize)


def resolve_width(value: str | int | None, software: bool | None = None) -> str:
    """The BVH layout to build, one of LAYOUTS: `value` (2, 4, 4q, auto), else
    $LIFT_GL_BVH_WIDTH, else auto. auto: DEFAULT_GPU_WIDTH on GPUs, DEFAULT_CPU_WIDTH on CPU
    rasterizers (software True), 2 where the device is not known (software None: pack_scene
    called on its own)."""
    text = env_choice(WIDTH_ENV_VAR, LAYOUTS, value)
    if text == "auto":
        return "2" if software is None else DEFAULT_CPU_WIDTH if software else DEFAULT_GPU_WIDTH
    return text


COLLAPSE_ENV_VAR = "LIFT_GL_BVH_COLLAPSE"


def resolve_collapse(value: str | None = None) -> tuple[str, tuple[float, ...]]:
    """How the binary tree becomes a wide one: `value`, else $LIFT_GL_BVH_COLLAPSE, else auto:
    greedy (collapse: the largest child opened first), or sah (accel/wide_sah.py: chosen by
    cost) with optional costs sah:NODE,LEAF,TRIANGLE (or NODE/LEAF/TRIANGLE). Returns (method, costs)."""
    text = (os.environ.get(COLLAPSE_ENV_VAR, "auto") if value is None else str(value)).strip().lower() or "auto"
    method, _, costs = text.partition(":")
    if method == "auto":
        method = DEFAULT_COLLAPSE
    try:
        numbers = tuple(float(c) for c in costs.replace("/", ",").split(",")) if costs else ()
    except ValueError:
        numbers = None
    if method not in ("greedy", "sah") or numbers is None or (numbers and (method != "sah" or len(numbers) != 3)):
        raise LiftError(f"${COLLAPSE_ENV_VAR} must be greedy, sah, sah:NODE,LEAF,TRIANGLE or auto, not {text!r}")
    return method, numbers


# On an H100 at 1920x1080 (docs/gpu.md "Seventeenth session"), the collapse by cost made pt's
# trace 0.98x (dining room), 0.99x (classroom) and 0.965x (Covered Dragon) of the greedy
# one's, its G-buffer 0.94x on the dining room, with 30-32% fewer wide nodes; on llvmpipe pt
# 1.00-1.025x faster in CPU time (cornell-box, classroom, dining room).
DEFAULT_COLLAPSE = "sah"


def wide_layout(nodes: np.ndarray, layout: str, collapse_method: str | None = None,
                slot_order: str | None = None) -> WideBVH | None:
    """The binary node array in `layout` ("4" or "4q"), or None where that layout cannot hold
    the tree (collapse, quantize). `collapse_method`: see resolve_collapse; `slot_order`: see
    resolve_slot_order."""
    method, costs = resolve_collapse(collapse_method)
    order = resolve_slot_order(slot_order)
    wide = None
    if method == "sah":
        from .wide_sah import collapse_sah
        wide = collapse_sah(nodes, *costs, slot_order=order)
    if wide is None:
        wide = collapse(nodes, slot_order=order)
    if wide is not None and layout == "4q":
        wide = quantize(wide)
    return wide


def _area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi.astype(np.float64) - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def quantize(wide: WideBVH) -> WideBVH | None:
    """The same tree with 8-bit child boxes (Ylitie, Karras and Laine 2017): 64 bytes a node,
    two nodes a 128-byte line. Per node, QROWS vec4 rows:
        row 0  origin.xyz (float), w: uint bits, the biased exponents of the per-axis scales
               s = 2^(e - 127) in bytes 0, 1, 2
        row 1  uint bits: qlo.x, qhi.x, qlo.y, qhi.y   (child i in byte i of each word)
        row 2  uint bits: qlo.z, qhi.z, 0, 0
        row 3  the child entries, as row 6 of the float layout
    A child's plane is origin + q * s: q * s is exact (8 bits times a power of two), so the GPU
    decodes exactly what numpy checks here, and every decoded box contains the float one
    (rounded outwards, corrected where the final add rounded inwards): the traversal visits a
    superset of the float layout's boxes and finds the same hits. Empty slots: qlo 255, qhi 0,
    and their EMPTY entry, which the GLSL masks out. None where a scale would leave float's
    exponent range."""
    r = wide.rows.reshape(-1, ROWS, 4)
    entry = r[:, 6].view(np.uint32)
    valid = entry != EMPTY
    lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1)          # (W, 4, 3), +inf where empty
    hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1)
    origin = np.where(valid[..., None], lo, np.inf).min(axis=1).astype(np.float32)   # (W, 3)
    top = np.where(valid[..., None], hi, -np.inf).max(axis=1).astype(np.float32)
    extent = np.maximum(top.astype(np.float64) - origin, 0.0)
    # the smallest power of two with 253 steps covering the extent (2 steps spare for rounding)
    with np.errstate(divide="ignore"):
        e = np.ceil(np.log2(np.maximum(extent / 253.0, 2.0 ** -126)))
    e = np.maximum(e, -126).astype(np.int64)
    if (e > 127).any() or not np.isfinite(origin).all():
        return None
    scale = np.exp2(e).astype(np.float32)                         # (W, 3), exact powers of two
    o = origin[:, None, :]
    s = scale[:, None, :]
    qlo = np.floor((lo.astype(np.float64) - o) / s)
    qhi = np.ceil((hi.astype(np.float64) - o) / s)
    qlo = np.clip(np.where(valid[..., None], qlo, 255), 0, 255)
    qhi = np.clip(np.where(valid[..., None], qhi, 0), 0, 255)

    def decode(q):   # what the GLSL computes: one float32 add of an exact product
        return (o + (q.astype(np.float32) * s)).astype(np.float32)

    for _ in range(2):   # where the add rounded inwards, one step outwards
        qlo = np.where(valid[..., None] & (decode(qlo) > lo), np.maximum(qlo - 1, 0), qlo)
        qhi = np.where(valid[..., None] & (decode(qhi) < hi), np.minimum(qhi + 1, 255), qhi)
    v = valid[..., None]
    if (v & (decode(qlo) > lo)).any() or (v & (decode(qhi) < hi)).any():
        return None
    qlo, qhi = qlo.astype(np.uint32), qhi.astype(np.uint32)
    shifts = np.array([0, 8, 16, 24], np.uint32)

    def pack(q):     # (W, 4) bytes -> (W,) words, child i in byte i
        return (q << shifts).sum(axis=1).astype(np.uint32)

    w = r.shape[0]
    out = np.zeros((w, QROWS, 4), np.uint32)
    out[:, 0, :3] = origin.view(np.uint32)
    out[:, 0, 3] = ((e[:, 0] + 127) | (e[:, 1] + 127) << 8 | (e[:, 2] + 127) << 16).astype(np.uint32)
    out[:, 1] = np.stack([pack(qlo[..., 0]), pack(qhi[..., 0]), pack(qlo[..., 1]), pack(qhi[..., 1])], axis=1)
    out[:, 2, 0], out[:, 2, 1] = pack(qlo[..., 2]), pack(qhi[..., 2])
    out[:, 3] = entry
    return WideBVH(rows=out.view(np.float32).reshape(w, QROWS * 4), width=wide.width,
                   stack_bound=wide.stack_bound, quantized=True, levels=wide.levels)


def decoded_boxes(wide: WideBVH) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, entries) of every child slot, (W, 4, 3), (W, 4, 3), (W, 4): what the GLSL
    traversal tests, for either layout (tests and intersect_wide_numpy)."""
    if not wide.quantized:
        r = wide.rows.reshape(-1, ROWS, 4)
        lo = np.stack([r[:, 0], r[:, 2], r[:, 4]], axis=-1)
        hi = np.stack([r[:, 1], r[:, 3], r[:, 5]], axis=-1)
        return lo, hi, r[:, 6].view(np.uint32)
    u = wide.rows.reshape(-1, QROWS, 4).view(np.uint32)
    origin = u[:, 0, :3].view(np.float32)
    e = (u[:, 0, 3:4] >> np.array([0, 8, 16], np.uint32)) & 0xFF
    scale = (e << 23).astype(np.uint32).view(np.float32)          # 2^(e - 127), as the GLSL builds it
    byte = lambda word: ((word[:, None] >> np.array([0, 8, 16, 24], np.uint32)) & 0xFF).astype(np.float32)
    qlo = np.stack([byte(u[:, 1, 0]), byte(u[:, 1, 2]), byte(u[:, 2, 0])], axis=-1)
    qhi = np.stack([byte(u[:, 1, 1]), byte(u[:, 1, 3]), byte(u[:, 2, 1])], axis=-1)
    lo = (origin[:, None, :] + qlo * scale[:, None, :]).astype(np.float32)
    hi = (origin[:, None, :] + qhi * scale[:, None, :]).astype(np.float32)
    entry = u[:, 3]
    empty = entry == EMPTY     # masked out by the GLSL: shown here as the float layout's (+inf, -inf)
    lo[empty], hi[empty] = np.inf, -np.inf
    return lo, hi, entry


def collapse(nodes: np.ndarray, width: int = 4, slot_order: str = "area") -> WideBVH | None:
    """The 4-wide tree of a binary node array (accel/bvh.py layout, (N, 8) float32), or None
    where the layout cannot hold it: a leaf of more than MAX_LEAF_COUNT triangles, a triangle
    index past MAX_FIRST, or a tree that needs a traversal stack deeper than STACK. Each
    node's children in `slot_order` (SLOT_ORDERS)."""
    if width != 4:
        raise ValueError(f"only 4-wide nodes are implemented, not {width}")
    nodes = np.asarray(nodes, np.float32)
    u = nodes.view(np.uint32)
    first = u[:, 3].astype(np.int64)
    count = u[:, 7].astype(np.int64)
    bmin, bmax = nodes[:, 0:3], nodes[:, 4:7]
    leaf = count > 0
    if (count > MAX_LEAF_COUNT).any() or (first[leaf] + count[leaf] > MAX_FIRST).any():
        return None
    area = _area(bmin, bmax)

    out_slots, out_ids = [], []          # per level: (m, 4) binary ids (-1 empty), wide ids
    n_wide = 1
    frontier = np.zeros(1, np.int64)     # binary nodes that become the wide nodes of a level
    root_is_leaf = bool(leaf[0])
    depth_push = np.zeros(1, np.int64)   # stack pushes on the path down to each frontier node
    stack_bound = 0
    while frontier.size:
        m = frontier.size
        slots = np.full((m, width), -1, np.int64)
        if root_is_leaf:                 # a one-leaf tree: the root's only child is itself
            slots[0, 0] = 0
            fill = np.ones(1, np.int64)
            root_is_leaf = False
        else:
            slots[:, 0] = first[frontier]
            slots[:, 1] = first[frontier] + 1
            fill = np.full(m, 2, np.int64)
        rows = np.arange(m)
        for _ in range(width - 2):
            valid = slots >= 0
            safe = np.where(valid, slots, 0)
            expandable = valid & ~leaf[safe]
            key = np.where(expandable, area[safe], -1.0)
            j = np.argmax(key, axis=1)
            go = np.flatnonzero(key[rows, j] >= 0)
            if not go.size:
                break
            c = slots[go, j[go]]
            slots[go, j[go]] = first[c]
            slots[go, fill[go]] = first[c] + 1
            fill[go] += 1
        stack_bound = max(stack_bound, int((depth_push + fill - 1).max()))
        valid = slots >= 0
        inner = valid & ~leaf[np.where(valid, slots, 0)]
        k = int(inner.sum())
        ids = np.full((m, width), -1, np.int64)
        ids[inner] = n_wide + np.arange(k)   # row-major: breadth-first numbering
        n_wide += k
        out_slots.append(slots)
        out_ids.append(ids)
        parent_push = np.repeat(depth_push + fill - 1, inner.sum(axis=1))
        frontier = slots[inner]
        depth_push = parent_push
    if stack_bound > STACK:
        return None

    slots = np.concatenate(out_slots)
    safe = np.where(slots >= 0, slots, 0)
    rows = wide_rows(slots, (slots >= 0) & leaf[safe], np.concatenate(out_ids), first, count, bmin, bmax, slot_order)
    return WideBVH(rows=rows, width=width, stack_bound=stack_bound, levels=len(out_slots))


# The order of a wide node's four children. The traversal sorts the children it enters by entry
# distance, but every child box that holds the ray's origin has the same one (the ray's tmin),
# and so do the boxes around a path vertex, where shadow and bounce rays start: those ties go
# in slot order (shaders/lift/bvh.glsl). Shadow rays outside the paired loop (CPU rasterizers,
# the ray-casting shader) take all their children in slot order. `area` puts the largest box
# first: for a shadow ray the child most likely to hold an occluder. On an H100 (docs/gpu.md
# "Seventeenth session") that made pt's trace 0.968x on the dining room, 0.855x on the Covered
# Dragon, 1.001x on the classroom against `build` (the collapse's own order: a node's slots
# from its left subtree first). On llvmpipe it made pt 0.956x as fast on the classroom, 1.016x
# on the dining room (why the classroom loses there is not known: the H100's ray-casting
# shader, whose shadow rays also take their children in slot order, ran the classroom's 1.9x
# as fast): auto is `area` on GPUs, `build` on CPU rasterizers.
SLOT_ORDER_ENV_VAR = "LIFT_GL_BVH_SLOT_ORDER"
SLOT_ORDERS = ("area", "build")


def resolve_slot_order(value: str | None = None, software: bool | None = None) -> str:
    """`value`, else $LIFT_GL_BVH_SLOT_ORDER, else auto: one of SLOT_ORDERS. auto: area, but
    build on CPU rasterizers (software True; None: the device is not known)."""
    text = env_choice(SLOT_ORDER_ENV_VAR, SLOT_ORDERS, value)
    if text == "auto":
        return "build" if software else "area"
    return text


def wide_rows(slots: np.ndarray, is_leaf: np.ndarray, ids: np.ndarray, leaf_first: np.ndarray,
              leaf_count: np.ndarray, bmin: np.ndarray, bmax: np.ndarray, slot_order: str = "area") -> np.ndarray:
    """The float layout's rows (W, 4 * ROWS) of a wide tree given per slot (W, 4) the binary
    node it stands for (-1: empty), whether it is a leaf entry and the wide id of an interior
    one; a leaf entry of binary node x holds triangles leaf_first[x] .. + leaf_count[x] - 1 and
    every slot the box (bmin[x], bmax[x]). Each node's slots in `slot_order` (SLOT_ORDERS)."""
    valid = slots >= 0
    safe = np.where(valid, slots, 0)
    if slot_order not in SLOT_ORDERS:
        raise ValueError(f"slot order must be one of {SLOT_ORDERS}, not {slot_order!r}")
    if slot_order == "area":
        # largest box first, empty slots last: see SLOT_ORDER_ENV_VAR
        order = np.argsort(-np.where(valid, _area(bmin[safe], bmax[safe]), -1.0), axis=1, kind="stable")
        slots, is_leaf, ids = (np.take_along_axis(a, order, 1) for a in (slots, is_leaf, ids))
        valid = slots >= 0
        safe = np.where(valid, slots, 0)
    entries = np.full(slots.shape, EMPTY, np.int64)
    lf = valid & is_leaf
    entries[lf] = LEAF_BIT | ((leaf_count[safe[lf]] - 1) << COUNT_SHIFT) | leaf_first[safe[lf]]
    entries[valid & ~is_leaf] = ids[valid & ~is_leaf]
    w = slots.shape[0]
    out = np.zeros((w, ROWS, 4), np.float32)
    lo = np.where(valid[..., None], bmin[safe], np.float32(np.inf))    # (w, 4, 3)
    hi = np.where(valid[..., None], bmax[safe], np.float32(-np.inf))
    for axis in range(3):
        out[:, 2 * axis, :] = lo[:, :, axis]
        out[:, 2 * axis + 1, :] = hi[:, :, axis]
    out[:, 6, :] = entries.astype(np.uint32).view(np.float32)
    return out.reshape(w, ROWS * 4)


def intersect_wide_numpy(wide: WideBVH, tri_positions_reordered: np.ndarray, origins: np.ndarray,
                         dirs: np.ndarray, tmin: float = 0.0, tmax: float = np.inf):
    """Closest hit of each ray through the wide tree: (t float64 (R,), tri int64 (R,)), as
    bvh.intersect_numpy does for the binary tree (tests compare the two). Wavefront: all
    (ray, wide node) pairs of a level at once, every child box tested, hit leaves' triangles
    intersected at once."""
    from .bvh import _safe_inv, moller_trumbore

    tris = np.asarray(tri_positions_reordered, np.float64)
    o_all = np.asarray(origins, np.float64).reshape(-1, 3)
    d_all = np.asarray(dirs, np.float64).reshape(-1, 3)
    n_rays = o_all.shape[0]
    best_t = np.full(n_rays, float(tmax))
    best_tri = np.full(n_rays, -1, np.int64)
    if tris.shape[0] == 0 or n_rays == 0:
        return np.where(best_tri < 0, np.inf, best_t), best_tri
    inv_all = _safe_inv(d_all)
    lo, hi, entry = decoded_boxes(wide)
    lo, hi, entry = lo.astype(np.float64), hi.astype(np.float64), entry.astype(np.int64)  # (W, 4, 3), (W, 4)
    pr = np.arange(n_rays)
    pn = np.zeros(n_rays, np.int64)
    while pr.size:
        o = o_all[pr][:, None, :]
        inv = inv_all[pr][:, None, :]
        with np.errstate(invalid="ignore"):
            t0 = (lo[pn] - o) * inv
            t1 = (hi[pn] - o) * inv
        near = np.where(inv >= 0, t0, t1).max(axis=2)
        far = np.where(inv >= 0, t1, t0).min(axis=2)
        hit = (np.maximum(near, tmin) <= np.minimum(far, best_t[pr][:, None]))   # (P, 4)
        e = entry[pn]
        hr, hs = np.nonzero(hit)
        ray, ent = pr[hr], e[hr, hs]
        is_leaf = (ent & LEAF_BIT) != 0
        lr, le = ray[is_leaf], ent[is_leaf]
        if lr.size:
            c = ((le >> COUNT_SHIFT) & (MAX_LEAF_COUNT - 1)) + 1
            f = le & (MAX_FIRST - 1)
            rr = np.repeat(lr, c)
            off = np.cumsum(c) - c
            tt = np.repeat(f - off, c) + np.arange(int(c.sum()))
            t, _, _, ok = moller_trumbore(tris[tt, 0], tris[tt, 1], tris[tt, 2], o_all[rr], d_all[rr])
            ok &= (t > tmin) & (t < best_t[rr])
            rr, tt, t = rr[ok], tt[ok], t[ok]
            if rr.size:
                s = np.lexsort((tt, t, rr))
                rr, tt, t = rr[s], tt[s], t[s]
                head = np.concatenate(([True], rr[1:] != rr[:-1]))
                best_t[rr[head]] = t[head]
                best_tri[rr[head]] = tt[head]
        pr, pn = ray[~is_leaf], ent[~is_leaf]
    return np.where(best_tri < 0, np.inf, best_t), best_tri
