// G-buffer, triangles: vertices come from the scene's SSBOs (three per triangle, in BVH
// order), so gl_VertexID / 3 is the triangle id the trace pass uses.
#include "lift/scene_data.glsl"
uniform mat4 u_view_proj;
flat out uint v_prim;
out vec2 v_bary;
out vec3 v_normal;
out vec3 v_world;
#ifdef LIFT_MOTION_VECTORS
#define LIFT_VERTEX_STAGE
#include "passes/motion_vectors.glsl"
out vec3 v_prev_world;
#endif
void main() {
    uint corner = uint(gl_VertexID) % 3u;
    v_prim = uint(gl_VertexID) / 3u;
    v_bary = corner == 1u ? vec2(1.0, 0.0) : (corner == 2u ? vec2(0.0, 1.0) : vec2(0.0));
    v_normal = tri_normal_row(uint(gl_VertexID)).xyz;
    v_world = tri_pos_row(uint(gl_VertexID)).xyz;
    gl_Position = u_view_proj * vec4(v_world, 1.0);
#ifdef LIFT_MOTION_VECTORS
    v_prev_world = prev_positions[gl_VertexID].xyz;  // the same corner where the last frame saw it
#endif
}
