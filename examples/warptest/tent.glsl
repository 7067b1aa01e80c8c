// A tent in each coordinate of the unit square, peaked at 1/2 (like pbrt's SampleTent): the
// density of one coordinate is t(x) = 4x below 1/2 and 4(1 - x) above, its CDF 2x^2 and
// 1 - 2(1 - x)^2, inverted piecewise.
//   lift-gl warptest examples/warptest/tent.glsl --sampler tent --domain square

float tent_1d(float u) {
    return u < 0.5 ? sqrt(0.5 * u) : 1.0 - sqrt(0.5 * (1.0 - u));
}

float tent_density_1d(float x) {
    return x < 0.5 ? 4.0 * x : 4.0 * (1.0 - x);
}

vec2 tent(vec2 u) { return vec2(tent_1d(u.x), tent_1d(u.y)); }

// Area density on [0,1]^2: the two coordinates are independent.
float tent_pdf(vec2 p) { return tent_density_1d(p.x) * tent_density_1d(p.y); }
