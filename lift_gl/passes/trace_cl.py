"""Trace pass for OpenCL plugins (`language = "opencl"`): the twin of trace.py.

inputs:  scene arrays (the PackedScene the GL buffers hold), camera, G-buffer visibility
         (read back from GL, plugins with primary = "gbuffer")
outputs: frame (the same RGBA32F GL texture trace.py writes: sum of this frame's valid
         samples in rgb, their count in a), then the usual accumulate pass;
         dropped NaN/Inf samples are added to the GL statistics counter

The host writes the kernel: the pixel loop, the seeds (the same random numbers as the GLSL
host), the primary hit rebuilt from the G-buffer or traced from the camera, the NaN/Inf
guard and the output. The plugin writes only
    float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params);
with its parameters as the fields of `Params`.
"""
from __future__ import annotations

import numpy as np

from .. import opencl
from ..plugins import Plugin
from .common import STAT_DROPPED

C_TYPES = {"int": "int", "float": "float", "bool": "int", "color": "float3"}

# Per-frame values, one float4 each (uint fields as bit patterns); lift_frame() reads them.
FRAME_LAYOUT = ("cam_pos", "cam_right", "cam_up", "cam_forward", "tan_half_fov lens_radius focus samples",
                "resolution jitter", "env_radiance frame", "num_triangles num_spheres num_lights seed")

PIXEL_FILTER_STRIDE = 132  # floats per axis of the pixel filter's knots (pixel_filter.h)

KERNEL_TEMPLATE = """
#include "lift/host.h"
#ifdef HAS_PIXEL_FILTER
#include "lift/pixel_filter.h"
#endif

// ---- plugin parameters (plugin.toml) ----
typedef struct {{
{fields}
    int unused_;  // C forbids an empty struct
}} Params;

Params lift_params(__global const float* v) {{
    Params p;
{loads}
    p.unused_ = 0;
    return p;
}}

// ---- plugin ----
#include "{entry}"

// ---- host ----
typedef struct {{ Camera camera; float2 jitter; uint frame, seed, samples; }} FrameInfo;

FrameInfo lift_frame(__global const float4* f, Scene* scene) {{
    FrameInfo info;
    info.camera.position = f[0].xyz;
    info.camera.right = f[1].xyz;
    info.camera.up = f[2].xyz;
    info.camera.forward = f[3].xyz;
    info.camera.tan_half_fov = f[4].x;
    info.camera.lens_radius = f[4].y;
    info.camera.focus_distance = f[4].z;
    info.camera.resolution = f[5].xy;
    info.jitter = f[5].zw;
    scene->env_radiance = f[6].xyz;
    info.frame = as_uint(f[6].w);
    scene->num_triangles = as_uint(f[7].x);
    scene->num_spheres = as_uint(f[7].y);
    scene->num_lights = as_uint(f[7].z);
    info.seed = as_uint(f[7].w);
    info.samples = as_uint(f[4].w);
    return info;
}}

#ifdef PRIMARY_GBUFFER
// The primary hit the raster found, rebuilt exactly along the camera ray; where ray and
// raster disagree (a sample exactly on an edge) the ray is traced instead.
Hit gbuffer_hit(const Scene* scene, uint4 v, Ray ray) {{
    Hit hit;
    hit.prim = NO_HIT;
    hit.t = ray.tmax;
    hit.bary = (float2)(0.0f);
    if (v.x == 0u) return hit;
    uint prim = v.x - 1u;
    float t = ray.tmax;
    float2 bary;
    if (prim < scene->num_triangles && intersect_triangle(scene, ray, prim, &t, &bary)) {{
        hit.prim = prim; hit.t = t; hit.bary = bary;
        return hit;
    }}
#ifdef HAS_SPHERES
    if (prim >= scene->num_triangles && intersect_sphere(scene, ray, prim - scene->num_triangles, &t)) {{
        hit.prim = prim; hit.t = t;
        return hit;
    }}
#endif
    trace_closest(scene, ray, &hit);
    return hit;
}}
#endif

bool lift_is_finite(float3 v) {{
    uint3 bits = as_uint3(v) & (uint3)(0x7f800000u);
    return bits.x != 0x7f800000u && bits.y != 0x7f800000u && bits.z != 0x7f800000u;
}}

__kernel void lift_trace(
        __global const float4* bvh_nodes, __global const float4* tri_pos, __global const float4* tri_normal,
        __global const float4* tri_uv, __global const uint2* tri_info, __global const Material* materials,
        __global const float4* lights, __global const float4* spheres,
        __global const float4* frame_values, __global const float* param_values,
        __global const uint4* visibility, __global float4* frame_out, volatile __global uint* dropped) {{
    Scene scene;
    scene.bvh_nodes = bvh_nodes; scene.tri_pos = tri_pos; scene.tri_normal = tri_normal;
    scene.tri_uv = tri_uv; scene.tri_info = tri_info; scene.materials = materials;
    scene.lights = lights; scene.spheres = spheres;
    FrameInfo info = lift_frame(frame_values, &scene);
    Params params = lift_params(param_values);
    uint2 pixel = (uint2)(get_global_id(0), get_global_id(1));
    uint width = (uint)info.camera.resolution.x;
    if (pixel.x >= width || pixel.y >= (uint)info.camera.resolution.y) return;
    uint index = pixel.y * width + pixel.x;  // GL texture order: row 0 at the bottom
    float2 position = convert_float2(pixel);

    float3 sum = (float3)(0.0f);
    float valid = 0.0f;
    for (uint s = 0u; s < info.samples; ++s) {{
        Rng rng = rng_init(pixel, info.frame, s, info.seed);
        Ray ray;
        Hit hit;
#ifdef PRIMARY_GBUFFER
        ray = camera_ray(&info.camera, position + info.jitter);
        hit = gbuffer_hit(&scene, visibility[index], ray);
#else
        float2 subpixel = rng_next2(&rng);
#ifdef HAS_PIXEL_FILTER
        subpixel = pixel_filter_offset(frame_values + FRAME_ROWS, subpixel);  // the scene's pixel filter
#endif
        float2 lens = rng_next2(&rng);
        ray = camera_ray_lens(&info.camera, position + subpixel, lens);
        trace_closest(&scene, ray, &hit);
#endif
        float3 L = radiance(ray, hit, &rng, &scene, &params);
        if (!lift_is_finite(L)) {{
            atomic_inc(dropped);  // dropped and counted, never averaged in
            continue;
        }}
        sum += L;
        valid += 1.0f;
    }}
    frame_out[index] = (float4)(sum, valid);
}}
"""


def generate_kernel(plugin: Plugin) -> str:
    fields, loads, offset = [], [], 0
    for p in plugin.params.values():
        fields.append(f"    {C_TYPES[p.type]} {p.name};  // {p.help}")
        if p.type == "color":
            loads.append(f"    p.{p.name} = (float3)(v[{offset}], v[{offset + 1}], v[{offset + 2}]);")
            offset += 3
        elif p.type == "float":
            loads.append(f"    p.{p.name} = v[{offset}];")
            offset += 1
        else:
            loads.append(f"    p.{p.name} = as_int(v[{offset}]);")
            offset += 1
    return KERNEL_TEMPLATE.format(fields="\n".join(fields), loads="\n".join(loads),
                                  entry=plugin.entry_path.as_posix())


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

    def run(self, uniforms: dict, visibility=None, park: bool = False, frames_left: int | None = None) -> None:
        """One frame (`park` and `frames_left` as TracePass.run takes them: this pass carries no
        paths, every path runs to its end)."""
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
