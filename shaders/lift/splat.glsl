// lift/splat.glsl: adding to any pixel of the frame, not only the one being shaded — what
// light tracing (BDPT's t = 1 strategy) needs: a light subpath seen by the camera lands on
// whichever pixel it projects to.
//
// The host declares the buffer only for plugins whose manifest says `splats = true`
// (it defines LIFT_SPLATS); everywhere else this file compiles to nothing. After the trace
// pass, the host adds the buffer to the frame's radiance sums and clears it, so a splat is
// averaged like the pixel's own samples: the mean divides it by the pixel's sample count.
// A light subpath per pixel sample then gives the light-tracing estimate with no extra factor.
//
// Sums are float atomics (GL_NV_shader_atomic_float, on llvmpipe and NVIDIA), or else a
// compare-and-swap loop on the float's bits (LIFT_SPLATS_CAS). Either way the order of the
// additions varies from run to run, so splatted images repeat only to float rounding.
#ifndef LIFT_SPLAT_GLSL
#define LIFT_SPLAT_GLSL
#ifdef LIFT_SPLATS
#include "lift/scene_data.glsl"
#include "lift/camera.glsl"
#include "lift/finite.glsl"
#ifdef HAS_PIXEL_FILTER
#include "lift/pixel_filter.glsl"
#endif

// Three floats per pixel (r, g, b), row-major with row 0 at the bottom (pixel y up).
#ifdef LIFT_SPLATS_CAS
layout(std430, binding = LIFT_BINDING_SPLATS) buffer LiftSplats { uint lift_splats[]; };
#else
layout(std430, binding = LIFT_BINDING_SPLATS) buffer LiftSplats { float lift_splats[]; };
#endif

void lift_splat_add(uint index, float value) {
#ifdef LIFT_SPLATS_CAS
    uint seen = lift_splats[index];
    while (true) {
        uint expected = seen;
        seen = atomicCompSwap(lift_splats[index], expected, floatBitsToUint(uintBitsToFloat(expected) + value));
        if (seen == expected) break;
    }
#else
    atomicAdd(lift_splats[index], value);
#endif
}

// Adds `value` to one pixel's sums, unweighted and unchecked (splat does both).
void splat_pixel(ivec2 pixel, vec3 value) {
    uint index = 3u * (uint(pixel.y) * uint(u_resolution.x) + uint(pixel.x));
    lift_splat_add(index, value.r);
    lift_splat_add(index + 1u, value.g);
    lift_splat_add(index + 2u, value.b);
}

// Adds `value` — one sample's whole contribution; the host divides by the sample count — to
// the pixel that contains the pixel position (pixels, y up, as camera_ray takes it), or, with
// the scene's pixel filter, to every pixel whose kernel covers it, weighted by the kernel
// there (the density that pixel's own camera samples are drawn from). Positions no pixel
// covers are ignored; a NaN or infinite value is dropped and counted in stats[1].
void splat(vec2 pixel_pos, vec3 value) {
    if (!lift_is_finite(value)) {
        atomicAdd(stats[1], 1u);
        return;
    }
    if (all(equal(value, vec3(0.0)))) return;
#ifdef HAS_PIXEL_FILTER
    // Pixel c's kernel covers offsets pixel_pos - c in [first, last).
    vec2 first = u_filter_span.xz;
    vec2 last = first + float(PIXEL_FILTER_KNOTS - 1) * u_filter_span.yw;
    ivec2 lo = max(ivec2(floor(pixel_pos - last)) + 1, ivec2(0));
    ivec2 hi = min(ivec2(floor(pixel_pos - first)), ivec2(u_resolution) - 1);
    for (int y = lo.y; y <= hi.y; ++y) {
        float wy = pixel_filter_density(1, pixel_pos.y - float(y));
        for (int x = lo.x; x <= hi.x; ++x) {
            float w = wy * pixel_filter_density(0, pixel_pos.x - float(x));
            if (w > 0.0) splat_pixel(ivec2(x, y), value * w);
        }
    }
#else
    ivec2 pixel = ivec2(floor(pixel_pos));
    if (!pixel_in_image(pixel)) return;
    splat_pixel(pixel, value);
#endif
}
#endif
#endif
