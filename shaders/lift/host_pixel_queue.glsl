// lift/host_pixel_queue.glsl: the pixel queue, an alternative to lift/host_main.comp's loop for
// a plugin that writes its paths as steps (LIFT_PATH_STEPS, pt) from the G-buffer: path
// regeneration. A lane takes its next pixel from this queue as soon as its pixel's paths have
// ended, instead of idling until the longest path of its warp ends. Pixels are numbered tile by
// tile (one work group's shape), so a warp's first 32 are one tile. The host zeroes the queue
// before each dispatch (lift_gl/passes/trace.py). Each pixel's samples are main()'s, in its
// order: the same sums.
//
// Where (lift_gl/options.py, the option pixel_queue): on GPUs, where pt's trace ran 1.04-1.57x
// faster with it (H100, docs/gpu.md); not on CPU rasterizers, where it cost 0.61x
// (docs/cpu-speed.md). With carried paths (lift/host_carry.glsl, the option carry_paths),
// paths still under way once the queue has run out go on in the next frame's dispatch.
#ifndef LIFT_HOST_PIXEL_QUEUE_GLSL
#define LIFT_HOST_PIXEL_QUEUE_GLSL

layout(std430, binding = 13) coherent buffer LiftPixelQueue { uint lift_queue_next; };

#ifdef LIFT_CARRY_PATHS
#include "lift/host_carry.glsl"
#else
// A finished pixel's samples (`late`: never, without carried paths).
void lift_store_pixel(ivec2 pixel, vec3 sum, float valid, bool late) {
    imageStore(u_frame_out, pixel, vec4(sum, valid));
}
#endif

void lift_trace_pixel_queue() {
    const uint tile_w = gl_WorkGroupSize.x, tile_h = gl_WorkGroupSize.y, group = tile_w * tile_h;
    uvec2 tiles = lift_tile_groups(ivec2(u_resolution), uvec2(tile_w, tile_h));   // (moved, interleaved: coherent sampling)
    uint items = tiles.x * tiles.y * group;
#ifdef HAS_MOTION
    g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
    ivec2 pixel = ivec2(0);
    Ray primary_ray;
    Hit primary_hit;
    Rng rng;
    PathState path;
    uint s = 0u;
    vec3 sum = vec3(0.0);
    float valid = 0.0;
    bool busy = false;  // a pixel taken whose samples are not all done
    bool late = false;  // that pixel's sample was parked in the previous frame: its samples go to u_late_out
    while (true) {
#ifdef LIFT_CARRY_PATHS
        // ---- carried paths: resume one the previous frame parked ----
        // (the parked count read at every take: reading it once a lane, with a flag once the
        // list was taken, ran the trace 1.03-1.3x slower on an H100)
        if (!busy) {
            uint side = 1u - u_carry_side;
            uint parked = min(lift_carry_count[side], lift_carry_capacity());
            if (lift_carry_next[side] < parked) {
                uint k = atomicAdd(lift_carry_next[side], 1u);
                if (k < parked) {
                    LiftParkedPath c = lift_carried[side * lift_carry_capacity() + k];
                    path = c.path;
                    rng = c.rng;
                    pixel = c.pixel;
                    s = c.s;
                    primary_ray = c.primary_ray;
                    primary_hit = c.primary_hit;
                    sum = vec3(0.0);
                    valid = 0.0;
                    late = true;
                    busy = true;
                }
            }
        }
#endif
        // ---- take the next pixel ----
        if (!busy) {
            late = false;
            uint item = atomicAdd(lift_queue_next, 1u);
            if (item >= items) break;
            uint tile = item / group, lane = item % group;
            pixel = lift_tile_pixel(uvec2(tile % tiles.x, tile / tiles.x), uvec2(lane % tile_w, lane / tile_w),
                                    uvec2(tile_w, tile_h));
            if (!pixel_in_image(pixel)) continue;
            s = 0u;
            sum = vec3(0.0);
            valid = 0.0;
            if (u_samples == 0u) {
                imageStore(u_frame_out, pixel, vec4(0.0));
                continue;
            }
            // main()'s samples of this pixel, in its order: the same sums
            primary_ray = camera_ray(vec2(pixel) + u_jitter);
            primary_hit = gbuffer_hit(pixel, primary_ray);
            rng = lift_sample_rng(pixel, 0u);
            path = path_start(primary_ray, primary_hit);
            busy = true;
        }
        // ---- one path vertex ----
        if (path_step(path, rng)) {
#ifdef LIFT_CARRY_PATHS
            // ---- carried paths: park this one once the queue has run out ----
            if (u_park != 0u && !late && LIFT_QUEUE_RAN_OUT) {
                uint k = atomicAdd(lift_carry_count[u_carry_side], 1u);
                if (k < lift_carry_capacity()) {
                    lift_carried[u_carry_side * lift_carry_capacity() + k] =
                        LiftParkedPath(path, rng, pixel, s, primary_ray, primary_hit);
                    imageStore(u_frame_out, pixel, vec4(sum, valid));  // the samples it finished
                    busy = false;
                    break;
                }
            }
#endif
            continue;
        }
        // ---- the path ended: its sample, then the pixel's next or the pixel done ----
        lift_add_sample(path_radiance(path), sum, valid);
        ++s;
        if (s < u_samples) {
            rng = lift_sample_rng(pixel, s);
            path = path_start(primary_ray, primary_hit);
            continue;
        }
        lift_store_pixel(pixel, sum, valid, late);
        busy = false;
    }
#ifdef LIFT_LOOP_LIMITED
    // Still busy: the driver's loop limit ended the loop (llvmpipe: 65535 iterations an
    // invocation; lift_report_invocation counts it). The samples done so far, as main() keeps
    // them. (Every pixel is taken: a dispatch has a lane for each, and a lane takes its first
    // pixel before its loop can run out.) Only where a driver cuts loops: on an H100 this one
    // store made the cornell-box's trace 1.7x slower.
    if (busy) lift_store_pixel(pixel, sum, valid, late);
#endif
}
#endif
