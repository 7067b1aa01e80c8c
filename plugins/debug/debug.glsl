// debug: one property of the first hit per pixel, no light transport.

vec3 hash_colour(uint v) {
    uint h = pcg_hash(v + 1u);
    return vec3(h & 255u, (h >> 8u) & 255u, (h >> 16u) & 255u) / 255.0;
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    if (hit.prim == NO_HIT) return vec3(0.0);
    Surface s = surface_at(ray, hit);
    if (mode == 0) return s.ns * 0.5 + 0.5;
    if (mode == 1) return bsdf_albedo(material_at(s.material, s.uv));  // textures applied
    if (mode == 2) return vec3(hit.t / max(depth_scale, 1e-20));
    if (mode == 3) return hash_colour(s.material);
    return vec3(1.0 - hit.bary.x - hit.bary.y, hit.bary);
}
