// lift/primary_hit.glsl: for the trace hosts only (lift/host_main.comp, lift/host_reduced.comp),
// included after the plugin and after `uniform usampler2D u_visibility`.
#ifndef LIFT_PRIMARY_HIT_GLSL
#define LIFT_PRIMARY_HIT_GLSL

// The primary hit the raster found at `pixel`, rebuilt exactly along the camera ray; where ray
// and raster disagree (a sample exactly on an edge) the ray is traced instead.
Hit gbuffer_hit(ivec2 pixel, Ray ray) {
    uvec4 v = texelFetch(u_visibility, pixel, 0);
    Hit hit;
    hit.prim = NO_HIT;
    hit.t = ray.tmax;
    hit.bary = vec2(0.0);
    if (v.x == 0u) return hit;
    uint prim = v.x - 1u;
    float t = ray.tmax;
    vec2 bary;
#ifdef HAS_INSTANCES
    hit.instance = visibility_instance(v);
    if (hit.instance != NO_INSTANCE) {  // the instance's triangle, in its object space
        if (prim < u_num_triangles && intersect_triangle(instance_ray(hit.instance, ray), prim, t, bary)) {
            hit.prim = prim; hit.t = t; hit.bary = bary;
            return hit;
        }
        trace_closest(ray, hit);
        return hit;
    }
#endif
    if (prim < u_num_triangles && intersect_triangle(ray, prim, t, bary)) {
        hit.prim = prim; hit.t = t; hit.bary = bary;
        return hit;
    }
#ifdef HAS_SPHERES
    if (prim >= u_num_triangles && intersect_sphere(ray, prim - u_num_triangles, t)) {
        hit.prim = prim; hit.t = t;
        return hit;
    }
#endif
    trace_closest(ray, hit);
    return hit;
}

#endif
