// lift/host_carry.glsl: carried paths, an addition to the pixel queue
// (lift/host_pixel_queue.glsl, with LIFT_CARRY_PATHS; the host side: lift_gl/passes/carry.py).
// Once the queue has run out, a lane whose path is still under way parks it in one half of this
// buffer and ends, instead of the frame waiting while the longest paths run alone on a few
// lanes. The next frame's lanes resume the parked paths before they take new pixels, run each
// to its end (a resumed path is never parked again) and write what they finish to u_late_out,
// with this frame's tag in u_late_tag_out; the accumulation adds a late texel whose tag is the
// frame's (an older one is stale: nothing clears the image) to the frame: per pixel, samples
// and their count (alpha), so a sample that lands a frame late is counted once, and the mean
// stays exact.
//
// Where (lift_gl/options.py, the option carry_paths): on GPUs for deep trees, where the
// frame's tail of lone long paths is long (docs/gpu.md); the code compiled in costs the others
// more than it saves.
#ifndef LIFT_HOST_CARRY_GLSL
#define LIFT_HOST_CARRY_GLSL

struct LiftParkedPath { PathState path; Rng rng; ivec2 pixel; uint s; Ray primary_ray; Hit primary_hit; };
layout(std430, binding = 15) coherent buffer LiftCarry {
    uint lift_carry_count[2];  // paths parked in each half (may pass the capacity: the extra ones ran on)
    uint lift_carry_next[2];   // the next one to resume
    LiftParkedPath lift_carried[];
};
layout(rgba32f, binding = 1) uniform writeonly image2D u_late_out;
layout(r32ui, binding = 2) uniform writeonly uimage2D u_late_tag_out;
uniform uint u_late_tag;        // this frame's tag (the host's frame count since the carry began, from 1)
uniform uint u_carry_side;      // this frame parks into half u_carry_side and resumes the other's
uniform uint u_park;            // 0: every path runs to its end (a render's last frame)

// Paths a half holds: the host sizes the buffer without knowing PathState's layout.
uint lift_carry_capacity() { return uint(lift_carried.length()) / 2u; }

// A resumed path's pixel: its samples and this frame's tag.
void lift_store_late(ivec2 pixel, vec3 sum, float valid) {
    imageStore(u_late_out, pixel, vec4(sum, valid));
    imageStore(u_late_tag_out, pixel, uvec4(u_late_tag));
}

// A finished pixel's samples: to the frame, or for a resumed path (`late`) to the late image.
void lift_store_pixel(ivec2 pixel, vec3 sum, float valid, bool late) {
    if (late) lift_store_late(pixel, sum, valid);
    else imageStore(u_frame_out, pixel, vec4(sum, valid));
}

#ifdef LIFT_CARRY_PARK_ALWAYS
#define LIFT_QUEUE_RAN_OUT true   // carry_paths=always: every new path parks after its first vertex (tests)
#else
#define LIFT_QUEUE_RAN_OUT (lift_queue_next >= items)
#endif
#endif
