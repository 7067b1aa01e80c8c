"""Where `pt`'s (or `bdpt`'s) trace pass spends its GPU time: variants of its compute program, timed alike.

    python benchmarks/gpu_pt_variants.py SCENE... [--size 1920x1080] [--max-depth 32]
        [--integrator pt|bdpt] [--variants main,base,s8x8,...] [--base-tree CHECKOUT] [--reps 7]
        [--out FILE.json] [--dump-binaries DIR]

For each scene the renderer is built once (--integrator, default pt, 1 spp, path length --max-depth); its trace
program's source (lift_gl/passes/trace.py) is then edited into variants (VARIANTS below),
each compiled into its own program, and the programs are dispatched in turn, round after
round (order reversed every other round), over the same G-buffer, scene buffers and uniforms.
Each dispatch is timed by a GL timer query (on llvmpipe by the CPU clock between two
ctx.finish()); the JSON keeps every time and the median. Some variants are exact (same
image: work-group shape, stack placement); others are diagnostics that change the image on
purpose (no shadow rays, shorter paths) to tell what a part of the path costs. For each
variant the image's difference from the first is recorded, so an "exact" variant that
changed the picture shows up. `main` is the trace program of another checkout
(--base-tree: its shaders/ and plugins/), as it ran there, so a change is measured against
the code it replaces in the same process. `tree` is the plugin of that checkout (its plugins/NAME
and shaders/) built as this renderer builds its own (work-group shape, stack placement, the
manifest's defines): an A/B of a plugin's code on this host, e.g. bdpt against a commit:
    python benchmarks/gpu_pt_variants.py SCENE --integrator bdpt --variants base,tree --base-tree ../base
For bdpt the two images differ by their random numbers (mean_rgb tells whether they agree).
`--tree NAME=CHECKOUT` (repeatable) adds more checkouts' plugins as variants named NAME.

bdpt diagnostics (where bdpt's GPU time goes; docs/integrators.md "bdpt"): bdpt_no_lt,
bdpt_no_connect, bdpt_light_only, bdpt_camera_only, bdpt_splat_plain, rr1 remove or change one
part of its work (bdpt's prepass, the light pass, runs untimed before each dispatch, its splats
dropped: it is timed as its own pass by lift-gl bench and benchmarks/gpu.py); the counting
variants' images are per-pixel counts (count_rays: closest-hit and shadow rays, and for bdpt
light-tracing joins; bdpt_count_paths: light vertices, camera vertices, s >= 2 joins, with the
loop iterations a warp of 8x4 runs against those its lanes need, `warp` in the JSON).

The G-buffer pass is timed too: rasterized with fragment-shader variants (`gbuffer` the real
one, `gbuffer_flat` writing constants, `gbuffer_nodepthwrite` without gl_FragDepth:
diagnostics of what rasterizing costs on this GPU), `traced` (TracedGBufferPass, one camera
ray a pixel) and `traced_visibility` (its program for frames, writing only the visibility).
Variant `camera`: pt with camera rays traced in the trace pass instead of a G-buffer
(primary = "camera", one sample a frame).

Shared memory (docs/gpu.md, "How a frame runs": the stack): pad2k ... pad32k give each work
group that much more shared memory (a diagnostic of what occupancy and the L1 cache it displaces
cost), groups8/16/24 trace with node-group stack entries (LIFT_BVH_GROUP_STACK) that many deep
(exact where the tree has no more levels), the _s8x8 / _s16x4 ones in 64-invocation groups.

Occupancy, carried paths, queue order (docs/gpu.md): occ_NAME is variant NAME with the occupancy
probe of benchmarks/gpu_occupancy.py (NVIDIA only; the JSON's `occupancy`: the warps an SM held;
the probe's atomics make its time meaningless); maxreg64/96 add NVIDIA's register pragma
(ignored); with --option carry_paths=on the base has the carry code and nocarry, carry_nostores,
carry_nopark take it or its parts out; queue_order_long_first, _short_first and _identity hand
out the pixel queue's tiles in an order computed from the G-buffer's albedo (tile_orders).

Coherent sampling (docs/gpu.md, "Coherent sampling"): coherent_tiles is pt's `coherent_sampling`
on (a work group's tile of pixels drawing the same random numbers, the tiles' grid moving from
frame to frame), coherent_fixed the same with the grid fixed, coherent_interleave2/4 with
interleaved tiles; coherent_rr shares only the roulette's number by tile; coherent_light,
coherent_bounce (and their _rr forms) share only the light sample's, the BSDF sample's numbers
(and the roulette's); for bdpt, bdpt_own_light (its coherent sampling: the light subpath drawn
from the pixel's own numbers), bdpt_shared (both subpaths shared by the tile) and
bdpt_own_camera (the camera subpath the pixel's own, the light subpath shared). All change the
image on purpose (not exact), each pixel's expectation unchanged.

--dump-binaries writes each variant's glGetProgramBinary blob (NVIDIA's holds its assembly
text, from which local-memory arrays and register use can be read).
"""
from __future__ import annotations

import argparse
import ctypes
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from lift_gl.report.gpu_clock import ClockReader, warm_up  # noqa: E402
from lift_gl.report.records import write_json  # noqa: E402
from lift_gl.passes.common import groups, tile_dispatch_size  # noqa: E402


# ---- source edits ----

def _sub(text: str, old: str, new: str, count: int = 1) -> str:
    if text.count(old) < 1:
        raise ValueError(f"variant edit: {old!r} not in the source")
    return text.replace(old, new) if count == 0 else text.replace(old, new, count)


def _after_version(text: str, line: str) -> str:
    """The program with `line` put right after its first line (#version)."""
    return text.replace("\n", f"\n{line}\n", 1)


def shape(x: int, y: int, shared: bool = True):
    """Work groups of x by y invocations, the BVH stack in shared memory or local arrays
    (LIFT_BVH_SHARED_STACK, shaders/lift/bvh.glsl)."""
    def edit(text):
        text = re.sub(r"layout\(local_size_x = \d+, local_size_y = \d+\) in;",
                      f"layout(local_size_x = {x}, local_size_y = {y}) in;", text)
        text = re.sub(r"#define LIFT_BVH_SHARED_STACK \d+\n", "", text)
        if shared:
            text = _after_version(text, f"#define LIFT_BVH_SHARED_STACK {x * y}")
        return text
    edit.local = (x, y)
    return edit


def no_shadow_rays(text: str) -> str:
    """Diagnostic: every shadow ray unblocked (what tracing them costs), traced alone or in one
    loop with the next ray (trace_shadow_and_next, LIFT_TRACE_PAIRED): both are edited, as trees
    that pair the two rays trace their shadow rays in that loop only."""
    text = _sub(text, "bool trace_occluded(Ray ray) {", "bool trace_occluded(Ray ray) { return false; }\nbool unused_occluded(Ray ray) {")
    head = "bool trace_shadow_and_next(bool shadow_wanted, Ray shadow, bool next_wanted, Ray next, out Hit hit) {"
    return _sub(text, head, head + "\n    shadow_wanted = false;")


def shadow_rays_of(delta: bool):
    """Diagnostic: pt's shadow rays traced only for the light samples of delta lights (distant
    lights: `delta` true) or only for the others (environment, emitters), the rest counted
    unblocked: what each kind's shadow rays cost."""
    def edit(text: str) -> str:
        return _sub(text, "                shadow_wanted = true;",
                    f"                shadow_wanted = {'' if delta else '!'}ls.is_delta;")
    return edit


def no_path_steps(text: str) -> str:
    """The host's loop over samples calling radiance() instead of the vertex-at-a-time loop."""
    return _sub(text, "#define LIFT_PATH_STEPS\n", "")


def no_textures(text: str) -> str:
    """Diagnostic: every texture lookup returns white (what bilinear lookups in the images buffer cost)."""
    return _sub(text, "vec3 texture_tint(uint id, vec2 uv) {", "vec3 texture_tint(uint id, vec2 uv) { return vec3(1.0);")


def no_srgb_decode(text: str) -> str:
    """Diagnostic: texels squared instead of the exact sRGB curve (what its pow() per channel costs)."""
    return _sub(text, "vec3 srgb_to_linear(vec3 c) {", "vec3 srgb_to_linear(vec3 c) { return c * c;")


def env_uniform(text: str) -> str:
    """Diagnostic: environment light samples uniform on the sphere instead of by the map's
    luminance (what the two binary searches over its CDFs cost; the MIS weights no longer match)."""
    return _sub(text, "bool ok = sample_env_map(u, wi, pdf, texel) && pdf > 0.0 && pdf < 1e30;\n"
                      "        radiance *= texel;\n        return ok;",
                "wi = sample_uniform_sphere(u);\n        pdf = pdf_uniform_sphere(wi);\n"
                "        radiance = env_radiance(wi);\n        return true;")


def env_constant(text: str) -> str:
    """Diagnostic: the environment's radiance without its map (what the bilinear map lookup costs)."""
    return _sub(text, "if (u_env_map_size.x > 0u) return u_env_radiance * env_map_lookup(", "if (false) return u_env_radiance * env_map_lookup(")


def no_light_samples(text: str) -> str:
    """Diagnostic: no next-event estimation at all (no light sample, no shadow ray)."""
    return _sub(text, "bool sample_light(vec3 p, vec3 u, out LightSample ls) {",
                "bool sample_light(vec3 p, vec3 u, out LightSample ls) { ls.pdf = 0.0; return false; }\n"
                "bool unused_sample_light(vec3 p, vec3 u, out LightSample ls) {")


def define(name: str):
    """The program with `name` #defined (e.g. LIFT_COHERENT_SAMPLING); "NAME VALUE" replaces a
    definition of NAME the renderer made."""
    def edit(text):
        text = undefine(name.split()[0])(text)
        return _after_version(text, f"#define {name}")
    return edit


def undefine(name: str):
    """The program without the renderer's #define of `name` (a flag or a number: not the
    shaders' own definitions in terms of other macros)."""
    def edit(text):
        return re.sub(rf"#define {name}( \d+)?\n", "", text)
    return edit


def pragma(option: str):
    """The program with `#pragma optionNV(option)` after #version: NVIDIA's GLSL compiler
    options (unroll none, ifcvt none, inline none, maxregcount N; other drivers ignore them),
    to tell how much of a variant's time is the compiler's choice of code shape."""
    def edit(text):
        return _after_version(text, f"#pragma optionNV({option})")
    return edit


def packed_local_stack(text: str) -> str:
    """The local stack array (no LIFT_BVH_SHARED_STACK) as uvec4 elements, four entries each,
    instead of one uint an element: NVIDIA's assembly declares local arrays in vec4 elements
    (the binary's lmem_vec4), so a uint array may take four times its bytes."""
    old = ("#define LIFT_BVH_STACK_DECLARE uint lift_bvh_stack[LIFT_BVH_STACK];\n"
           "#define LIFT_BVH_STACK_SET(i, v) lift_bvh_stack[i] = (v)\n"
           "#define LIFT_BVH_STACK_GET(i) lift_bvh_stack[i]\n")
    new = ("#define LIFT_BVH_STACK_DECLARE uvec4 lift_bvh_stack4[(LIFT_BVH_STACK + 3) / 4];\n"
           "#define LIFT_BVH_STACK_SET(i, v) lift_bvh_stack4[uint(i) >> 2u][uint(i) & 3u] = (v)\n"
           "#define LIFT_BVH_STACK_GET(i) lift_bvh_stack4[uint(i) >> 2u][uint(i) & 3u]\n")
    return _sub(text, old, new)


def stack_entries(n: int):
    """The 4-wide traversal's stack declared with n entries instead of the tree's own bound
    (LIFT_BVH_STACK_SIZE, accel/wide.stack_size): what the shared memory it takes costs."""
    def edit(text):
        text, k = re.subn(r"#define LIFT_BVH_STACK_SIZE \d+\n", f"#define LIFT_BVH_STACK_SIZE {n}\n", text)
        if k != 1:
            raise ValueError("variant edit: no LIFT_BVH_STACK_SIZE in the source (a binary tree?)")
        return text
    return edit


def children_entries(n: int):
    """The 4-wide traversal's stack of child entries, n deep, where the renderer chose node
    groups (accel/wide.stack_defines): exact where n >= the tree's stack_bound."""
    def edit(text):
        return stack_entries(n)(undefine("LIFT_BVH_SHARED_DEPTH")(undefine("LIFT_BVH_GROUP_STACK")(text)))
    return edit


def group_entries(n: int, shared: int | None = None, local: tuple[int, int] | None = None):
    """Node-group stack entries (LIFT_BVH_GROUP_STACK), n deep: all in shared memory, or only
    the top `shared` (LIFT_BVH_SHARED_DEPTH), whatever the renderer chose; in work groups of
    `local` invocations (shape) where given. Exact where n >= the tree's levels."""
    depth = undefine("LIFT_BVH_SHARED_DEPTH") if shared is None else shared_depth(shared)
    return compose(define("LIFT_BVH_GROUP_STACK"), stack_entries(n), depth, *([shape(*local)] if local else []))


def shared_depth(n: int):
    """The top n entries of the traversal stack in shared memory (LIFT_BVH_SHARED_DEPTH, lift/bvh.glsl;
    by default all of them), the rest spilled to a local array."""
    return define(f"LIFT_BVH_SHARED_DEPTH {n}")


def pad_shared(n_bytes: int):
    """n_bytes more shared memory a work group, written and read so that the compiler keeps
    it: what shared memory costs the program (fewer groups fit on an SM, and the L1 cache that
    shares its memory shrinks; docs/gpu.md "A stack of node groups"). A diagnostic: the image
    is the same."""
    words = n_bytes // 4
    def edit(text):
        text = _sub(text, "void main() {\n", "shared uint lift_pad[%d];\nvoid main() {\n"
                    "    lift_pad[(gl_LocalInvocationIndex * 131u + gl_WorkGroupID.x) %% %du] = gl_WorkGroupID.y;\n"
                    "    barrier();\n"
                    "    if (lift_pad[(gl_LocalInvocationIndex * 7u + gl_WorkGroupID.y) %% %du] == 0xFFFFFFFFu) return;\n"
                    % (words, words, words))
        return text
    return edit


# ---- bdpt diagnostics (where bdpt's GPU time goes) ----
# Each removes or replaces one part of bdpt's work; none keeps the image. Anchors are bdpt's source as of this script; an edit whose anchor is gone raises.

def bdpt_no_light_tracing(text: str) -> str:
    """Diagnostic: no t = 1 strategy (the light subpath still traced and stored)."""
    return _sub(text, "if (strategy_kept(s, 1)) strategy_light_tracing(y, y_prev);", "")


def bdpt_no_connect(text: str) -> str:
    """Diagnostic: no s >= 2, t >= 2 joins (light tracing, s = 0 and s = 1 kept)."""
    return _sub(text, "if (strategy_kept(s, t)) join = strategy_connect(y, y_prev, z, z_prev);", "")


def bdpt_light_only(text: str) -> str:
    """Diagnostic: only the light subpath, traced and stored (its last vertex read back so that
    the stores stay), no joins, no camera subpath."""
    text = bdpt_no_light_tracing(text)
    return _sub(text, "return camera_subpath(ray, hit, bdpt_depth_limit(), light_vertices, rng);",
                "return 1e-30 * light_vertex(max(light_vertices - 1, 0)).beta;")


def bdpt_camera_only(text: str) -> str:
    """Diagnostic: no light subpath: the camera subpath with s = 0 and s = 1 only (pt's work)."""
    return _sub(text, "int light_vertices = light_subpath(depth_limit, rng);", "int light_vertices = 0;")


def bdpt_splat_plain(text: str) -> str:
    """Diagnostic: splats as plain read-add-writes instead of atomics (races: wrong sums)."""
    return _sub(text, "atomicAdd(lift_splats[index], value);", "lift_splats[index] += value;")


def _counting(text: str, edits) -> str:
    """The image becomes three per-pixel counts (diag_r/g/b, incremented by `edits`: (anchor,
    code put after it)); splats are off so nothing else lands in the frame, and pixels are not
    taken from a queue (a lane's counts would run on over its pixels)."""
    text = undefine("LIFT_PIXEL_QUEUE")(text)
    # declared where the library starts, after its #extension if it has one (GLSL takes none later)
    extension = "#extension GL_NV_shader_atomic_float : require\n#endif\n"   # lift/host.glsl's, in an #if
    anchor = extension if extension in text else "#line 200001\n"
    text = _sub(text, anchor, anchor + "float diag_r = 0.0, diag_g = 0.0, diag_b = 0.0;\n")
    text = _sub(text, "imageStore(u_frame_out, pixel, vec4(sum, valid));",
                "imageStore(u_frame_out, pixel, vec4(diag_r, diag_g, diag_b, valid));", 0)
    if "void splat(vec2 pixel_pos, vec3 value) {" in text:
        text = _sub(text, "void splat(vec2 pixel_pos, vec3 value) {", "void splat(vec2 pixel_pos, vec3 value) { return;", 0)
    for anchor, code in edits:
        text = _sub(text, anchor, anchor + " " + code, 0)
    return text


def count_rays(text: str) -> str:
    """Counts per pixel: closest-hit rays (r), shadow rays (g), and for bdpt attempted splats (b)."""
    edits = [("bool trace_closest(Ray ray, out Hit hit) {", "diag_r += 1.0;"),
             ("bool trace_occluded(Ray ray) {", "diag_g += 1.0;")]
    if "void strategy_light_tracing(PathVertex y, PathVertex y_prev) {" in text:
        edits.append(("void strategy_light_tracing(PathVertex y, PathVertex y_prev) {", "diag_b += 1.0;"))
    return _counting(text, edits)


def bdpt_count_paths(text: str) -> str:
    """Counts per pixel: light subpath vertices (r, y0 included, as the prepass stored them), camera
    vertices joined (g, z1 on), s >= 2 joins attempted (b). The image of this variant is the counts."""
    return _counting(text, [
        ("int light_vertices = stored_light_vertices();", "diag_r += float(light_vertices);"),
        ("vec3 camera_vertex_joins(PathVertex z, PathVertex z_prev, float emitter_pdf, int t, int light_vertices,\n"
         "                         inout Rng rng) {", "diag_g += 1.0;"),
        ("Join strategy_connect(PathVertex y, PathVertex y_prev, PathVertex z, PathVertex z_prev) {", "diag_b += 1.0;")])


def warp_costs(light: np.ndarray, camera: np.ndarray, depth: int, local=(8, 4)) -> dict:
    """From per-pixel light-vertex and camera-vertex counts (bdpt_count_paths), the iterations
    of bdpt's loops per lane and per warp (a warp runs a loop as long as its longest lane):
    camera vertex t = 2.. joins s = 0..min(max(L, 1), depth + 2 - t). Returns means per pixel."""
    h, w = light.shape
    lx, ly = local
    h2, w2 = h - h % ly, w - w % lx
    L = light[:h2, :w2].reshape(h2 // ly, ly, w2 // lx, lx).transpose(0, 2, 1, 3).reshape(-1, lx * ly)
    C = camera[:h2, :w2].reshape(h2 // ly, ly, w2 // lx, lx).transpose(0, 2, 1, 3).reshape(-1, lx * ly)
    lane_joins = np.zeros_like(L)
    warp_joins = np.zeros(L.shape[0])
    for t in range(2, int(C.max()) + 2):
        alive = C >= t - 1
        iters = np.where(alive, np.minimum(np.maximum(L, 1), depth + 2 - t) + 1, 0)
        lane_joins += iters
        warp_joins += iters.max(axis=1)
    return {"join_iterations_lane": float(lane_joins.mean()), "join_iterations_warp": float(warp_joins.mean()),
            "camera_steps_lane": float(C.mean()), "camera_steps_warp": float(C.max(axis=1).mean()),
            "light_steps_lane": float(L.mean()), "light_steps_warp": float(L.max(axis=1).mean()),
            "light_max": float(L.max()), "camera_max": float(C.max())}


QUEUE_COUNTERS_MAX = 256  # uints the harness's queue buffer holds (queue_spread, queue_sm)


def queue_spread(k: int):
    """The pixel queue as k counters instead of one (fewer atomics on one address): counter c
    owns tiles c, c + k, c + 2k... (a tile stays one warp's 32 pixels), a work group starts at
    its own counter and moves to the next when that one's tiles are gone. The same pixels, each
    once; the order differs, not the image."""
    assert 1 <= k <= QUEUE_COUNTERS_MAX

    def edit(text):
        text = _sub(text, "coherent buffer LiftPixelQueue { uint lift_queue_next; };",
                    f"coherent buffer LiftPixelQueue {{ uint lift_queue_next[{k}]; }};")
        return _sub(text, "uint item = atomicAdd(lift_queue_next, 1u);",
                    "uint item = items;\n"
                    f"            uint first_counter = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) % {k}u;\n"
                    f"            for (uint k = 0u; k < {k}u && item >= items; ++k) {{\n"
                    f"                uint c = (first_counter + k) % {k}u;\n"
                    "                uint n = atomicAdd(lift_queue_next[c], 1u);\n"
                    f"                item = (c + {k}u * (n / group)) * group + n % group;\n"
                    "            }")
    return edit


def queue_per_sm(text: str) -> str:
    """The pixel queue as one counter per SM (GL_NV_shader_thread_group's gl_SMIDNV and
    gl_SMCountNV), counter s owning the s-th of gl_SMCountNV runs of consecutive tiles: the
    warps of one SM work on one part of the image at a time (its L1 sees one region), and an SM
    whose run is done takes from the next. The same image; NVIDIA only."""
    text = _after_version(text, "#extension GL_NV_shader_thread_group : require")
    text = _sub(text, "coherent buffer LiftPixelQueue { uint lift_queue_next; };",
                f"coherent buffer LiftPixelQueue {{ uint lift_queue_next[{QUEUE_COUNTERS_MAX}]; }};")
    return _sub(text, "uint item = atomicAdd(lift_queue_next, 1u);",
                "uint item = items;\n"
                f"            uint sms = min(gl_SMCountNV, {QUEUE_COUNTERS_MAX}u), all_tiles = tiles.x * tiles.y;\n"
                "            uint run = (all_tiles + sms - 1u) / sms;\n"
                "            for (uint k = 0u; k < sms && item >= items; ++k) {\n"
                "                uint c = (gl_SMIDNV + k) % sms;\n"
                "                if (lift_queue_next[c] >= run * group) continue;   // done: a read, not an atomic\n"
                "                uint n = atomicAdd(lift_queue_next[c], 1u);\n"
                "                uint tile = c * run + n / group;\n"
                "                if (n / group < run && tile < all_tiles) item = tile * group + n % group;\n"
                "            }")


def queue_morton(text: str) -> str:
    """The pixel queue's tiles in Morton (Z) order instead of row by row: the warps running at
    once work on a compact part of the image rather than a band across it. The order covers the
    power-of-two square around the tile grid; items off the grid are skipped (another take
    from the queue). The same image."""
    return _sub(text, "uint item = atomicAdd(lift_queue_next, 1u);",
                "uint item = items;\n"
                "            uint side = 1u;\n"
                "            while (side < max(tiles.x, tiles.y)) side *= 2u;\n"
                "            for (;;) {\n"
                "                uint n = atomicAdd(lift_queue_next, 1u);\n"
                "                uint m = n / group;\n"
                "                if (m >= side * side) break;\n"
                "                uint tx = 0u, ty = 0u;\n"
                "                for (uint b = 0u; b < 16u; ++b) {\n"
                "                    tx |= ((m >> (2u * b)) & 1u) << b;\n"
                "                    ty |= ((m >> (2u * b + 1u)) & 1u) << b;\n"
                "                }\n"
                "                if (tx < tiles.x && ty < tiles.y) { item = (ty * tiles.x + tx) * group + n % group; break; }\n"
                "            }")


def _group_invocations(text: str) -> int:
    m = re.search(r"layout\(local_size_x = (\d+), local_size_y = (\d+)\) in;", text)
    return int(m.group(1)) * int(m.group(2))


def regen_primary(text: str) -> str:
    """The queued megakernel without its pixel's camera ray and G-buffer hit kept for the
    pixel's next sample: a later sample computes both again (a G-buffer read), so they are not
    live across every traversal (fewer registers). The same image."""
    return _sub(text, "            rng = lift_sample_rng(pixel, s);\n            path = path_start(primary_ray, primary_hit);\n            continue;",
                "            rng = lift_sample_rng(pixel, s);\n            Ray again = camera_ray(vec2(pixel) + u_jitter);\n"
                "            path = path_start(again, gbuffer_hit(pixel, again));\n            continue;")


def pending_shared(text: str) -> str:
    """pt: what a vertex's light sample adds if its shadow ray is unblocked, kept in shared
    memory across the traversal instead of three registers. The same image."""
    n = _group_invocations(text)
    text = _sub(text, "bool path_step(inout PathState path, inout Rng rng) {",
                f"shared vec3 lift_pending_light[{n}];\nbool path_step(inout PathState path, inout Rng rng) {{")
    return _sub(text, "    if (!trace_shadow_and_next(shadow_wanted, shadow_ray, goes_on, next_ray, next_hit) && shadow_wanted)\n        path.L += L_light;",
                "    lift_pending_light[gl_LocalInvocationIndex] = L_light;\n"
                "    if (!trace_shadow_and_next(shadow_wanted, shadow_ray, goes_on, next_ray, next_hit) && shadow_wanted)\n"
                "        path.L += lift_pending_light[gl_LocalInvocationIndex];")


def drop_at_end(text: str) -> str:
    """Diagnostic of the frame's tail (docs/gpu.md, "Measuring": the last lanes running the
    longest paths alone): a lane whose path is still under way when the pixel queue has run out
    drops it and ends. The image loses those paths' samples (not exact); the time is what a
    frame would take if such paths went on in the next frame's dispatch instead (less the cost
    of saving and resuming them): an upper bound on what carrying paths across frames gains."""
    return _sub(text, "        if (path_step(path, rng)) {\n",
                "        if (path_step(path, rng)) {\n            if (lift_queue_next >= items) {\n"
                "                imageStore(u_frame_out, pixel, vec4(sum, valid));   // the samples done so far\n"
                "                break;\n            }\n")


# Coherent sampling (docs/gpu.md): `coherent_tiles` is pt's parameter `coherent_sampling` on
# (shaders/lift/host_tiles.glsl: a tile's pixels draw the same random numbers);
# coherent_parts shares only some of a vertex's numbers.
def fixed_tiles(text: str) -> str:
    """Coherent sampling's tiles in the image's grid in every frame (the noise's blocks then
    stay in place) instead of a grid offset from frame to frame."""
    return _sub(text, "ivec2 lift_tile_offset(uvec2 tile) {  // this frame's offset of the grid of blocks (k x k tiles)",
                "ivec2 lift_tile_offset(uvec2 tile) {\n    return ivec2(0);")


def coherence_defines(text: str) -> dict:
    """The coherent-sampling defines of a program's source, for tile_dispatch_size: the first
    #define of each name (the renderer's or a variant's, before the shader's own default)."""
    found = {}
    for name, value in re.findall(r"#define (LIFT_COHERENT_SAMPLING|LIFT_COHERENT_INTERLEAVE)\b ?(\d*)", text):
        found.setdefault(name, int(value or 1))
    return found


def coherent_parts(light: bool = False, bounce: bool = False, roulette: bool = False):
    """Some dimensions of a vertex's random numbers shared by the tile (fixed 8x4 tiles, keyed
    on tile, frame, sample, depth and dimension): the roulette's one (coherent_rr: a warp's
    paths end together), the light sample's three (light, point), the BSDF sample's three (lobe,
    direction). The pixel's own numbers are still drawn (and dropped) for those dimensions, so
    that the others are the ones the base draws. Diagnostics of which shared dimension makes a
    warp's rays coherent."""
    def edit(text):
        text = _sub(text, "bool path_step(inout PathState path, inout Rng rng) {",
                    "uint lift_rr_key;\n"
                    "float lift_shared_u(int depth, uint dim) {\n"
                    "    return float(pcg_hash(lift_rr_key + uint(depth) * 0x9e3779b9u + dim * 0x85ebca6bu) >> 8u) * (1.0 / 16777216.0);\n"
                    "}\n"
                    "vec3 lift_shared3(int depth, uint dim) {\n"
                    "    return vec3(lift_shared_u(depth, dim), lift_shared_u(depth, dim + 1u), lift_shared_u(depth, dim + 2u));\n"
                    "}\n"
                    "bool path_step(inout PathState path, inout Rng rng) {")
        if light:
            text = _sub(text, "if (sample_light(s.p, vec3(rng_next(rng), sample_pair(rng)), ls)",
                        "vec3 lift_u_light = vec3(rng_next(rng), sample_pair(rng));\n"
                        "        if (sample_light(s.p, lift_shared3(depth, 1u) + 0.0 * lift_u_light, ls)")
        if bounce:
            text = _sub(text, "bool goes_on = bsdf_sample(m, wo, vec3(sample_pair(rng), rng_next(rng)), bs);",
                        "vec3 lift_u_bsdf = vec3(sample_pair(rng), rng_next(rng));\n"
                        "    bool goes_on = bsdf_sample(m, wo, lift_shared3(depth, 4u) + 0.0 * lift_u_bsdf, bs);")
        if roulette:
            text = _sub(text, "if (rng_next(rng) >= survive) goes_on = false;",
                        "if (lift_shared_u(depth, 0u) + 0.0 * rng_next(rng) >= survive) goes_on = false;")
        return _sub(text, "    return rng_init_pixel_sample(lift_rng_key(uvec2(pixel)), u_frame",
                    "    uvec2 lift_tile = uvec2(pixel) / uvec2(8u, 4u);\n"
                    "    lift_rr_key = pcg_hash(lift_tile.x + pcg_hash(lift_tile.y + pcg_hash(u_frame + pcg_hash(s + u_seed))));\n"
                    "    return rng_init_pixel_sample(lift_rng_key(uvec2(pixel)), u_frame")
    return edit


def bdpt_coherent(light_shared: bool, camera_own: bool = False):
    """bdpt with coherent sampling (which draws each pixel's light subpath from the host's
    lift_own_rng, the pixel's own numbers) and instead its light subpath shared by the tile
    (`light_shared`: not kept, its light tracing splats one path per tile), or with
    that and the camera subpath drawn from the pixel's own numbers (`camera_own`)."""
    def edit(text):
        text = define("LIFT_COHERENT_SAMPLING")(text)
        if light_shared:
            text = _sub(text, "int light_vertices = light_subpath(depth_limit, lift_own_rng);",
                        "int light_vertices = light_subpath(depth_limit, rng);")
        if camera_own:
            text = _sub(text, "return camera_subpath(ray, hit, bdpt_depth_limit(), light_vertices, rng);",
                        "return camera_subpath(ray, hit, bdpt_depth_limit(), light_vertices, lift_own_rng);")
        return text
    return edit


# The plugin parameters of the scene being measured (run_scene sets it): const_params needs
# their values, which a source edit alone does not know.
CURRENT_PARAMS: dict = {}


def const_params(text: str) -> str:
    """The plugin's parameters as compile-time constants instead of uniforms (their values this
    run), so that the compiler can fold what depends on them (the Russian roulette's tests, the
    bounce window). The same image: what specialising a render whose settings cannot change
    would gain."""
    for name, value in CURRENT_PARAMS.items():
        m = re.search(rf"uniform (int|uint|float|bool) {name};", text)
        if m is None:
            continue
        glsl = {"bool": "true" if value else "false", "float": repr(float(value)),
                "int": str(int(value)), "uint": f"{int(value)}u"}[m.group(1)]
        text = text.replace(m.group(0), f"const {m.group(1)} {name} = {glsl};", 1)
    return text


def live_plus(count: int):
    """Diagnostic of register pressure: `count` more floats live across pt's traversal (made
    before it from the path's state, used after it only where u_frame is 0xffffffff, which no
    frame is): what more live state costs, so roughly what less would gain. The same image."""
    def edit(text):
        made = "".join(f"    float lift_extra{i} = path.throughput[{i % 3}] * {1.0 + 0.01 * (i + 1)} + float(path.depth + {i});\n"
                       for i in range(count))
        used = " + ".join(f"lift_extra{i}" for i in range(count))
        text = _sub(text, "    if (!trace_shadow_and_next(shadow_wanted, shadow_ray, goes_on, next_ray, next_hit) && shadow_wanted)",
                    made + "    if (!trace_shadow_and_next(shadow_wanted, shadow_ray, goes_on, next_ray, next_hit) && shadow_wanted)")
        return _sub(text, "    if (!goes_on) return false;\n    path.ray = next_ray;",
                    f"    if (u_frame == 0xffffffffu) path.L += vec3({used});\n    if (!goes_on) return false;\n    path.ray = next_ray;")
    return edit


# Occupancy probe (NVIDIA: GL_NV_shader_thread_group): how many warps an SM holds at once.
# The same probe as benchmarks/gpu_occupancy.py's (OCCUPANCY_PROBE there), here edited into a
# trace program.
sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/, also when loaded by path (tests)
from gpu_occupancy import OCCUPANCY_BINDING, OCCUPANCY_WORDS, occupancy_probe, occupancy_summary  # noqa: E402


def occupancy(edit=None):
    """Diagnostic of register pressure: the variant `edit` made (None: the base) with the
    occupancy probe (gpu_occupancy.py): warps each SM held at once, which is what the
    program's registers (and shared memory) allowed. Lane 0 of a warp counts its warp in when
    the warp starts and out when that lane reports at the end."""
    def probed(text):
        text = edit(text) if edit else text
        enter, leave, decl = occupancy_probe()
        text = _after_version(text, "#extension GL_NV_shader_thread_group : require")
        # the buffer before the report (lift/host_report.glsl), which main() follows
        text = _sub(text, "void lift_report_invocation() {", decl + "void lift_report_invocation() {\n" + leave)
        return _sub(text, "void main() {", "void main() {\n" + enter)
    probed.local = getattr(edit, "local", None)
    return probed


# Variants whose edit is meant for the light subpath as well (bdpt's, coherent sampling's): a
# two-pass plugin's prepass (its light subpaths, passes/prepass.py) is edited alike and run
# before the variant's trace dispatch. Other variants keep the renderer's prepass.
PREPASS_EDITED = ("bdpt_", "coherent_")


def prepass_variant(edit, text: str) -> str | None:
    """The prepass source with a variant's edit, or None where the edit does not apply there
    (an anchor only the trace program has) or changes nothing."""
    if edit is None:
        return None
    try:
        edited = edit(text)
    except ValueError:
        return None
    return edited if edited != text else None


def variant(name: str):
    """VARIANTS[name], or for occ_NAME that variant with the occupancy probe."""
    if name.startswith("occ_") and name[4:] in VARIANTS:
        edit, over, exact = VARIANTS[name[4:]]
        return occupancy(edit), over, exact
    return VARIANTS[name]


# What of the carry code (LIFT_CARRY_PATHS, with --option carry_paths=on) costs a frame that
# parks nothing: each edit takes one part out (not exact where that part would run).
def carry_no_extra_stores(text: str) -> str:
    """The carry code without its image stores besides the pixel's usual one: the parked
    pixel's finished samples and the late image's two."""
    text = _sub(text, "                    imageStore(u_frame_out, pixel, vec4(sum, valid));  // the samples it finished\n", "")
    return _sub(text, "    imageStore(u_late_out, pixel, vec4(sum, valid));\n    imageStore(u_late_tag_out, pixel, uvec4(u_late_tag));\n",
                "    lift_carried[0].s = floatBitsToUint(sum.x + valid);\n")


def carry_no_park(text: str) -> str:
    """The carry code without its park block."""
    start = text.index("            if (u_park != 0u && !late && LIFT_QUEUE_RAN_OUT) {")
    end = text.index("#endif\n            continue;", start)
    return text[:start] + text[end:]


# The pixel queue's tiles in another order (docs/gpu.md, "Alternatives measured and not
# kept"): item k's tile is lift_tile_order[k / group], an order the harness computes from the
# G-buffer (tile_orders).
TILE_ORDER_BINDING = 21


def queue_tile_order(text: str) -> str:
    """The queued megakernel taking its tiles in the order of a buffer (the same image)."""
    text = _sub(text, "void lift_trace_pixel_queue() {",
                f"layout(std430, binding = {TILE_ORDER_BINDING}) readonly buffer LiftTileOrder {{ uint lift_tile_order[]; }};\n"
                "void lift_trace_pixel_queue() {")
    return _sub(text, "uint tile = item / group, lane = item % group;",
                "uint tile = lift_tile_order[item / group], lane = item % group;")


def tile_orders(albedo: np.ndarray, local: tuple[int, int]) -> dict[str, np.ndarray]:
    """Orders of the image's tiles (local-sized, row by row as the queue numbers them) for the
    queue_order_ variants, by a guess of each tile's work: the expected path length under
    roulette by albedo, 1 / (1 - a), a the largest component of the first hit's albedo (at most
    0.95; 0 for a camera ray that left the scene), averaged over the tile. long_first: most
    work first, so that the last pixels taken (whose paths make the frame's tail) are the
    cheapest; short_first the reverse (a control); identity the queue's own order (what the
    lookup alone costs)."""
    h, w = albedo.shape[:2]
    lx, ly = local
    tx, ty = (w + lx - 1) // lx, (h + ly - 1) // ly
    a = np.zeros((ty * ly, tx * lx), np.float64)
    hit = albedo[..., 3] > 0
    a[:h, :w] = np.where(hit, 1.0 / (1.0 - np.minimum(albedo[..., :3].max(axis=-1), 0.95)), 0.0)
    key = a.reshape(ty, ly, tx, lx).mean(axis=(1, 3)).ravel()
    order = np.argsort(-key, kind="stable").astype(np.uint32)
    return {"queue_order_long_first": order, "queue_order_short_first": order[::-1].copy(),
            "queue_order_identity": np.arange(tx * ty, dtype=np.uint32)}


def compose(*edits):
    def edit(text):
        for e in edits:
            text = e(text)
        return text
    edit.local = next((e.local for e in reversed(edits) if hasattr(e, "local")), None)
    return edit


# name -> (source edit or None, uniform overrides, exact: same image as the base). The base
# is lift-gl's own trace program for this GL (on a GPU: 8x4, stack in shared memory);
# `main` (with --base-tree) is another checkout's. Variants of stack placement and traversal
# loops on main's bvh.glsl are in this script at commit 242c491.
VARIANTS = {
    "base": (None, {}, True),
    "s8x4": (shape(8, 4), {}, True),   # the stack in shared memory (the queued megakernel keeps it local)
    "s8x8": (shape(8, 8), {}, True),
    "s16x4": (shape(16, 4), {}, True),
    "s4x8": (shape(4, 8), {}, True),
    "s16x2": (shape(16, 2), {}, True),
    "s32x1": (shape(32, 1), {}, True),
    "s8x4_local": (shape(8, 4, shared=False), {}, True),
    "s4x8_local": (shape(4, 8, shared=False), {}, True),
    "s8x8_local": (shape(8, 8, shared=False), {}, True),
    "s32x1_local": (shape(32, 1, shared=False), {}, True),
    "s16x4_local": (shape(16, 4, shared=False), {}, True),
    "s4x4_local": (shape(4, 4, shared=False), {}, True),   # half a warp a work group
    "s16x1_local": (shape(16, 1, shared=False), {}, True),
    "packed_local": (compose(shape(8, 4, shared=False), packed_local_stack), {}, True),
    "nosteps": (compose(no_path_steps, shape(8, 4)), {}, True),
    "noshadow": (compose(no_shadow_rays, shape(8, 4)), {}, False),
    "notex": (no_textures, {}, False),
    "nosrgb": (no_srgb_decode, {}, False),
    "env_uniform": (env_uniform, {}, False),
    "env_const": (env_constant, {}, False),
    "env_both": (compose(env_uniform, env_constant), {}, False),
    "nolight": (no_light_samples, {}, False),
    "noshadow_base": (no_shadow_rays, {}, False),            # every shadow ray skipped, the base's layout
    "shadow_delta_only": (shadow_rays_of(True), {}, False),   # only distant lights' shadow rays traced
    "shadow_delta_none": (shadow_rays_of(False), {}, False),  # distant lights' shadow rays skipped
    "unpaired": (undefine("LIFT_TRACE_PAIRED"), {}, True),
    "queue": (define("LIFT_PIXEL_QUEUE"), {}, True),
    "queue_spread4": (queue_spread(4), {}, True),
    "queue_spread16": (queue_spread(16), {}, True),
    "queue_spread64": (queue_spread(64), {}, True),
    "queue_sm": (queue_per_sm, {}, True),
    "queue_morton": (queue_morton, {}, True),
    "regen_primary": (regen_primary, {}, True),
    "pending_shared": (pending_shared, {}, True),
    "drop_at_end": (drop_at_end, {}, False),
    "coherent_tiles": (define("LIFT_COHERENT_SAMPLING"), {}, False),
    "coherent_fixed": (compose(define("LIFT_COHERENT_SAMPLING"), fixed_tiles), {}, False),
    "coherent_interleave2": (compose(define("LIFT_COHERENT_SAMPLING"), define("LIFT_COHERENT_INTERLEAVE 2")), {}, False),
    "coherent_interleave4": (compose(define("LIFT_COHERENT_SAMPLING"), define("LIFT_COHERENT_INTERLEAVE 4")), {}, False),
    "coherent_rr": (coherent_parts(roulette=True), {}, False),
    "coherent_light": (coherent_parts(light=True), {}, False),
    "coherent_bounce": (coherent_parts(bounce=True), {}, False),
    "coherent_light_rr": (coherent_parts(light=True, roulette=True), {}, False),
    "coherent_bounce_rr": (coherent_parts(bounce=True, roulette=True), {}, False),
    "bdpt_own_light": (define("LIFT_COHERENT_SAMPLING"), {}, False),   # bdpt's coherent sampling as kept
    "bdpt_shared": (bdpt_coherent(light_shared=True), {}, False),
    "bdpt_own_camera": (bdpt_coherent(light_shared=True, camera_own=True), {}, False),
    "const_params": (const_params, {}, True),
    "live_plus4": (live_plus(4), {}, True),
    "live_plus8": (live_plus(8), {}, True),
    "live_plus16": (live_plus(16), {}, True),
    "noqueue": (undefine("LIFT_PIXEL_QUEUE"), {}, True),
    "queue_order_long_first": (queue_tile_order, {}, True),
    "queue_order_short_first": (queue_tile_order, {}, True),
    "queue_order_identity": (queue_tile_order, {}, True),
    "nocarry": (undefine("LIFT_CARRY_PATHS"), {}, True),   # with --option carry_paths=on: its code's cost
    "carry_nostores": (carry_no_extra_stores, {}, True),
    "carry_nopark": (carry_no_park, {}, True),
    "paired": (define("LIFT_TRACE_PAIRED"), {}, True),
    # NVIDIA's compiler options (on pt's trace only inline none changes its time: 0.09-0.16x)
    "nounroll": (pragma("unroll none"), {}, True),
    "noifcvt": (pragma("ifcvt none"), {}, True),
    "noinline": (pragma("inline none"), {}, True),
    "maxreg64": (pragma("maxregcount 64"), {}, True),    # with occ_: whether NVIDIA's GL honours it
    "maxreg96": (pragma("maxregcount 96"), {}, True),
    "depth1": (shape(8, 4), {"max_depth": 1}, False),
    "depth2": (shape(8, 4), {"max_depth": 2}, False),
    "depth4": (shape(8, 4), {"max_depth": 4}, False),
    "shared1": (shared_depth(1), {}, True),
    "shared2": (shared_depth(2), {}, True),
    "shared4": (shared_depth(4), {}, True),
    "shared6": (shared_depth(6), {}, True),
    "shared8": (shared_depth(8), {}, True),
    "shared16": (shared_depth(16), {}, True),
    "shared24": (shared_depth(24), {}, True),
    "stack16": (stack_entries(16), {}, True),   # exact only where the tree's bound is <= 16
    "stack32": (stack_entries(32), {}, True),   # ... <= 32
    "stack48": (stack_entries(48), {}, True),
    "stack64": (stack_entries(64), {}, True),
    # node-group stack entries (LIFT_BVH_GROUP_STACK) n deep: exact where the tree has <= n levels
    "groups8": (group_entries(8), {}, True),
    "groups16": (group_entries(16), {}, True),
    "groups24": (group_entries(24), {}, True),
    # ... with only the top 8 or 12 entries in shared memory, the deeper ones in a local array
    "groups24_shared8": (group_entries(24, shared=8), {}, True),
    "groups24_shared12": (group_entries(24, shared=12), {}, True),
    "groups16_shared8": (group_entries(16, shared=8), {}, True),
    "children16": (children_entries(16), {}, True),
    "children48": (children_entries(48), {}, True),
    "children56": (children_entries(56), {}, True),
    "groups24_s8x8": (group_entries(24, local=(8, 8)), {}, True),
    "groups16_s8x8": (group_entries(16, local=(8, 8)), {}, True),
    "groups24_s16x4": (group_entries(24, local=(16, 4)), {}, True),
    "pad2k": (pad_shared(2048), {}, True),
    "pad4k": (pad_shared(4096), {}, True),
    "pad8k": (pad_shared(8192), {}, True),
    "pad16k": (pad_shared(16384), {}, True),
    "pad32k": (pad_shared(32768), {}, True),
    "bdpt_no_lt": (bdpt_no_light_tracing, {}, False),
    "bdpt_no_connect": (bdpt_no_connect, {}, False),
    "bdpt_light_only": (bdpt_light_only, {}, False),
    "bdpt_camera_only": (bdpt_camera_only, {}, False),
    "bdpt_splat_plain": (bdpt_splat_plain, {}, False),
    "rr1": (None, {"rr_depth": 1}, False),
    "count_rays": (count_rays, {}, False),
    "bdpt_count_paths": (bdpt_count_paths, {}, False),
}
COUNTING = ("count_rays", "bdpt_count_paths")


def tree_plugin_source(renderer, tree: Path) -> str:
    """The trace program that checkout `tree`'s plugin (its plugins/NAME and shaders/) gives
    with this renderer's host: the megakernel's own defines (pixel queue, stack placement,
    splats: TracePass.defines), work groups and main(). Built from this checkout, it is the
    base program's text but for the paths of its includes (tested)."""
    from lift_gl import shaders
    from lift_gl.passes.trace import generate_main

    local = renderer.trace.local_size
    folder = tree / "plugins" / renderer.plugin.name
    main = generate_main(renderer.plugin, local).replace(
        renderer.plugin.entry_path.as_posix(), (folder / renderer.plugin.entry_path.name).resolve().as_posix())
    return shaders.assemble(main, renderer.trace.defines, include_dirs=[folder, tree / "shaders"],
                            main_name=f"<{tree} trace main>").text


def tree_source(renderer, tree: Path) -> str:
    """The trace program that checkout `tree` (its shaders/ and plugins/pt) builds for this
    renderer's defines, in 8x8 work groups with local stacks (what main ran on GPUs)."""
    from lift_gl import shaders
    from lift_gl.passes.trace import generate_main
    from lift_gl.plugins import param_defines

    defines = dict(renderer.defines, **param_defines(renderer.plugin, renderer.params), PRIMARY_GBUFFER=True)
    folder = tree / "plugins" / renderer.plugin.name
    main = generate_main(renderer.plugin, (8, 8)).replace(
        renderer.plugin.entry_path.as_posix(), (folder / renderer.plugin.entry_path.name).resolve().as_posix())
    return shaders.assemble(main, defines, include_dirs=[folder, tree / "shaders"],
                            main_name=f"<{tree} trace main>").text


# ---- program binaries (NVIDIA: assembly text inside) ----

GL_PROGRAM_BINARY_LENGTH = 0x8741


def program_binary(program) -> bytes | None:
    """glGetProgramBinary of a moderngl program, through the EGL/GL loader; None if unsupported."""
    try:
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        get_iv = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(
            egl.eglGetProcAddress(b"glGetProgramiv"))
        get_bin = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_int),
                                   ctypes.POINTER(ctypes.c_uint), ctypes.c_void_p)(
            egl.eglGetProcAddress(b"glGetProgramBinary"))
        n = ctypes.c_int(0)
        get_iv(program.glo, GL_PROGRAM_BINARY_LENGTH, ctypes.byref(n))
        if n.value <= 0:
            return None
        buf = ctypes.create_string_buffer(n.value)
        length, fmt = ctypes.c_int(0), ctypes.c_uint(0)
        get_bin(program.glo, n.value, ctypes.byref(length), ctypes.byref(fmt), buf)
        return buf.raw[:length.value]
    except (OSError, AttributeError, TypeError):
        return None


def binary_summary(blob: bytes | None) -> dict:
    """What the NVIDIA assembly in a program binary says about local memory and temporaries."""
    if not blob:
        return {}
    text = blob.decode("latin-1")
    out = {"bytes": len(blob)}
    lmem = re.findall(r"TEMP lmem\d*\[(\d+)\]", text)
    if lmem:
        out["lmem_vec4"] = [int(v) for v in lmem]
    temps = re.search(r"\nTEMP (R\d+(?:, R\d+)*);", text)
    if temps:  # vec4 temporaries before register allocation: a hint of register pressure
        out["temps_vec4"] = temps.group(1).count("R")
    shared = re.search(r"SHARED_MEMORY (\d+);", text)
    if shared:
        out["shared_bytes"] = int(shared.group(1))
    for key in ("REG", "reg", "NumRegs", "numRegs"):
        m = re.search(rf"{key}\D{{0,4}}(\d+)", text)
        if m:
            out[f"hint_{key}"] = int(m.group(1))
    return out


# ---- the measurement ----

def trace_uniforms(renderer) -> dict:
    from lift_gl.frame import compiled_pixel_filter
    from lift_gl.passes.camera import frame_jitter
    from lift_gl.passes.pixel_filter import filter_uniforms
    from lift_gl.passes.trace import param_uniforms

    # The pixel filter's uniforms too: without them bdpt's splats cover no pixel, so its light
    # tracing adds nothing and no atomics run.
    uniforms = dict(renderer.scene_uniforms, **renderer.camera_uniforms, **param_uniforms(renderer.plugin, renderer.params),
                    u_frame=7, u_seed=renderer.seed & 0xFFFFFFFF, u_samples=1, u_sample_base=7, u_stream=0,
                    u_jitter=frame_jitter(7, renderer.seed),
                    **filter_uniforms(compiled_pixel_filter(renderer), renderer.scene.film_size, renderer.size))
    if renderer.prepass is not None:   # where the trace pass finds the prepass's storage
        uniforms.update(renderer.prepass.uniforms(1))
    return uniforms


def dispatch_invocations(defines: dict, size, local) -> int:
    """The invocations of a trace or prepass dispatch: the work groups that cover
    tile_dispatch_size (whole blocks over the moved image with coherent sampling), times their size."""
    gx, gy, _ = groups(*tile_dispatch_size(defines, size, local), local)
    return gx * gy * local[0] * local[1]


def widen_prepass(renderer, invocations: int) -> None:
    """The renderer's prepass storage numbered for dispatches of up to `invocations`. A variant
    that turns coherent sampling on by its edit dispatches whole blocks over the moved image,
    more invocations than the renderer's layout counts (prepass.py numbers a sample's entries by
    invocation): its invocations past the count would write into other pixels' entries, racing
    them, and read past the storage. Numbering with gaps is as good (lift_prepass_begin), so the
    widest dispatch's count serves every variant; the buffers grow on the next run."""
    from dataclasses import replace

    layout = renderer.prepass.layout
    if invocations <= layout.invocations:
        return
    wide = replace(layout, invocations=invocations)
    if wide.buffer_bytes(renderer.prepass.samples) > layout.max_block:
        raise SystemExit(f"the prepass storage of {invocations} invocations passes the driver's largest "
                         "storage block: a smaller --size")
    renderer.prepass.layout = wide
    renderer.prepass.samples = 0   # reallocated by its next run (PrepassPass._allocate)


def camera_source(renderer):
    """The trace program of pt with primary = "camera" (the host traces camera rays)."""
    from lift_gl import shaders
    from lift_gl.passes.trace import generate_main
    from lift_gl.plugins import param_defines

    defines = dict(renderer.defines, **param_defines(renderer.plugin, renderer.params))
    local = renderer.trace.local_size
    if "LIFT_BVH_SHARED_STACK" in renderer.trace.source.text:
        defines["LIFT_BVH_SHARED_STACK"] = local[0] * local[1]
    return shaders.assemble(generate_main(renderer.plugin, local), defines, include_dirs=[renderer.plugin.folder],
                            main_name="<pt camera-primary main>").text


def gbuffer_variants(renderer) -> dict:
    """Fragment-shader variants of the G-buffer pass (diagnostics of raster cost)."""
    from lift_gl import shaders
    from lift_gl.passes.gbuffer import SHADER_DIR

    vert = shaders.assemble(SHADER_DIR / "gbuffer.vert", renderer.defines).text
    frag = shaders.assemble(SHADER_DIR / "gbuffer.frag", renderer.defines).text
    flat = re.sub(r"void main\(\) \{.*\}\s*$", "void main() {\n    o_visibility = uvec4(v_prim + 1u, 0u, 0u, 0u);\n"
                  "    o_normal_depth = vec4(0.0);\n    o_albedo = vec4(0.0);\n}\n", frag, flags=re.S)
    early = frag.replace("gl_FragDepth = clamp(view_depth * u_inv_far, 0.0, 1.0);", "")
    return {"gbuffer": (vert, frag), "gbuffer_flat": (vert, flat), "gbuffer_nodepthwrite": (vert, early)}


def stack_too_short(source: str, packed) -> str | None:
    """Why a 4-wide trace program's stack is too short for this tree, or None: a variant that
    declares fewer entries than the tree can push (stack_bound for child entries, levels for
    node groups) may overflow it, and on a GPU that can hang the program (seen on the H100)."""
    m = re.search(r"#define LIFT_BVH_STACK_SIZE (\d+)\n", source)
    if m is None or packed.bvh_width != 4:
        return None
    groups = "#define LIFT_BVH_GROUP_STACK\n" in source
    need = packed.bvh_levels if groups else packed.bvh_stack
    if int(m.group(1)) >= need:
        return None
    return f"{m.group(1)} stack entries, the tree needs {need} ({'levels' if groups else 'stack_bound'})"


def run_scene(ctx, path, size, max_depth, names, reps, dump_dir, base_tree=None, integrator="pt", trees=None,
              settings=None, options=None):
    from lift_gl.gl.context import is_software
    from lift_gl.passes.camera import frame_jitter, view_projection, near_far
    from lift_gl.passes.common import set_uniforms
    from lift_gl.passes.gbuffer import GBufferPass, TracedGBufferPass
    from lift_gl.passes.trace import reset_pixel_queue
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    scene = load_scene(path)
    r = Renderer(scene, size=size, integrator=integrator, params={"max_depth": max_depth, **(settings or {})}, ctx=ctx,
                 options=options)
    if "main" in names and base_tree is not None and r.packed.bvh_width != 2 \
            and "LIFT_BVH_WIDTH" not in (Path(base_tree) / "shaders" / "lift" / "bvh.glsl").read_text():
        raise SystemExit(f"{base_tree} traverses only the binary BVH and this scene's is {r.packed.bvh_width}-wide: "
                         "run with --option bvh_width=2 (lift_gl/options.py)")
    r.render(spp=2)  # warm-up; leaves a G-buffer for the variants
    CURRENT_PARAMS.clear()
    CURRENT_PARAMS.update(r.params)
    cpu = is_software(ctx)
    base_source = r.trace.source.text
    uniforms = trace_uniforms(r)
    programs, info, coherence = {}, {}, {}
    prepasses = {}   # variant: (its prepass program, its coherence defines), where its edit changes the prepass
    for name in names:
        if name == "camera":
            src, over, exact, local = camera_source(r), {}, False, r.trace.local_size
        elif name == "main":
            src, over, exact, local = tree_source(r, base_tree), {}, True, (8, 8)
        elif name == "tree" or name in (trees or {}):
            tree = base_tree if name == "tree" else trees[name]
            src, over, exact, local = tree_plugin_source(r, tree), {}, integrator == "pt", r.trace.local_size
        else:
            edit, over, exact = variant(name)
            src = edit(base_source) if edit else base_source
            local = getattr(edit, "local", None) or r.trace.local_size
            short = stack_too_short(src, r.packed)
            if short:   # its traversal could write past its stack: garbage entries can loop forever
                print(f"{Path(path).parent.name}: {name} skipped: {short}", flush=True)
                continue
        if r.prepass is not None and name.removeprefix("occ_").startswith(PREPASS_EDITED):
            edited = prepass_variant(edit, r.prepass.source.text)
            if edited is not None:
                prepasses[name] = (ctx.compute_shader(edited), coherence_defines(edited))
        start = time.perf_counter()
        prog = ctx.compute_shader(src)
        compile_s = time.perf_counter() - start
        blob = program_binary(prog)
        if dump_dir and blob:
            dump_dir.mkdir(parents=True, exist_ok=True)
            (dump_dir / f"{Path(path).parent.name}_{name}.bin").write_bytes(blob)
        programs[name] = (prog, dict(uniforms, **over), local)
        coherence[name] = coherence_defines(src)   # how many work groups its dispatch needs
        info[name] = {"exact": exact, "local_size": list(local), "compile_s": compile_s,
                      "binary": binary_summary(blob)}
    names = [name for name in names if name in programs]   # less the skipped ones
    w, h = size
    if r.prepass is not None:   # storage numbered for the widest dispatch, trace's or prepass's
        widest = [dispatch_invocations(coherence[n], size, programs[n][2]) for n in names]
        widest += [dispatch_invocations(d, size, r.prepass.local_size) for _, d in prepasses.values()]
        widen_prepass(r, max(widest, default=0))
        uniforms.update(r.prepass.uniforms(1))
        for prog, unif, _ in programs.values():
            unif.update(r.prepass.uniforms(1))
    frame = r.trace.frame
    splats = r.trace.splats
    query = ctx.query(time=True)
    gb = gbuffer_variants(r) if r.gbuffer is not None else {}
    gb_programs = {k: ctx.program(vertex_shader=v, fragment_shader=f) for k, (v, f) in gb.items()}
    gb_vaos = {k: ctx.vertex_array(p, []) for k, p in gb_programs.items()}
    raster_pass = GBufferPass(ctx, size, r.defines, r.packed.num_triangles, r.packed.num_spheres) if gb else None
    traced_pass = TracedGBufferPass(ctx, size, r.defines) if gb else None
    jitter = frame_jitter(7, r.seed)
    queue = ctx.buffer(reserve=4 * QUEUE_COUNTERS_MAX)   # queue_spread's counters
    probe = ctx.buffer(reserve=4 * OCCUPANCY_WORDS)   # the occ_ variants' counters
    orders = {}
    if any(n.startswith("queue_order_") for n in names) and r.gbuffer is not None:
        refresh_albedo = np.frombuffer(r.gbuffer.albedo.read(), np.float16).reshape(size[1], size[0], 4).astype(np.float32)
        orders = {k: ctx.buffer(v.tobytes()) for k, v in tile_orders(refresh_albedo, r.trace.local_size).items()}

    def dispatch(name):
        prog, unif, (lx, ly) = programs[name]
        r.buffers.bind()
        if r.prepass is not None:
            r.prepass.bind()
        set_uniforms(prog, unif)
        if "u_visibility" in prog:
            r.gbuffer.visibility.use(location=0)
            prog["u_visibility"].value = 0
        frame.bind_to_image(0, read=False, write=True)
        if splats is not None:
            splats.bind()
        reset_pixel_queue(ctx, queue)   # the pixel queue (LIFT_PIXEL_QUEUE), where a variant has it
        queue.write(bytes(4 * QUEUE_COUNTERS_MAX))   # every counter of queue_spread too
        probe.bind_to_storage_buffer(OCCUPANCY_BINDING)
        if name.removeprefix("occ_") in orders:
            orders[name.removeprefix("occ_")].bind_to_storage_buffer(TILE_ORDER_BINDING)
        if r.trace.carry is not None and "u_park" in prog:   # carrying compiled in: its buffer, nothing parks
            r.trace.carry.before_dispatch(prog, park=False)
        # a program that moves (and interleaves) its tiles, coherent sampling, covers whole
        # blocks over the moved image (passes/common.py tile_dispatch_size)
        prog.run(*groups(*tile_dispatch_size(coherence[name], (w, h), (lx, ly)), (lx, ly)))

    def resolve_splats():  # outside the timing: adds light tracing's splats to the frame, clears them
        if splats is not None:
            splats.add_to(frame)

    def refresh(name):  # the renderer's own G-buffer (raster or traced), and the prepass of variant `name`
        if r.gbuffer is not None:
            r.buffers.bind()
            r.gbuffer.run(r.camera, r.packed.bounds, jitter, r.scene_uniforms, r.camera_uniforms)
        if r.prepass is not None:   # bdpt's light subpaths, stored for the trace pass to join
            own = r.prepass.program, r.prepass.defines
            r.prepass.program, r.prepass.defines = prepasses.get(name, own)   # run as the renderer runs its own
            try:
                r.buffers.bind()
                r.prepass.run(uniforms, splats)
            finally:
                r.prepass.program, r.prepass.defines = own
            splats.buffer.clear()   # light tracing's splats: the prepass's work, not the trace pass's image

    def raster(name):
        r.buffers.bind()
        if name in ("traced", "traced_visibility"):   # the second: what a frame runs (only the visibility)
            traced_pass.run(r.camera, r.packed.bounds, jitter, r.scene_uniforms, r.camera_uniforms,
                            visibility_only=name == "traced_visibility")
            return
        g = raster_pass
        vao = gb_vaos[name]
        unif = dict(r.scene_uniforms, **r.camera_uniforms)
        unif["u_view_proj"] = view_projection(r.camera, size, r.packed.bounds, jitter).ravel()
        unif["u_inv_far"] = 1.0 / near_far(r.camera, r.packed.bounds)[1]
        g.fbo.use()
        g.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        set_uniforms(vao.program, unif)
        vao.render(ctx.TRIANGLES, vertices=3 * r.packed.num_triangles)
        ctx.disable(ctx.DEPTH_TEST)

    def timed(fn, name):
        ctx.finish()
        start = time.perf_counter_ns()
        with query:
            fn(name)
        ctx.finish()
        return (time.perf_counter_ns() - start if cpu else query.elapsed) / 1e6

    # images first (one dispatch each), then the timing rounds; the frame is filled with NaN
    # before each, so that a variant that leaves pixels unwritten cannot pass for exact
    images = {}
    unwritten = np.full((h, w, 4), np.nan, np.float32).tobytes()
    occupancy_seen = {}
    for name in names:
        refresh(name)
        frame.write(unwritten)
        probe.write(bytes(4 * OCCUPANCY_WORDS))
        dispatch(name)
        resolve_splats()
        if name.startswith("occ_"):
            occupancy_seen[name] = occupancy_summary(np.frombuffer(probe.read(), np.uint32))
        images[name] = np.frombuffer(frame.read(), np.float32).reshape(h, w, 4)[..., :3].copy()
    times = {name: [] for name in names}
    gb_names = [*gb, "traced", "traced_visibility"] if gb else []
    gb_times = {name: [] for name in gb_names}
    # an idle GPU's clock rises only under sustained work (lift_gl/report/gpu_clock.py)
    clock = ClockReader(ctx.info.get("GL_RENDERER", ""))
    warm = warm_up(lambda: [(refresh(names[0]), dispatch(names[0]), ctx.finish()) for _ in range(4)], clock)
    round_mhz = []
    for rep in range(reps + 1):
        order = names if rep % 2 == 0 else names[::-1]
        for name in order:
            refresh(name)
            ms = timed(dispatch, name)
            resolve_splats()
            if rep:
                times[name].append(ms)
        for name in (gb_names if rep % 2 == 0 else gb_names[::-1]):
            ms = timed(raster, name)
            if rep:
                gb_times[name].append(ms)
        round_mhz.append(clock.sm_mhz())
    base = images[names[0]]
    result = {"scene": Path(path).parent.name if Path(path).stem == "scene" else Path(path).stem,
              "integrator": integrator, "size": [w, h], "triangles": int(r.packed.num_triangles), "max_depth": max_depth, "variants": {}}
    for name in names:
        img = images[name]
        result["variants"][name] = dict(info[name], ms=times[name], median_ms=float(np.median(times[name])),
                                        mean_rgb=float(np.mean(img)), max_abs_diff_vs_first=float(np.max(np.abs(img - base))),
                                        finite=bool(np.isfinite(img).all()))
        if name in occupancy_seen:
            result["variants"][name]["occupancy"] = occupancy_seen[name]
        if name in COUNTING:  # the image is per-pixel counts
            result["variants"][name]["mean_counts_rgb"] = [float(v) for v in img.reshape(-1, 3).mean(axis=0)]
            if name == "bdpt_count_paths":
                result["variants"][name]["warp"] = warp_costs(img[..., 0], img[..., 1], max_depth)
    result["gbuffer"] = {name: {"ms": t, "median_ms": float(np.median(t))} for name, t in gb_times.items()}
    result["gbuffer_kind"] = type(r.gbuffer).__name__ if r.gbuffer is not None else None
    result["sm_clock"] = {"warm_up": warm, "rounds_mhz": round_mhz}  # NVIDIA only, else None
    for obj in [*gb_vaos.values(), *gb_programs.values(), *(p for p, _, _ in programs.values()),
                *(p for p, _ in prepasses.values()),
                *([raster_pass, traced_pass] if gb else [])]:
        obj.release()
    queue.release()
    probe.release()
    for buf in orders.values():
        buf.release()
    r.release()
    return result


def table(record: dict) -> str:
    names = record["variants"]
    lines = [f"{record['gl']}; {record.get('integrator', 'pt')}, 1 spp, path length {record['max_depth']}; trace pass ms (median of "
             f"{record['reps']} timer-queried dispatches, variants interleaved); x base = base ms / variant ms.", "",
             "| variant | exact | " + " | ".join(f"{c['scene']} ms | x base" for c in record["results"]) + " |",
             "|---|---|" + "---|---|" * len(record["results"])]
    for name in names:
        ran = [c["variants"][name] for c in record["results"] if name in c["variants"]]
        cells = [name, "yes" if name == names[0] or (ran and ran[0]["exact"]) else "no" if ran else "–"]
        for c in record["results"]:
            v = c["variants"].get(name)
            if v is None:   # skipped on this scene (stack_too_short)
                cells += ["skipped", "–"]
                continue
            base = c["variants"][names[0]]["median_ms"]
            cells += [f"{v['median_ms']:.3f}", f"{base / v['median_ms']:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| scene | " + " | ".join(record["results"][0]["gbuffer"]) + " |",
              "|---|" + "---|" * len(record["results"][0]["gbuffer"])]
    for c in record["results"]:
        lines.append(f"| {c['scene']} | " + " | ".join(f"{v['median_ms']:.3f}" for v in c["gbuffer"].values()) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    from lift_gl.cli import _size
    from lift_gl.gl.context import create_context, describe

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--max-depth", type=int, default=32)
    ap.add_argument("--integrator", default="pt", help="pt or bdpt (or any plugin of this checkout)")
    ap.add_argument("--variants", default=",".join(list(VARIANTS) + ["camera"]),
                    help="comma-separated, the first is the reference of the image check; also camera, main, tree")
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--dump-binaries", type=Path)
    ap.add_argument("--base-tree", type=Path, help="another checkout: variant `main` is its trace program")
    ap.add_argument("--tree", action="append", default=[], metavar="NAME=CHECKOUT",
                    help="variant NAME is the plugin of that checkout, as `tree` is of --base-tree (repeatable)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="plugin setting of every variant, e.g. rr_depth=1 (repeatable)")
    ap.add_argument("--backend", default="auto")
    from lift_gl.options import add_option_argument, from_args

    add_option_argument(ap)   # the renderer's options (lift_gl/options.py), e.g. --option carry_paths=on
    args = ap.parse_args(argv)
    from lift_gl.report.configurations import parse_spec
    settings = parse_spec(":".join([args.integrator, *args.set]))[1]
    names = [n.strip() for n in args.variants.split(",") if n.strip()]
    trees = dict(t.split("=", 1) for t in args.tree)
    trees = {k: Path(v) for k, v in trees.items()}
    for n in names:
        if n in ("main", "tree") and args.base_tree is None:
            raise SystemExit(f"--variants {n} needs --base-tree")
        if n not in VARIANTS and n[4:] not in VARIANTS and n not in ("camera", "main", "tree") and n not in trees:
            raise SystemExit(f"--variants: unknown {n!r}; known: {', '.join(VARIANTS)}, camera")
    ctx = create_context(args.backend)
    record = {"gl": describe(ctx), "integrator": args.integrator, "size": args.size, "max_depth": args.max_depth, "reps": args.reps,
              "settings": settings, "variants": names, "results": []}
    for path in args.scenes:
        start = time.perf_counter()
        res = run_scene(ctx, path, _size(args.size), args.max_depth, names, args.reps, args.dump_binaries, args.base_tree,
                        args.integrator, trees, settings, from_args(args))
        record["results"].append(res)
        print(f"{res['scene']} ({time.perf_counter() - start:.0f} s): " + ", ".join(
            f"{n} {v['median_ms']:.3f}" for n, v in res["variants"].items())
            + "; gbuffer " + ", ".join(f"{n} {v['median_ms']:.3f}" for n, v in res["gbuffer"].items())
            + f"; SM clock MHz after each round {res['sm_clock']['rounds_mhz']}"
            + "".join(f"; {n} warps/SM {v['occupancy']['warps_per_sm_max']} (mean {v['occupancy']['warps_per_sm_mean']:.1f}, "
                      f"warp slots {v['occupancy']['warp_slot_max']})" for n, v in res["variants"].items() if "occupancy" in v),
            flush=True)
        if args.out:
            write_json(args.out, record, indent=1)
    print(table(record))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
