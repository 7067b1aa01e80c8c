// WRONG on purpose: the tent of tent.glsl, with its pdf 5% too large (a peak of 4.2 instead
// of 4 in x). The sampler is right; warptest rejects the pair (the histogram sees 5% fewer
// samples than the pdf promises in every cell, and the pdf integrates to 1.05).
//   lift-gl warptest examples/warptest/tent_pdf_off_5_percent.glsl --sampler tent --domain square

float tent_1d(float u) {
    return u < 0.5 ? sqrt(0.5 * u) : 1.0 - sqrt(0.5 * (1.0 - u));
}

vec2 tent(vec2 u) { return vec2(tent_1d(u.x), tent_1d(u.y)); }

float tent_pdf(vec2 p) {
    float tx = p.x < 0.5 ? 4.2 * p.x : 4.2 * (1.0 - p.x);  // the bug: 4.2
    float ty = p.y < 0.5 ? 4.0 * p.y : 4.0 * (1.0 - p.y);
    return tx * ty;
}
