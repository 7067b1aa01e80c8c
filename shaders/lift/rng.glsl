// lift/rng.glsl: per-sample random numbers. PCG (O'Neill) hash for decorrelated seeds,
// then a PCG stream; every number is a deterministic function of (pixel, frame, sample, seed).
// rng_ld2 adds low-discrepancy pairs for the first decisions of a path (see below).
#ifndef LIFT_RNG_GLSL
#define LIFT_RNG_GLSL

struct Rng {
    uint state;         // PCG stream: rng_next
    uint sample_index;  // this pixel's sample number over all frames: rng_ld2's sequence index
    uint ld_seed;       // per-pixel hash for rng_ld2's random shifts
    uint ld_pair;       // how many rng_ld2 pairs this sample used
};

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

Rng rng_init(uvec2 pixel, uint frame, uint sample_index, uint seed) {
    uint h = pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(sample_index + pcg_hash(seed)))));
    return Rng(h, frame, pcg_hash(pixel.x ^ pcg_hash(pixel.y ^ pcg_hash(seed + 0x9e3779b9u))), 0u);
}

// The host's seeding: `pixel_sample` counts this pixel's samples over all frames, so that
// rng_ld2 walks one low-discrepancy sequence across the whole accumulation.
Rng rng_init_pixel_sample(uvec2 pixel, uint frame, uint sample_in_frame, uint pixel_sample, uint seed) {
    Rng r = rng_init(pixel, frame, sample_in_frame, seed);
    r.sample_index = pixel_sample;
    return r;
}

// Uniform in [0, 1): 24 random bits, so 1.0 is never returned.
float rng_next(inout Rng r) {
    r.state = r.state * 747796405u + 2891336453u;
    uint word = ((r.state >> ((r.state >> 28u) + 4u)) ^ r.state) * 277803737u;
    word = (word >> 22u) ^ word;
    return float(word >> 8u) * (1.0 / 16777216.0);
}

vec2 rng_next2(inout Rng r) { return vec2(rng_next(r), rng_next(r)); }

// A low-discrepancy pair: point `sample_index` of the 4D Kronecker (R4) sequence, pair
// `ld_pair` of it (dims 1-2, then 3-4), rotated by a random shift per pixel and pair
// (Cranley-Patterson). Each pair is exactly uniform for every pixel (the shift is), so
// estimators stay unbiased, and over a pixel's samples the pairs fill the square far more
// evenly than independent numbers: for the first light and BSDF samples of a path this
// lowers the error at equal sample count. Beyond two pairs it falls back to rng_next2.
vec2 rng_ld2(inout Rng r) {
    // 1 / phi^i, phi the real root of x^5 = x + 1 (Roberts' generalised golden ratio)
    const vec4 ALPHA = vec4(0.85667488, 0.73389185, 0.62870298, 0.53859013);
    uint pair = r.ld_pair++;
    if (pair >= 2u) return rng_next2(r);
    uint h = pcg_hash(r.ld_seed + pair);
    vec2 shift = vec2(float(h >> 8u), float(pcg_hash(h) >> 8u)) * (1.0 / 16777216.0);
    vec2 alpha = pair == 0u ? ALPHA.xy : ALPHA.zw;
    // fract(n * alpha) in fixed point: exact for any n, where n * alpha in float is not.
    uvec2 step_fixed = uvec2(alpha * 4294967296.0);
    uvec2 point_fixed = step_fixed * r.sample_index;
    return fract(vec2(point_fixed >> 8u) * (1.0 / 16777216.0) + shift);
}
vec3 rng_next3(inout Rng r) { return vec3(rng_next(r), rng_next(r), rng_next(r)); }

#endif
