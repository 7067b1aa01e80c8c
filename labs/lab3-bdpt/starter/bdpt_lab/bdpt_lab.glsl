// bdpt_lab: lab 3's bidirectional path tracer (Veach 1997, ch. 10; the structure of
// pbrt-v3, ch. 16). This file is given; your steps are in bdpt_strategies.glsl and
// bdpt_mis.glsl (handout.md).
//
// Each sample traces a light subpath y0 y1 ... (y0 on an emitter picked by power, or a
// direction of the environment or of a distant light, whose ray starts on a disk across the
// scene: lift/emission.glsl) and a camera subpath z0 z1 ... (z0 the pinhole, z1 the G-buffer's
// hit), and makes a full path of every pair of prefixes: s light vertices and t camera vertices.
//   s = 0        the camera subpath hit a light by itself                 (given)
//   s = 1        a fresh light sample joined to z_{t-1} (as in pt)        (given)
//   s, t >= 2    y_{s-1} joined to z_{t-1} with a shadow ray              (step 1)
//   t = 1        y_{s-1} joined to the pinhole: light tracing, splatted   (step 2)
// Every (s, t) is an unbiased estimate of the paths it can make; multiple importance sampling
// (bdpt_mis.glsl, step 3) weights them so that together they count each path once. Delta
// vertices (mirrors, smooth glass) are never joined; the strategies that would need it get
// weight 0. The light subpath is stored; the camera subpath is joined to it as it is traced,
// one camera vertex at a time, so that it needs no array (bdpt_subpaths.glsl).
// Parameters (plugin.toml): max_depth, rr_depth, rr_min_survival, mis_power, only_s, only_depth.
#include "lift/emission.glsl"
#include "lift/camera_importance.glsl"
#include "bdpt_vertex.glsl"
#include "bdpt_mis.glsl"
#include "bdpt_strategies.glsl"
#include "bdpt_subpaths.glsl"

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    int depth_limit = bdpt_depth_limit();
    int light_vertices = light_subpath(depth_limit, rng);

    // ---- t = 1: every light vertex seen by the pinhole, splatted ----
    PathVertex y_prev = light_vertex(0);  // each join reads one stored vertex: y_{s-2} is kept from the last
    for (int s = 2; s <= light_vertices && s - 1 <= depth_limit; ++s) {
        PathVertex y = light_vertex(s - 1);
        if (strategy_kept(s, 1)) strategy_light_tracing(y, y_prev);
        y_prev = y;
    }

    // ---- t >= 2: each camera vertex joined to every light prefix as the camera subpath is traced ----
    return camera_subpath(ray, hit, depth_limit, light_vertices, rng);
}
