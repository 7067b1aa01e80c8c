"""Trace pass for OpenCL plugins (`language = "opencl"`): the twin of trace.py.

inputs:  scene arrays (the PackedScene the GL buffers hold), camera, G-buffer visibility
         (read back from GL, plugins with primary = "gbuffer")
outputs: frame (the same RGBA32F GL texture trace.py writes: sum of this frame's valid
         samples in rgb, their count in a), then the usual accumulate pass;
         dropped NaN/Inf samples are added to the GL statistics counter

The kernel is shaders/opencl/lift/host_kernel.cl, the host's: the pixel loop, the seeds (the
same random numbers as the GLSL host), the primary hit rebuilt from the G-buffer or traced from
the camera, the NaN/Inf guard (lift/sample_guard.h) and the output. The plugin writes only
    float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params);
with its parameters as the fields of `Params`, which generate_kernel writes into the program's
head with the include of the plugin's entry file.
"""
from __future__ import annotations

import numpy as np

from .. import opencl
from ..plugins import Plugin
from .common import STAT_DROPPED

C_TYPES = {"int": "int", "float": "float", "bool": "int", "color": "float3"}

HOST_KERNEL = "lift/host_kernel.cl"
# Per-frame values, one float4 each (uint fields as bit patterns); lift_frame() (host_kernel.cl) reads them.
FRAME_LAYOUT = ("cam_pos", "cam_right", "cam_up", "cam_forward", "tan_half_fov lens_radius focus samples",
                "resolution jitter", "env_radiance frame", "num_triangles num_spheres num_lights seed")

PIXEL_FILTER_STRIDE = 132  # floats per axis of the pixel filter's knots (pixel_filter.h)


def generate_kernel(plugin: Plugin) -> str:
    """The OpenCL trace program's text: its generated head (the plugin's Params, their loads
    from the parameter buffer, the plugin's entry file), then the host's kernel."""
    fields, loads, offset = [], [], 0
    for p in plugin.params.values():
        fields.append(f"    {C_TYPES[p.type]} {p.name};  // {' '.join(p.help.split())}")
        if p.type == "color":
            loads.append(f"    p.{p.name} = (float3)(v[{offset}], v[{offset + 1}], v[{offset + 2}]);")
            offset += 3
        elif p.type == "float":
            loads.append(f"    p.{p.name} = v[{offset}];")
            offset += 1
        else:
            loads.append(f"    p.{p.name} = as_int(v[{offset}]);")
            offset += 1
    return "\n".join([
        f"// {plugin.name}: the head of an OpenCL trace program (lift_gl/passes/trace_cl.py generate_kernel)",
        '#include "lift/host.h"',
        "// ---- plugin parameters (plugin.toml) ----",
        "typedef struct {", *fields, "    int unused_;  // C forbids an empty struct", "} Params;",
        "Params lift_params(__global const float* v) {", "    Params p;", *loads, "    p.unused_ = 0;",
        "    return p;", "}",
        "// ---- plugin ----",
        f'#include "{plugin.entry_path.as_posix()}"',
        "// ---- host ----",
        f'#include "{HOST_KERNEL}"', ""])


def pack_params(plugin: Plugin, uniforms: dict) -> np.ndarray:
    """The parameter values in the order lift_params() reads them (ints and bools as int bits)."""
    values: list[np.ndarray] = [np.zeros(1, np.float32)]  # never an empty buffer
    for name, p in plugin.params.items():
        value = uniforms[name]
        if p.type == "color":
            values.append(np.asarray(value, np.float32).reshape(3))
        elif p.type == "float":
            values.append(np.array([value], np.float32))
        else:
            values.append(np.array([int(value)], np.int32).view(np.float32))
    return np.concatenate(values[1:] or values)


def pack_frame(uniforms: dict) -> np.ndarray:
    """The host uniforms trace.py sets, as FRAME_LAYOUT's float4 rows; then, with a pixel
    filter, its knots (shaders/opencl/lift/pixel_filter.h)."""
    f = np.zeros((len(FRAME_LAYOUT), 4), np.float32)
    f[0, :3], f[1, :3] = uniforms["u_cam_pos"], uniforms["u_cam_right"]
    f[2, :3], f[3, :3] = uniforms["u_cam_up"], uniforms["u_cam_forward"]
    f[4, :3] = uniforms["u_tan_half_fov"], uniforms["u_lens_radius"], uniforms["u_focus_distance"]
    f[5] = (*uniforms["u_resolution"], *uniforms["u_jitter"])
    f[6, :3] = uniforms["u_env_radiance"]
    bits = f.view(np.uint32)
    bits[4, 3] = uniforms["u_samples"]
    bits[6, 3] = uniforms["u_frame"]
    bits[7] = (uniforms["u_num_triangles"], uniforms["u_num_spheres"], uniforms["u_num_lights"], uniforms["u_seed"])
    if "u_filter_span" not in uniforms:
        return f
    cdf = np.zeros((2, PIXEL_FILTER_STRIDE), np.float32)
    cdf[0, :len(uniforms["u_filter_cdf_x"])] = uniforms["u_filter_cdf_x"]
    cdf[1, :len(uniforms["u_filter_cdf_y"])] = uniforms["u_filter_cdf_y"]
    span = np.array([uniforms["u_filter_span"]], np.float32)
    return np.concatenate([f, span, cdf.reshape(-1, 4)])


SCENE_ARRAYS = ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info", "materials", "lights", "spheres")


class OpenCLTracePass:
    name = "trace"
    inputs = ("scene", "camera", "visibility?")
    outputs = ("frame",)

    def __init__(self, ctx, size, plugin: Plugin, defines: dict, scene_buffers):
        self.cl = opencl.import_pyopencl(plugin.manifest)
        self.context, self.queue = opencl.device(plugin.manifest)
        self.size = size
        self.plugin = plugin
        defines = dict(defines)
        if plugin.primary == "gbuffer":
            defines["PRIMARY_GBUFFER"] = True
        defines["FRAME_ROWS"] = len(FRAME_LAYOUT)  # where pack_frame puts the pixel filter's knots
        self.source = opencl.assemble(generate_kernel(plugin), defines, include_dirs=[plugin.folder],
                                      main_name=f"<{plugin.name} host kernel>")
        self.kernel = opencl.build(self.source, plugin.manifest).lift_trace
        self.shared_stack = False   # the kernel's BVH stack is a private array (renderer.explain says it)
        mf = self.cl.mem_flags
        packed = scene_buffers.packed
        self.scene = [self.cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                     hostbuf=np.ascontiguousarray(getattr(packed, name)))
                      for name in SCENE_ARRAYS]
        w, h = size
        self.visibility = self.cl.Buffer(self.context, mf.READ_ONLY, w * h * 16)
        self.out = self.cl.Buffer(self.context, mf.WRITE_ONLY, w * h * 16)
        self.dropped = self.cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=np.zeros(1, np.uint32))
        self.gl_stats = scene_buffers.stats
        self.host_out = np.empty((h, w, 4), np.float32)
        self.frame = ctx.texture(size, 4, dtype="f4")

    def run(self, uniforms: dict, visibility=None, park: bool = False) -> None:
        """One frame (`park` as TracePass.run takes it: this pass carries no paths, every path
        runs to its end)."""
        cl, queue = self.cl, self.queue
        mf = cl.mem_flags
        frame = cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=pack_frame(uniforms))
        params = cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=pack_params(self.plugin, uniforms))
        if visibility is not None and self.plugin.primary == "gbuffer":
            cl.enqueue_copy(queue, self.visibility, visibility.read())
        self.kernel(queue, self.size, None, *self.scene, frame, params, self.visibility, self.out, self.dropped)
        cl.enqueue_copy(queue, self.host_out, self.out)
        dropped = np.zeros(1, np.uint32)
        cl.enqueue_copy(queue, dropped, self.dropped)  # blocking: host_out is ready too
        self.frame.write(self.host_out.tobytes())
        if dropped[0]:
            self._add_dropped(int(dropped[0]))
            cl.enqueue_copy(queue, self.dropped, np.zeros(1, np.uint32))
        frame.release()
        params.release()

    def _add_dropped(self, count: int) -> None:
        stats = np.frombuffer(self.gl_stats.read(), np.uint32).copy()
        stats[STAT_DROPPED] += count
        self.gl_stats.write(stats.tobytes())

    def release(self) -> None:
        for buffer in (*self.scene, self.visibility, self.out, self.dropped):
            buffer.release()
        self.frame.release()
