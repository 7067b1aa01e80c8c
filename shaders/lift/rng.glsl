// lift/rng.glsl: per-sample random numbers. PCG (O'Neill) hash for decorrelated seeds,
// then a PCG stream; every number is a deterministic function of (pixel, frame, sample, seed).
// rng_ld2 adds low-discrepancy pairs for a path's light and BSDF samples (see below).
#ifndef LIFT_RNG_GLSL
#define LIFT_RNG_GLSL

// A sample's random number state. The host makes one per sample (rng_init_pixel_sample) and
// passes it to radiance() as `inout Rng rng`; draw from it with rng_next, rng_next2,
// rng_next3 and rng_ld2.
struct Rng {
    uint state;         // PCG stream: rng_next
    uint sample_index;  // this pixel's sample number over all frames: rng_ld2's sequence index
    uint ld_seed;       // per-pixel hash for rng_ld2's random shifts
    uint ld_pair;       // how many rng_ld2 pairs this sample used
};

// PCG's output permutation as a hash of one word (Jarzynski and Olano 2020).
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A state decorrelated from every other (pixel, frame, sample, seed).
Rng rng_init(uvec2 pixel, uint frame, uint sample_index, uint seed) {
    uint h = pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(sample_index + pcg_hash(seed)))));
    return Rng(h, frame, pcg_hash(pixel.x ^ pcg_hash(pixel.y ^ pcg_hash(seed + 0x9e3779b9u))), 0u);
}

// The host's seeding: `pixel_sample` counts this pixel's samples in its stream over all
// frames, so that rng_ld2 walks one low-discrepancy sequence across the accumulation.
// Streams are independently scrambled sequences: the host gives each half of the frames (the
// error estimate's two halves) its own, so the halves stay independent estimates.
Rng rng_init_pixel_sample(uvec2 pixel, uint frame, uint sample_in_frame, uint pixel_sample, uint seed, uint stream) {
    Rng r = rng_init(pixel, frame, sample_in_frame, seed);
    r.sample_index = pixel_sample;
    r.ld_seed = pcg_hash(r.ld_seed ^ pcg_hash(stream + 0x68bc21ebu));
    return r;
}

// Uniform in [0, 1): 24 random bits, so 1.0 is never returned.
float rng_next(inout Rng r) {
    r.state = r.state * 747796405u + 2891336453u;
    uint word = ((r.state >> ((r.state >> 28u) + 4u)) ^ r.state) * 277803737u;
    word = (word >> 22u) ^ word;
    return float(word >> 8u) * (1.0 / 16777216.0);
}

// Two and three uniform numbers in [0, 1), drawn by rng_next one after the other.
vec2 rng_next2(inout Rng r) { return vec2(rng_next(r), rng_next(r)); }
vec3 rng_next3(inout Rng r) { return vec3(rng_next(r), rng_next(r), rng_next(r)); }

// ---- Low-discrepancy pairs: Owen-scrambled Sobol points, a new scramble per pair ----
// rng_ld2 returns pair number `ld_pair` of this pixel's sample `sample_index`: the first two
// Sobol dimensions (a (0,2)-sequence, stratified in every elementary interval), Owen-scrambled
// with a hash keyed on (pixel, pair), and the sample index itself scrambled per pair so that
// different pairs are decorrelated ("padding", as in Burley 2020, "Practical Hash-based Owen
// Scrambling"). For a random key every output is exactly uniform (x + key is uniform and the
// permutation is a bijection), so estimators stay unbiased; over a pixel's samples each pair
// fills the square far more evenly than independent numbers. Used for the light and BSDF
// samples of every bounce, it lowers the error at equal sample count.

// A bijection of 32-bit words in which each bit depends only on itself and the bits below it
// (Laine and Karras 2011): applied to bit-reversed values it permutes nested intervals.
uint lk_permute(uint x, uint key) {
    x += key;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Owen scrambling of a 32-bit fixed-point value in [0, 1), keyed.
uint owen_scramble(uint x, uint key) { return bitfieldReverse(lk_permute(bitfieldReverse(x), key)); }

// Sobol's second dimension, bit-reversed. Its generator matrix (rows v_k = v_(k-1) ^
// (v_(k-1) >> 1), v_0 = 2^31) is Pascal's triangle mod 2, so by Lucas' theorem output bit j
// (counted from the top) is the XOR of the index bits k whose bit positions contain j's
// (k & j == j): five butterfly steps, one per bit of a position. No loop: a loop over the
// index bits ran 32 times (the scrambled index is a random word), and on llvmpipe every
// iteration costs the whole SIMD batch; and llvmpipe stops an invocation after 65535 loop
// iterations in all, which that loop spent at about 60 a bounce.
uint sobol_dimension_1_reversed(uint index) {
    index ^= (index >> 1u) & 0x55555555u;
    index ^= (index >> 2u) & 0x33333333u;
    index ^= (index >> 4u) & 0x0f0f0f0fu;
    index ^= (index >> 8u) & 0x00ff00ffu;
    index ^= (index >> 16u) & 0x0000ffffu;
    return index;
}

// The sample's next low-discrepancy pair in [0, 1)^2 (see above); for the two numbers of a
// light or BSDF sample at each bounce, in the same order in every sample.
vec2 rng_ld2(inout Rng r) {
    uint key = pcg_hash(r.ld_seed + r.ld_pair++ * 0x9e3779b9u);
    uint index = owen_scramble(r.sample_index, key);
    uint x = owen_scramble(bitfieldReverse(index), pcg_hash(key ^ 0xa511e9b3u));
    uint y = bitfieldReverse(lk_permute(sobol_dimension_1_reversed(index), pcg_hash(key ^ 0x63d83595u)));  // owen_scramble of the unreversed
    return vec2(x >> 8u, y >> 8u) * (1.0 / 16777216.0);
}

#endif
