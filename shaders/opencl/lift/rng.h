// lift/rng.h: per-sample random numbers, the same PCG hash and stream as shaders/lift/rng.glsl:
// a sample of an OpenCL plugin draws the numbers its GLSL twin draws for the same
// (pixel, frame, sample, seed).
#ifndef LIFT_CL_RNG_H
#define LIFT_CL_RNG_H

typedef struct { uint state; } Rng;

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

Rng rng_init(uint2 pixel, uint frame, uint sample_index, uint seed) {
    Rng r;
    r.state = pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(sample_index + pcg_hash(seed)))));
    return r;
}

// Uniform in [0, 1): 24 random bits, so 1.0 is never returned.
float rng_next(Rng* r) {
    r->state = r->state * 747796405u + 2891336453u;
    uint word = ((r->state >> ((r->state >> 28u) + 4u)) ^ r->state) * 277803737u;
    word = (word >> 22u) ^ word;
    return (float)(word >> 8u) * (1.0f / 16777216.0f);
}

// C leaves the order of a vector literal's components unspecified: draw one at a time.
float2 rng_next2(Rng* r) {
    float a = rng_next(r);
    float b = rng_next(r);
    return (float2)(a, b);
}

float3 rng_next3(Rng* r) {
    float a = rng_next(r);
    float b = rng_next(r);
    float c = rng_next(r);
    return (float3)(a, b, c);
}

#endif
