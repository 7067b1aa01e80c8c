// lift/rng.glsl: per-sample random numbers. PCG (O'Neill) hash for decorrelated seeds,
// then a PCG stream; every number is a deterministic function of (pixel, frame, sample, seed).
#ifndef LIFT_RNG_GLSL
#define LIFT_RNG_GLSL

struct Rng { uint state; };

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

Rng rng_init(uvec2 pixel, uint frame, uint sample_index, uint seed) {
    uint h = pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(sample_index + pcg_hash(seed)))));
    return Rng(h);
}

// Uniform in [0, 1): 24 random bits, so 1.0 is never returned.
float rng_next(inout Rng r) {
    r.state = r.state * 747796405u + 2891336453u;
    uint word = ((r.state >> ((r.state >> 28u) + 4u)) ^ r.state) * 277803737u;
    word = (word >> 22u) ^ word;
    return float(word >> 8u) * (1.0 / 16777216.0);
}

vec2 rng_next2(inout Rng r) { return vec2(rng_next(r), rng_next(r)); }
vec3 rng_next3(inout Rng r) { return vec3(rng_next(r), rng_next(r), rng_next(r)); }

#endif
