#include "lift/scene_data.glsl"
#include "lift/bsdf.glsl"
#include "lift/textures.glsl"
uniform vec3 u_cam_pos;
uniform vec3 u_cam_forward;
uniform float u_inv_depth_scale;      // the depth test's depth (lift_gl/passes/camera.py DEPTH_STEPS)
uniform float u_inv_log_depth_range;
flat in uint v_sphere;
in vec3 v_world;
layout(location = 0) out uvec4 o_visibility;
layout(location = 1) out vec4 o_normal_depth;
layout(location = 2) out vec4 o_albedo;
#ifdef LIFT_MOTION_VECTORS
#include "passes/motion_vectors.glsl"
layout(location = 3) out vec4 o_motion;
#endif
void main() {
    vec4 cr = spheres[2u * v_sphere];
    vec3 d = normalize(v_world - u_cam_pos);
    vec3 oc = u_cam_pos - cr.xyz;
    float b = dot(oc, d);
    float c = dot(oc, oc) - cr.w * cr.w;
    float disc = b * b - c;
    if (disc < 0.0) discard;
    float s = sqrt(disc);
    float t = -b - s;
    if (t <= 0.0) t = -b + s;  // the camera is inside the sphere
    if (t <= 0.0) discard;
    vec3 p = u_cam_pos + t * d;
    float view_depth = dot(p - u_cam_pos, u_cam_forward);
    gl_FragDepth = clamp(log2(1.0 + max(view_depth, 0.0) * u_inv_depth_scale) * u_inv_log_depth_range, 0.0, 1.0);
    uint material = floatBitsToUint(spheres[2u * v_sphere + 1u].x);
    o_visibility = uvec4(u_num_triangles + v_sphere + 1u, 0u, 0u, material);
    vec3 n = normalize(p - cr.xyz);
    if (dot(n, -d) < 0.0) n = -n;
    o_normal_depth = vec4(n, view_depth);
#ifdef LIFT_MOTION_VECTORS
    // A sphere moves rigidly: its row after the triangle corners holds its displacement.
    o_motion = motion_vector(p, p + prev_positions[3u * u_num_triangles + v_sphere].xyz, fwidth(view_depth));
#endif
    o_albedo = vec4(bsdf_albedo(material_at(material, sphere_uv(normalize(p - cr.xyz)))), 1.0);
}
