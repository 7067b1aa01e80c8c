// Which of the previous frame's pixels hold this pixel's history: the rule of the reprojection
// (reproject.comp) in one place, for the accumulation and for a temporal denoiser's input.
//
// The G-buffer's motion vector says where pixel p's first hit was in the previous frame; the
// 2x2 bilinear taps there count only where the previous frame saw the same surface:
//   - depth: the tap's view depth (previous frame) matches the view depth this point had in
//     the previous camera, within 2 x the depth change per pixel (a slanted floor changes
//     depth quickly from pixel to pixel and must not be rejected) plus a small relative slack;
//   - normal: the two normals agree within normal_cos.
// No surface here (the background), or a tap off screen, keeps nothing.
#ifndef LIFT_HISTORY_TAPS_GLSL
#define LIFT_HISTORY_TAPS_GLSL

struct HistoryTaps {
    ivec2 base;      // the top-left tap; tap i is base + (i & 1, i >> 1)
    vec4 weight;     // each tap's bilinear weight where it holds the same surface, else 0
    vec3 rejected;   // bilinear weight rejected by depth (x), by normal (y), off screen or no surface (z)
};

HistoryTaps history_taps(ivec2 p, ivec2 size, vec4 nd, vec4 motion, sampler2D prev_normal_depth,
                         float depth_slack, float normal_cos) {
    HistoryTaps taps;
    taps.base = p;
    taps.weight = vec4(0.0);
    taps.rejected = vec3(0.0, 0.0, 1.0);
    if (!(nd.w > 0.0)) return taps;  // a surface (the background keeps no history)
    taps.rejected = vec3(0.0);
    vec2 position = vec2(p) + motion.xy;  // (p + 0.5 + motion) - 0.5: texel centres at integers
    position = clamp(position, vec2(-2.0), vec2(size) + 1.0);  // far off screen: no int overflow
    taps.base = ivec2(floor(position));
    vec2 f = position - vec2(taps.base);
    float tolerance = 2.0 * motion.w + depth_slack * motion.z;
    for (int i = 0; i < 4; ++i) {
        ivec2 o = ivec2(i & 1, i >> 1);
        ivec2 q = taps.base + o;
        float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
        if (w <= 0.0) continue;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) { taps.rejected.z += w; continue; }
        vec4 prev_nd = texelFetch(prev_normal_depth, q, 0);
        if (!(prev_nd.w > 0.0) || abs(prev_nd.w - motion.z) > tolerance) { taps.rejected.x += w; continue; }
        if (dot(prev_nd.xyz, nd.xyz) < normal_cos) { taps.rejected.y += w; continue; }
        taps.weight[i] = w;
    }
    return taps;
}

#endif
