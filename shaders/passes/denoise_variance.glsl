// The variance guide of the denoiser: the variance of one pixel's mean irradiance luminance.
// One function, so that a better source (temporal moments) can replace it in one place.
//
// Now: from the accumulation's two half-buffers (lift_gl/error_estimate.py). With half means
// A (n_a samples) and B (n_b samples), (A - B)^2 n_a n_b / n^2 estimates the variance of the
// mean (one degree of freedom). Taken on the luminance of the demodulated gap, so that the
// correlation of the colour channels is kept. Negative: unknown (one half is still empty).
#ifndef LIFT_DENOISE_VARIANCE_GLSL
#define LIFT_DENOISE_VARIANCE_GLSL

float denoise_luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

float luminance_variance(vec4 totals, vec4 half_difference, vec3 divisor) {
    vec4 a = 0.5 * (totals + half_difference);
    vec4 b = 0.5 * (totals - half_difference);
    float n_a = floor(a.a + 0.5), n_b = floor(b.a + 0.5);
    if (n_a <= 0.0 || n_b <= 0.0) return -1.0;
    float n = n_a + n_b;
    float gap = denoise_luminance((a.rgb / n_a - b.rgb / n_b) / divisor);
    return gap * gap * n_a * n_b / (n * n);
}
#endif
