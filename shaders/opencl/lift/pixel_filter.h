// The scene's pixel filter for traced camera rays (HAS_PIXEL_FILTER), as
// shaders/lift/pixel_filter.glsl: the host appends to the frame's values, after its
// FRAME_LAYOUT rows (lift_gl/passes/trace_cl.py), one row of knot spans (first offset and
// spacing, x then y) and the two axes' cumulative distributions, PIXEL_FILTER_STRIDE floats each.
#ifndef LIFT_PIXEL_FILTER_H
#define LIFT_PIXEL_FILTER_H

#define PIXEL_FILTER_KNOTS 129   // 2^7 + 1: the search below takes 7 steps
#define PIXEL_FILTER_STRIDE 132  // the knots, padded to whole float4 rows

float pixel_filter_axis(__global const float4* filter_rows, int axis, float u) {
    __global const float* cdf = (__global const float*)(filter_rows + 1) + axis * PIXEL_FILTER_STRIDE;
    int lo = 0, hi = PIXEL_FILTER_KNOTS - 1;  // cdf[lo] <= u < cdf[hi]
    for (int step = 0; step < 7; ++step) {
        int mid = (lo + hi) >> 1;
        if (cdf[mid] <= u) lo = mid; else hi = mid;
    }
    float c0 = cdf[lo], c1 = cdf[hi];
    float t = c1 > c0 ? clamp((u - c0) / (c1 - c0), 0.0f, 1.0f) : 0.5f;
    float4 span = filter_rows[0];
    return axis == 0 ? span.x + ((float)lo + t) * span.y : span.z + ((float)lo + t) * span.w;
}

float2 pixel_filter_offset(__global const float4* filter_rows, float2 u) {
    return (float2)(pixel_filter_axis(filter_rows, 0, u.x), pixel_filter_axis(filter_rows, 1, u.y));
}

#endif
