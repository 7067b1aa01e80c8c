// G-buffer, triangles: visibility (primitive id + 1, barycentrics, material; with instances
// the instance + 1 in w's high 16 bits), shading
// normal facing the camera with view depth, and albedo (the denoiser's guide).
#include "lift/scene_data.glsl"
#include "lift/bsdf.glsl"
#include "lift/textures.glsl"
uniform vec3 u_cam_pos;
uniform vec3 u_cam_forward;
uniform float u_inv_depth_scale;      // the depth test's depth (lift_gl/passes/camera.py DEPTH_STEPS)
uniform float u_inv_log_depth_range;
flat in uint v_prim;
in vec2 v_bary;
in vec3 v_normal;
in vec3 v_world;
#ifdef LIFT_INSTANCE_DRAW
flat in uint v_instance;
#endif
layout(location = 0) out uvec4 o_visibility;
layout(location = 1) out vec4 o_normal_depth;
layout(location = 2) out vec4 o_albedo;
#ifdef LIFT_MOTION_VECTORS
#include "passes/motion_vectors.glsl"
in vec3 v_prev_world;
layout(location = 3) out vec4 o_motion;
#endif
void main() {
    uint material = tri_info_at(v_prim).x;
#ifdef LIFT_INSTANCE_DRAW
    // w: the material in the low 16 bits, the instance record + 1 above (visibility_instance)
    material = instance_material(v_instance, v_prim);
    uint tag = material | ((v_instance + 1u) << 16u);
#else
    uint tag = material;
#endif
    o_visibility = uvec4(v_prim + 1u, floatBitsToUint(v_bary.x), floatBitsToUint(v_bary.y), tag);
    vec3 n = length(v_normal) > 0.0 ? normalize(v_normal) : vec3(0.0, 0.0, 1.0);
    if (dot(n, u_cam_pos - v_world) < 0.0) n = -n;
    float view_depth = dot(v_world - u_cam_pos, u_cam_forward);
    gl_FragDepth = clamp(log2(1.0 + max(view_depth, 0.0) * u_inv_depth_scale) * u_inv_log_depth_range, 0.0, 1.0);
    o_normal_depth = vec4(n, view_depth);
#ifdef LIFT_MOTION_VECTORS
    o_motion = motion_vector(v_world, v_prev_world, fwidth(view_depth));
#endif
    uint i = 3u * v_prim;
    vec2 uv = (1.0 - v_bary.x - v_bary.y) * tri_uv_row(i).xy + v_bary.x * tri_uv_row(i + 1u).xy + v_bary.y * tri_uv_row(i + 2u).xy;
    o_albedo = vec4(bsdf_albedo(material_at(material, uv)), 1.0);
}
