// lift/host_frame.glsl: what the host tells a trace program about the frame it runs, declared
// before the plugin (lift/host.glsl includes it), which may read it. The host's sample loop
// (lift/host_main.comp) draws each sample's random numbers from these.
#ifndef LIFT_HOST_FRAME_GLSL
#define LIFT_HOST_FRAME_GLSL
#include "lift/rng.glsl"

uniform uint u_frame;        // frames since the accumulation began
uniform uint u_seed;         // the render's seed
uniform uint u_samples;      // samples per pixel this frame
uniform uint u_sample_base;  // samples per pixel of this frame's stream accumulated before it
uniform uint u_stream;       // which half of the frames (error estimate) this one belongs to
uniform vec2 u_jitter;       // this frame's subpixel offset (G-buffer primary)

#ifdef LIFT_COHERENT_SAMPLING
// Coherent sampling gives `rng` to the pixels of a tile alike; this holds the pixel's own
// numbers for the sample radiance() is called for (set by the host before each call), for a
// plugin that wants some draws unshared: bdpt's light subpaths. Not for path_step(), which
// may resume another pixel's path.
Rng lift_own_rng;
#endif
#endif
