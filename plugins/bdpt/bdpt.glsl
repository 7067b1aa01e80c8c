// bdpt: bidirectional path tracing (Veach 1997, ch. 10; the structure of pbrt-v3, ch. 16).
//
// Each sample traces a light subpath y0 y1 ... (y0 on an emitter picked by power, or a
// direction of the environment or of a distant light, whose ray starts on a disk across the
// scene: lift/emission.glsl) and a camera subpath z0 z1 ... (z0 the pinhole, z1 the G-buffer's
// hit), and makes a full path of every pair of prefixes: s light vertices and t camera vertices.
//   s = 0        the camera subpath hit a light by itself
//   s = 1        a fresh light sample joined to z_{t-1} (next event estimation, as in pt)
//   t = 1        y_{s-1} joined to the pinhole: light tracing, splatted to the pixel it lands on
//   otherwise    y_{s-1} joined to z_{t-1} with a shadow ray
// Every (s, t) is an unbiased estimate of the paths it can make; multiple importance sampling
// (bdpt_mis.glsl) weights them so that together they count each path once. Delta vertices
// (mirrors, smooth glass) are never joined; the strategies that would need it get weight 0.
// A distant light is a delta in direction: no camera subpath can hit it (s = 0 gets weight 0),
// but it can be sampled (s = 1) and can start light subpaths (s >= 2, t = 1).
// Two passes (Davidovic et al. 2014): the prepass (bdpt_light_pass, [prepass] in plugin.toml)
// traces each pixel sample's light subpath, stores it (bdpt_vertex.glsl) and splats its t = 1
// joins; the trace pass (radiance) traces the camera subpath and joins each of its vertices to
// the stored light subpath as it goes, so that it needs no array (bdpt_subpaths.glsl).
// Parameters (plugin.toml): max_depth, rr_depth, rr_min_survival, mis_power, only_s, only_depth.
#include "lift/emission.glsl"
#include "lift/camera_importance.glsl"
#include "bdpt_vertex.glsl"
#include "bdpt_mis.glsl"
#include "bdpt_strategies.glsl"
#include "bdpt_subpaths.glsl"

// ==== the prepass: the light subpath, stored, and light tracing ====
void bdpt_light_pass(ivec2 pixel, inout Rng rng) {
    int depth_limit = bdpt_depth_limit();
#ifdef LIFT_COHERENT_SAMPLING
    // Coherent sampling shares `rng` by tile, so the tile's camera subpaths travel together; its
    // light subpaths stay the pixel's own: one shared light path, splatted once by every pixel
    // of the tile, made light tracing's noise the tile's size times larger (docs/gpu.md).
    int light_vertices = light_subpath(depth_limit, lift_own_rng);
#else
    int light_vertices = light_subpath(depth_limit, rng);
#endif
    store_light_subpath_end(light_vertices, rng);

    // ---- t = 1: every light vertex seen by the pinhole, splatted ----
    PathVertex y_prev = light_vertex(0);  // each join reads one stored vertex: y_{s-2} is kept from the last
    for (int s = 2; s <= light_vertices && s - 1 <= depth_limit; ++s) {
        PathVertex y = light_vertex(s - 1);
        if (strategy_kept(s, 1)) strategy_light_tracing(y, y_prev);
        y_prev = y;
    }
}

// ==== the trace pass: the camera subpath, joined to the stored light subpath ====
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    int light_vertices = stored_light_vertices();
#ifndef LIFT_COHERENT_SAMPLING
    rng = stored_light_rng();  // the sample's numbers go on where the light subpath left them
#endif
    // ---- t >= 2: each camera vertex joined to every light prefix as the camera subpath is traced ----
    return camera_subpath(ray, hit, bdpt_depth_limit(), light_vertices, rng);
}
