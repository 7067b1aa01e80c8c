// G-buffer, triangles: vertices come from the scene's SSBOs (three per triangle, in BVH
// order), so gl_VertexID / 3 is the triangle id the trace pass uses.
// With LIFT_INSTANCE_DRAW, one draw places one prototype's BLAS triangles (object space) once
// per instance record u_instance_first + gl_InstanceID (lift_gl/passes/gbuffer.py).
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
#ifdef LIFT_INSTANCE_DRAW
uniform uint u_instance_first;
flat out uint v_instance;
#ifdef LIFT_MOTION_VECTORS
uniform uint u_prev_instance_rows;  // prev_positions row of instance 0's previous transform
#endif
#endif
void main() {
    uint corner = uint(gl_VertexID) % 3u;
    v_prim = uint(gl_VertexID) / 3u;
    v_bary = corner == 1u ? vec2(1.0, 0.0) : (corner == 2u ? vec2(0.0, 1.0) : vec2(0.0));
    v_normal = tri_normal_row(uint(gl_VertexID)).xyz;
    v_world = tri_pos_row(uint(gl_VertexID)).xyz;
#ifdef LIFT_INSTANCE_DRAW
    v_instance = u_instance_first + uint(gl_InstanceID);
    vec4 object = vec4(v_world, 1.0);
    v_world = instance_point_to_world(v_instance, v_world);
    v_normal = instance_normal_to_world(v_instance, v_normal);
#endif
    gl_Position = u_view_proj * vec4(v_world, 1.0);
#ifdef LIFT_MOTION_VECTORS
#ifdef LIFT_INSTANCE_DRAW
    // the instance's transform in the last frame (rows of a 3x4 matrix, lift_gl/temporal.py)
    uint r = u_prev_instance_rows + 3u * v_instance;
    v_prev_world = vec3(dot(prev_positions[r], object), dot(prev_positions[r + 1u], object),
                        dot(prev_positions[r + 2u], object));
#else
    v_prev_world = prev_positions[gl_VertexID].xyz;  // the same corner where the last frame saw it
#endif
#endif
}
