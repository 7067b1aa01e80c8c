// G-buffer, spheres: each sphere is drawn as the back faces of its bounding cube, and the
// fragment shader intersects the exact sphere (an impostor), so silhouettes are exact.
#include "lift/scene_data.glsl"
uniform mat4 u_view_proj;
flat out uint v_sphere;
out vec3 v_world;
// The 36 corners of a cube's 12 triangles, from the vertex index.
vec3 cube_corner(int i) {
    const int faces[36] = int[36](0,2,1, 1,2,3, 4,5,6, 5,7,6, 0,1,4, 1,5,4, 2,6,3, 3,6,7, 0,4,2, 2,4,6, 1,3,5, 3,7,5);
    int c = faces[i];
    return vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1) * 2.0 - 1.0;
}
void main() {
    v_sphere = uint(gl_InstanceID);
    vec4 cr = spheres[2 * gl_InstanceID];
    v_world = cr.xyz + cr.w * 1.001 * cube_corner(gl_VertexID);
    gl_Position = u_view_proj * vec4(v_world, 1.0);
}
