// lift/textures.glsl: image textures and the material at a surface point.
// Textures live in the `images` buffer (lift_gl/scene/images.py): texture t has a
// descriptor at images[4t .. 4t+3] = (first texel word, width, height, flags; bit 0: sRGB)
// and RGBA8 texels, one word each, rows from the top of the image. Texture coordinates are
// OpenGL's: (0, 0) is the bottom-left corner; the image repeats outside [0, 1].
#ifndef LIFT_TEXTURES_GLSL
#define LIFT_TEXTURES_GLSL
#include "lift/scene_data.glsl"

#ifdef HAS_TEXTURES
// The exact sRGB decoding curve (IEC 61966-2-1), per channel.
vec3 srgb_to_linear(vec3 c) {
    return mix(pow((c + 0.055) / 1.055, vec3(2.4)), c / 12.92, lessThanEqual(c, vec3(0.04045)));
}

// Texel (x, y) of the texture whose texels start at word `first`, RGBA in [0, 1], decoded to
// linear where `srgb`.
vec4 texture_texel(uint first, uint width, int x, int y, bool srgb) {
    vec4 c = unpackUnorm4x8(images[first + uint(y) * width + uint(x)]);
    if (srgb) c.rgb = srgb_to_linear(c.rgb);
    return c;
}

// Bilinear filtering between texel centres, in linear space (decoded before filtering).
vec4 texture_lookup(uint t, vec2 uv) {
    uint first = images[4u * t], flags = images[4u * t + 3u];
    int w = int(images[4u * t + 1u]), h = int(images[4u * t + 2u]);
    bool srgb = (flags & 1u) != 0u;
    // Row 0 is the top of the image, v = 0 its bottom.
    vec2 p = vec2(uv.x * float(w), (1.0 - uv.y) * float(h)) - 0.5;
    vec2 p0 = floor(p);
    vec2 f = p - p0;
    // Repeat: the positive remainder, also for coordinates far outside [0, 1].
    int x0 = int(mod(p0.x, float(w))), y0 = int(mod(p0.y, float(h)));
    x0 = clamp(x0, 0, w - 1);
    y0 = clamp(y0, 0, h - 1);
    int x1 = x0 + 1 == w ? 0 : x0 + 1, y1 = y0 + 1 == h ? 0 : y0 + 1;
    vec4 top = mix(texture_texel(first, uint(w), x0, y0, srgb), texture_texel(first, uint(w), x1, y0, srgb), f.x);
    vec4 bottom = mix(texture_texel(first, uint(w), x0, y1, srgb), texture_texel(first, uint(w), x1, y1, srgb), f.x);
    return mix(top, bottom, f.y);
}
#endif

// Texture coordinates on a sphere with outward normal n: longitude, latitude from +y.
vec2 sphere_uv(vec3 n) {
    return vec2(atan(n.z, n.x) * 0.15915494 + 0.5, acos(clamp(n.y, -1.0, 1.0)) * 0.31830989);
}

// What material id's texture multiplies its base colour by at uv: 1 where it has none.
vec3 texture_tint(uint id, vec2 uv) {
#ifdef HAS_TEXTURES
    uint tex = uint(materials[id].k_pad.w + 0.5);
    if (tex > 0u) return texture_lookup(tex - 1u, uv).rgb;
#endif
    return vec3(1.0);
}

// materials[id] with a tint from texture_tint applied: for code that keeps the tint of a
// point to shade it again later (bdpt's path vertices) instead of looking the texture up again.
Material material_tinted(uint id, vec3 tint) {
    Material m = materials[id];
    m.color_type.rgb *= tint;
    return m;
}

// The material at a surface point: materials[id] with its textures applied (the base
// colour times the texture's colour at uv). Plugins use this rather than materials[id].
Material material_at(uint id, vec2 uv) {
#ifdef HAS_TEXTURES
    return material_tinted(id, texture_tint(id, uv));
#else
    return materials[id];
#endif
}
#endif
