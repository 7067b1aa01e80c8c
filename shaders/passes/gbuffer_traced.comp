// G-buffer by ray casting (lift_gl/passes/gbuffer.py, TracedGBufferPass): the raster pass's
// visibility, normal_depth and albedo from one camera ray per pixel through the same
// jittered pixel position, for GPUs whose raster hardware is the bottleneck (docs/gpu.md).
// The ray is the one the trace pass rebuilds the primary hit along (lift/primary_hit.glsl),
// so the two agree by construction.
#include "lift/scene_data.glsl"
#include "lift/trace.glsl"
#include "lift/camera.glsl"
#include "lift/surface.glsl"
#include "lift/bsdf.glsl"
#include "lift/textures.glsl"
layout(local_size_x = LIFT_GBUFFER_LOCAL_X, local_size_y = LIFT_GBUFFER_LOCAL_Y) in;
layout(rgba32ui, binding = 0) uniform writeonly uimage2D u_visibility_out;
layout(rgba32f, binding = 1) uniform writeonly image2D u_normal_depth_out;
layout(rgba16f, binding = 2) uniform writeonly image2D u_albedo_out;
uniform vec2 u_jitter;  // this frame's subpixel offset, as the raster's projection has it

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, ivec2(u_resolution)))) return;
    Ray ray = camera_ray(vec2(pixel) + u_jitter);
    Hit hit;
    if (!trace_closest(ray, hit)) {  // background: the raster's clear values
        imageStore(u_visibility_out, pixel, uvec4(0u));
#ifndef LIFT_GBUFFER_VISIBILITY_ONLY
        imageStore(u_normal_depth_out, pixel, vec4(0.0));
        imageStore(u_albedo_out, pixel, vec4(0.0));
#endif
        return;
    }
    Surface s = surface_at(ray, hit);
    // As the raster: the interpolated shading normal (triangles) or the sphere's normal,
    // turned to face the camera; the view depth along the camera's forward axis.
    vec3 n = s.ns;
    if (dot(n, ray.origin - s.p) < 0.0) n = -n;
    float view_depth = dot(s.p - u_cam_pos, u_cam_forward);
    vec2 bary = hit.prim < u_num_triangles ? hit.bary : vec2(0.0);
    uint tag = s.material;  // as the raster writes w (lift/scene_data.glsl: visibility_instance)
#ifdef HAS_INSTANCES
    if (hit.instance != NO_INSTANCE) tag |= (hit.instance + 1u) << 16u;
#endif
    imageStore(u_visibility_out, pixel, uvec4(hit.prim + 1u, floatBitsToUint(bary.x), floatBitsToUint(bary.y), tag));
#ifndef LIFT_GBUFFER_VISIBILITY_ONLY  // the frame needs only what the trace pass reads
    imageStore(u_normal_depth_out, pixel, vec4(n, view_depth));
    imageStore(u_albedo_out, pixel, vec4(bsdf_albedo(material_at(s.material, s.uv)), 1.0));
#endif
}
