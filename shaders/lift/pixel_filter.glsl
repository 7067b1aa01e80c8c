// The scene's pixel filter for traced camera rays and splats (compiled in with HAS_PIXEL_FILTER): a
// uniform point in [0, 1)^2 becomes a subpixel offset drawn from the rendered pixel's
// kernel, by inverting the cumulative distribution the host tabulates per axis at evenly
// spaced offsets (lift_gl/passes/pixel_filter.py; the G-buffer's jitter inverts the same knots).
#ifndef LIFT_PIXEL_FILTER_GLSL
#define LIFT_PIXEL_FILTER_GLSL

#define PIXEL_FILTER_KNOTS 129      // 2^7 + 1: the search below takes 7 steps
uniform float u_filter_cdf_x[PIXEL_FILTER_KNOTS];
uniform float u_filter_cdf_y[PIXEL_FILTER_KNOTS];
uniform vec4 u_filter_span;         // first offset and spacing of the knots: x axis, y axis

// Knot i of an axis's tabulated CDF (axis 0: x, 1: y).
float filter_cdf(int axis, int i) {
    return axis == 0 ? u_filter_cdf_x[i] : u_filter_cdf_y[i];
}

// The offset along one axis (rendered pixels from the pixel's corner) whose CDF is u: a
// binary search of the knots, then linear between two.
float pixel_filter_axis(int axis, float u) {
    int lo = 0, hi = PIXEL_FILTER_KNOTS - 1;  // cdf[lo] <= u < cdf[hi]
    for (int step = 0; step < 7; ++step) {
        int mid = (lo + hi) >> 1;
        if (filter_cdf(axis, mid) <= u) lo = mid; else hi = mid;
    }
    float c0 = filter_cdf(axis, lo), c1 = filter_cdf(axis, hi);
    float f = c1 > c0 ? clamp((u - c0) / (c1 - c0), 0.0, 1.0) : 0.5;
    vec2 span = axis == 0 ? u_filter_span.xy : u_filter_span.zw;
    return span.x + (float(lo) + f) * span.y;
}

// The kernel's density at `offset` (rendered pixels from the pixel's corner) along an axis:
// constant between two knots, as the sampling above draws it.
float pixel_filter_density(int axis, float offset) {
    vec2 span = axis == 0 ? u_filter_span.xy : u_filter_span.zw;
    float k = (offset - span.x) / span.y;
    if (!(k >= 0.0 && k < float(PIXEL_FILTER_KNOTS - 1))) return 0.0;
    int i = int(k);
    return (filter_cdf(axis, i + 1) - filter_cdf(axis, i)) / span.y;
}

// A subpixel offset drawn from the pixel filter's kernel, from two uniform numbers.
vec2 pixel_filter_offset(vec2 u) {
    return vec2(pixel_filter_axis(0, u.x), pixel_filter_axis(1, u.y));
}

#endif
