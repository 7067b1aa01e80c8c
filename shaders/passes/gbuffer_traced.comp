// G-buffer by ray casting (lift_gl/passes/gbuffer.py, TracedGBufferPass): the raster pass's
// visibility, normal_depth and albedo from one camera ray per pixel through the same
// jittered pixel position, for GPUs whose raster hardware is the bottleneck (docs/gpu.md).
// The ray is the one the trace pass rebuilds the primary hit along (lift/primary_hit.glsl),
// so the two agree by construction. With LIFT_MOTION_VECTORS (temporal reprojection) it writes
// the raster's motion vectors too, from the hit point and the previous camera.
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
#ifdef LIFT_MOTION_VECTORS
#include "passes/motion_vectors.glsl"
layout(rgba32f, binding = 3) uniform writeonly image2D u_motion_out;
uniform uint u_prev_instance_rows;  // prev_positions row of instance 0's previous transform

// Where the previous frame saw the hit point (prev_positions, lift_gl/temporal.py): the same
// barycentric point of the triangle's previous corners, the instance's previous transform of
// the object-space point, or the sphere's previous displacement added.
vec3 previous_position(Hit hit, Surface s) {
    if (hit.prim >= u_num_triangles) return s.p + prev_positions[3u * u_num_triangles + hit.prim - u_num_triangles].xyz;
    uint i = 3u * hit.prim;
    vec3 b = vec3(1.0 - hit.bary.x - hit.bary.y, hit.bary);
#ifdef HAS_INSTANCES
    if (hit.instance != NO_INSTANCE) {
        vec4 object = vec4(b.x * tri_pos_row(i).xyz + b.y * tri_pos_row(i + 1u).xyz + b.z * tri_pos_row(i + 2u).xyz, 1.0);
        uint r = u_prev_instance_rows + 3u * hit.instance;
        return vec3(dot(prev_positions[r], object), dot(prev_positions[r + 1u], object), dot(prev_positions[r + 2u], object));
    }
#endif
    return b.x * prev_positions[i].xyz + b.y * prev_positions[i + 1u].xyz + b.z * prev_positions[i + 2u].xyz;
}

// The raster's fwidth(view depth), which compute shaders lack: the view depth where the rays
// through the next pixel right and up meet the hit's tangent plane, less this one's.
float view_depth_gradient(vec2 pixel_pos, Surface s, float view_depth) {
    float gradient = 0.0;
    for (int axis = 0; axis < 2; ++axis) {
        Ray next = camera_ray(pixel_pos + (axis == 0 ? vec2(1.0, 0.0) : vec2(0.0, 1.0)));
        float t = dot(s.ng, s.p - next.origin) / dot(s.ng, next.dir);  // Inf, NaN: motion_vector drops it
        gradient += abs(t * dot(next.dir, u_cam_forward) - view_depth);
    }
    return gradient;
}
#endif

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
#ifdef LIFT_MOTION_VECTORS
        imageStore(u_motion_out, pixel, vec4(0.0));  // background has no history
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
#ifdef LIFT_MOTION_VECTORS
    imageStore(u_motion_out, pixel, motion_vector(s.p, previous_position(hit, s),
                                                  view_depth_gradient(vec2(pixel) + u_jitter, s, view_depth)));
#endif
}
