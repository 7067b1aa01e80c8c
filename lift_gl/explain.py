"""`lift-gl render --explain`: what a renderer runs and why. The device, the scene, the plugin,
what is biased, the frame's passes (from their declarations: passes/graph.py), the features
compiled in, where the scene's arrays live, the BVH, and every option's choice."""
from __future__ import annotations

from .denoise import BIASED as DENOISER_BIASED
from .gl.context import describe
from .passes.common import COHERENT_DEFINE, INTERLEAVE_DEFINE


def explain(r) -> str:
    lines = [f"device: {describe(r.ctx)}",
             f"scene: {_triangle_count(r.packed)} triangles, {r.packed.num_spheres} spheres, "
             f"{r.packed.num_lights} emitters, BVH depth {r.packed.bvh_depth}",
             f"integrator: {r.plugin.name} ({r.plugin.folder}), primary hit from {r.plugin.primary}",
             f"parameters: {', '.join(f'{k}={v}' for k, v in r.params.items())}"]
    if r.plugin.biased:
        lines.append(f"BIASED: {r.plugin.biased}")
    lines += _coherent_sampling(r)
    if r.temporal.clamp_sigma > 0 and r.reproject is not None:
        lines.append(f"BIASED: temporal neighbourhood clamp (+-{r.temporal.clamp_sigma:g} sigma) on moving frames")
    if r.denoise_pass is not None:
        lines.append(f"BIASED: denoise={r.denoise.mode} ({r.denoise.denoiser}): {DENOISER_BIASED}")
    lines.append("passes (inputs -> outputs, from each pass's declarations):")
    lines += r.graph.explain()
    if r.gbuffer is None:
        lines.append("  (no gbuffer: the plugin traces camera rays, primary = \"camera\")")
    lines.append("scene features compiled in (+) and left out (-):")
    lines += ["  " + f for f in r.features.explain()]
    if r.buffers.in_uniform_block:
        lines.append("scene arrays in uniform blocks, which a CPU rasterizer reads faster than storage "
                     f"buffers (docs/cpu-speed.md): {', '.join(sorted(r.buffers.in_uniform_block))}")
    lines += _memory(r)
    lines.append("options (--option KEY=VALUE; lift_gl/options.py):")
    lines += r.choices.explain()
    return "\n".join(lines)


def _coherent_sampling(r) -> list[str]:
    if COHERENT_DEFINE not in getattr(r.trace, "defines", {}):
        return []
    w, h = r.trace.local_size
    k = int(r.trace.defines.get(INTERLEAVE_DEFINE, 1))
    spread = f" (its pixels {k} apart in a {k * w}x{k * h} block: interleaved)" if k > 1 else ""
    return [f"coherent sampling: the pixels of each {w}x{h} tile{spread} share their random numbers "
            "(the tiles move every frame; a plugin may draw some of its own: bdpt's light subpaths): "
            "unbiased per pixel, the noise correlated in blocks"
            + ("; the denoiser keeps such blocks (docs/denoiser.md)" if r.denoise_pass is not None else "")]


def _triangle_count(p) -> str:
    if p.raster_rows is None:
        return f"{p.num_triangles}"
    return (f"{p.num_source_triangles} ({p.num_triangles} stored: the BVH split large ones into "
            f"several references, accel/presplit.py)")


def _instances(r) -> list[str]:
    if not r.scene.instances:
        return []
    p = r.packed
    flattened = len(r.scene.instances) - p.num_instances
    blas = p.instance_blas or {}
    line = (f"instances: {p.num_instances:,} traced through {len(blas)} BLAS "
            f"({sum(len(b.positions) for b, _, _ in blas.values()):,} triangles, built once) under a TLAS of depth "
            f"{p.instance_table.tlas_depth if p.instance_table else 0}")
    if flattened:
        line += (f"; {flattened:,} copied into world space (emissive or moving within the shutter, "
                 "or an OpenCL plugin: lift_gl/scene/instances.py)")
    return [line]


def _stack(r) -> list[str]:
    """What the trace pass's BVH stack holds and how deep it is (accel/wide.stack_defines)."""
    d = r.plugin_defines(r.plugin, r.params) if r.packed.bvh_width != 2 else {}
    if "LIFT_BVH_STACK_SIZE" not in d:
        return []
    what = "node groups" if d.get("LIFT_BVH_GROUP_STACK") else "child entries"
    if getattr(r.trace, "shared_stack", None) is False:
        shared = ", in a local array"   # CPU rasterizers; on GPUs pt's queued megakernel (passes/trace.py)
    else:
        shared = (f", the top {d['LIFT_BVH_SHARED_DEPTH']} in shared memory on GPUs"
                  if "LIFT_BVH_SHARED_DEPTH" in d else "")
    paired = ("a path vertex's shadow ray and next ray traced in one loop" if d.get("LIFT_TRACE_PAIRED")
              else "shadow and next rays traced apart")
    return [f"BVH stack: {d['LIFT_BVH_STACK_SIZE']} {what}{shared}; {paired}"]


def _memory(r) -> list[str]:
    """The scene's storage buffers, each with its size and binding, and how a big scene was split."""
    p, plan = r.packed, r.buffers.plan
    buffers = r.buffers.memory()
    total = sum(size for _, _, size in buffers)
    kind = "binary" if p.bvh_width == 2 else f"{p.bvh_width}-wide"
    lines = [f"BVH: {p.bvh_nodes.shape[0]:,} {kind}{' quantized' if p.bvh_quantized else ''} nodes, "
             f"depth {p.bvh_depth} (binary), built by {p.bvh_builder} (lift_gl/accel)",
             *_stack(r),
             *_instances(r),
             f"GPU memory, scene storage buffers: {total / (1 << 20):,.1f} MiB in {len(buffers)} buffers "
             f"(limit {r.limits.max_ssbo_bytes / (1 << 20):,.0f} MiB a buffer)"
             + (f"; BVH and triangles split into {plan.chunks} buffers of up to "
                f"{plan.chunk_rows * 16 / (1 << 20):,.1f} MiB" if plan.split else "")]
    lines += [f"  {name:<40} binding {binding:>2}  {size:>14,} bytes" for name, binding, size in buffers]
    return lines
