// Shared by the à-trous passes: guides and the background test.
#ifndef LIFT_ATROUS_COMMON_GLSL
#define LIFT_ATROUS_COMMON_GLSL
uniform sampler2D u_normal_depth;  // normal (xyz; zero where no surface), view depth (w)

bool is_surface(vec4 nd) { return dot(nd.xyz, nd.xyz) > 0.25; }

float atrous_luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// Screen-space gradient of view depth at p: per axis the smaller one-sided difference, so a
// depth edge next to p does not widen the tolerance of the whole surface.
vec2 depth_gradient(ivec2 p, ivec2 size, float z) {
    vec2 g;
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 e = axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
        ivec2 fwd = min(p + e, size - 1), back = max(p - e, ivec2(0));
        vec4 f = texelFetch(u_normal_depth, fwd, 0), b = texelFetch(u_normal_depth, back, 0);
        float df = is_surface(f) ? f.w - z : 1e30, db = is_surface(b) ? z - b.w : 1e30;
        float d = abs(df) < abs(db) ? df : db;
        g[axis] = abs(d) < 1e29 ? d : 0.0;
    }
    return g;
}
#endif
