// lift/prepass.glsl: the storage a plugin's prepass writes and its trace pass reads ([prepass]
// in plugin.toml; lift_gl/passes/prepass.py runs it). The prepass runs once per pixel sample,
// before the trace pass, with that sample's random numbers; each pixel sample owns `entries`
// uvec4s (the manifest's count), which both passes reach by entry number:
//   prepass_store(entry, value)   in the prepass (or the trace pass)
//   prepass_load(entry)           in the trace pass (or the prepass)
// The host sets the current pixel sample (lift_prepass_begin, lift/host_report.glsl: it needs
// the work group's size, declared after this file) before calling the plugin.
//
// Entry-major layout: entry e of every pixel sample is one run of the buffer, the lanes of a
// warp side by side in it, so their stores and loads of one entry coalesce. Where the entries
// of all pixel samples would pass the driver's largest storage block
// (GL_MAX_SHADER_STORAGE_BLOCK_SIZE), the host spreads them over up to four buffers,
// LIFT_PREPASS_BUFFER_ENTRIES entries each.
#ifndef LIFT_PREPASS_GLSL
#define LIFT_PREPASS_GLSL
#ifdef LIFT_PREPASS
uniform uint u_prepass_invocations;  // invocations of one dispatch (the image, in tiles)
uniform uint u_prepass_stride;       // pixel samples each entry's run has room for

layout(std430, binding = LIFT_BINDING_PREPASS0) buffer LiftPrepass0 { uvec4 lift_prepass0[]; };
#if LIFT_PREPASS_BUFFERS > 1
layout(std430, binding = LIFT_BINDING_PREPASS1) buffer LiftPrepass1 { uvec4 lift_prepass1[]; };
#endif
#if LIFT_PREPASS_BUFFERS > 2
layout(std430, binding = LIFT_BINDING_PREPASS2) buffer LiftPrepass2 { uvec4 lift_prepass2[]; };
#endif
#if LIFT_PREPASS_BUFFERS > 3
layout(std430, binding = LIFT_BINDING_PREPASS3) buffer LiftPrepass3 { uvec4 lift_prepass3[]; };
#endif

uint lift_prepass_sample;  // the current pixel sample's number: lift_prepass_begin (lift/host_report.glsl)

void prepass_store(int entry, uvec4 value) {
    uint run = uint(entry) % uint(LIFT_PREPASS_BUFFER_ENTRIES), part = uint(entry) / uint(LIFT_PREPASS_BUFFER_ENTRIES);
    uint i = run * u_prepass_stride + lift_prepass_sample;
#if LIFT_PREPASS_BUFFERS > 1
    if (part == 1u) { lift_prepass1[i] = value; return; }
#endif
#if LIFT_PREPASS_BUFFERS > 2
    if (part == 2u) { lift_prepass2[i] = value; return; }
#endif
#if LIFT_PREPASS_BUFFERS > 3
    if (part == 3u) { lift_prepass3[i] = value; return; }
#endif
    lift_prepass0[i] = value;
}

uvec4 prepass_load(int entry) {
    uint run = uint(entry) % uint(LIFT_PREPASS_BUFFER_ENTRIES), part = uint(entry) / uint(LIFT_PREPASS_BUFFER_ENTRIES);
    uint i = run * u_prepass_stride + lift_prepass_sample;
#if LIFT_PREPASS_BUFFERS > 1
    if (part == 1u) return lift_prepass1[i];
#endif
#if LIFT_PREPASS_BUFFERS > 2
    if (part == 2u) return lift_prepass2[i];
#endif
#if LIFT_PREPASS_BUFFERS > 3
    if (part == 3u) return lift_prepass3[i];
#endif
    return lift_prepass0[i];
}
#endif
#endif
