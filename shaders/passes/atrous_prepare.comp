// À-trous, before the first iteration: where the variance is unknown (one half-buffer still
// empty, i.e. a single frame), estimate it spatially, as SVGF does for a short history: the
// luminance variance over the 5x5 neighbours on the same surface (normal and depth test).
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/atrous_common.glsl"
layout(rgba32f, binding = 0) uniform readonly image2D u_in;
layout(rgba32f, binding = 1) uniform writeonly image2D u_out;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_out);
    if (any(greaterThanEqual(p, size))) return;
    vec4 c = imageLoad(u_in, p);
    vec4 nd = texelFetch(u_normal_depth, p, 0);
    if (!is_surface(nd)) {  // background: passed through; variance 0 for the 3x3 blur of its neighbours
        imageStore(u_out, p, vec4(c.rgb, 0.0));
        return;
    }
    if (c.a >= 0.0) {
        imageStore(u_out, p, c);
        return;
    }
    float m1 = 0.0, m2 = 0.0, count = 0.0;
    for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            vec4 nd_q = texelFetch(u_normal_depth, q, 0);
            if (!is_surface(nd_q) || dot(nd.xyz, nd_q.xyz) < 0.9
                || abs(nd_q.w - nd.w) > 0.05 * max(abs(nd.w), 1e-6)) continue;
            float l = atrous_luminance(imageLoad(u_in, q).rgb);
            m1 += l;
            m2 += l * l;
            count += 1.0;
        }
    }
    m1 /= count;
    imageStore(u_out, p, vec4(c.rgb, max(m2 / count - m1 * m1, 0.0) * count / max(count - 1.0, 1.0)));
}
