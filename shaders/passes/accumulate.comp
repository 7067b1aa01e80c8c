// Accumulate, still camera: the exact running sum of every frame's (radiance sum, sample
// count), kept in float32 with Neumaier's compensated summation, so that the mean stays
// exact to float precision over millions of frames (a plain float sum stops growing once
// a frame's contribution falls below half an ulp of the total).
//
// Beside it, the difference of the two half-buffers: frames of half A added, of half B
// subtracted (the host picks each frame's half at random: passes/accumulate.py half_sign).
// The halves are independent estimates of the same image, so their difference measures the
// noise of the mean without a reference (lift_gl/error_estimate.py).
// It is a plain float sum: it only needs two or three correct digits, and its rounding
// error grows like sqrt(frames) ulps of a value that itself grows like sqrt(frames).
//
// A moving camera does not change this pass: the reprojection pass (reproject.comp) runs
// before it on such frames and rewrites these buffers as the history seen from the new
// camera, and this pass adds the frame to that history.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform readonly image2D u_frame;
layout(rgba32f, binding = 1) uniform image2D u_sum;
layout(rgba32f, binding = 2) uniform image2D u_compensation;
layout(rgba32f, binding = 3) uniform image2D u_half_difference;
layout(rgba32f, binding = 4) uniform image2D u_moments;
uniform float u_half_sign;  // +1: this frame goes to half A, -1: to half B
#ifdef LIFT_LATE_SAMPLES
// Samples of paths parked in the previous frame's dispatch and finished in this one
// (lift_gl/passes/carry.py): a texel tagged with this frame's tag is added with the frame; an
// older one is stale (nothing clears the image: a store of zeros here made this pass 2.8x
// slower on an H100).
layout(rgba32f, binding = 5) uniform readonly image2D u_late;
layout(r32ui, binding = 6) uniform readonly uimage2D u_late_tag;
uniform uint u_late_frame_tag;
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_sum)))) return;
    precise vec4 x = imageLoad(u_frame, p);
#ifdef LIFT_LATE_SAMPLES
    if (imageLoad(u_late_tag, p).r == u_late_frame_tag) x += imageLoad(u_late, p);
#endif

    // ---- The whole accumulation: compensated sum ----
    precise vec4 sum = imageLoad(u_sum, p);
    precise vec4 c = imageLoad(u_compensation, p);
    precise vec4 t = sum + x;
    // The low-order bits lost in t: of x when the sum is larger, of the sum otherwise.
    precise vec4 lost_x = (sum - t) + x;
    precise vec4 lost_sum = (x - t) + sum;
    c += mix(lost_sum, lost_x, greaterThanEqual(abs(sum), abs(x)));
    imageStore(u_sum, p, t);
    imageStore(u_compensation, p, c);

    // ---- Half A minus half B: for the error estimate ----
    imageStore(u_half_difference, p, imageLoad(u_half_difference, p) + u_half_sign * x);

    // ---- First and second moments of the frames' luminance: for the variance view ----
    // (sum of L, sum of L^2, frames); plain float sums, like the half difference.
    if (x.a > 0.0) {
        float l = dot(x.rgb / x.a, vec3(0.2126, 0.7152, 0.0722));
        imageStore(u_moments, p, imageLoad(u_moments, p) + vec4(l, l * l, 1.0, 0.0));
    }
}
