// lift/light_tree.glsl: the emissive primitive next event estimation picks at a point, by a
// walk down the light tree (lift_gl/scene/light_tree.py: build, layout, and the importance
// after Conty Estevez and Kulla 2018). light_tree_pdf retraces a light's walk: the same
// products, so MIS gets the sampler's probability exactly. Compiled with LIFT_LIGHT_TREE.
#ifndef LIFT_LIGHT_TREE_GLSL
#define LIFT_LIGHT_TREE_GLSL

#define LIFT_LIGHT_LEAF 0x80000000u
#define LIFT_LIGHT_NODE_ROWS 3u

// Node `node`'s first row in `lights`.
uint light_node_row(uint node) { return u_num_lights + LIFT_LIGHT_NODE_ROWS * node; }

// Second child, or LIFT_LIGHT_LEAF | light index.
uint light_node_link(uint node) { return floatBitsToUint(lights[light_node_row(node) + 1u].w); }

// intensity / d^2 x cos(theta_w - theta_o - theta_b), without inverse trigonometry.
float light_node_importance(vec3 p, uint node) {
    uint row = light_node_row(node);
    vec4 lo_intensity = lights[row], hi = lights[row + 1u], cone = lights[row + 2u];
    vec3 centre = 0.5 * (lo_intensity.xyz + hi.xyz), half_diagonal = 0.5 * (hi.xyz - lo_intensity.xyz);
    float radius2 = dot(half_diagonal, half_diagonal);
    vec3 d = p - centre;
    float dist2 = dot(d, d);
    float falloff = lo_intensity.w / max(max(dist2, radius2), 1e-30);
    if (!(dist2 > radius2)) return falloff;  // inside the bounding sphere: every direction
    float cos_w = clamp(dot(cone.xyz, d) * inversesqrt(dist2), -1.0, 1.0);
    float cos_o = cone.w;
    if (cos_w >= cos_o) return falloff;      // p inside the cone
    float sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0)), sin_o = sqrt(max(1.0 - cos_o * cos_o, 0.0));
    float cos_x = cos_w * cos_o + sin_w * sin_o, sin_x = sin_w * cos_o - cos_w * sin_o;
    float sin_b2 = radius2 / dist2;
    float cos_b = sqrt(max(1.0 - sin_b2, 0.0));
    if (cos_x >= cos_b) return falloff;      // within the sphere's half angle of the cone
    float cos_t = cos_x * cos_b + sin_x * sqrt(sin_b2);
    return cos_t > 0.0 ? falloff * cos_t : 0.0;
}

// P(first child) at p; negative where neither child lights p.
float light_first_child_probability(vec3 p, uint node) {
    float first = light_node_importance(p, node + 1u), second = light_node_importance(p, light_node_link(node));
    float total = first + second;
    return total > 0.0 && total < 1e38 ? first / total : -1.0;
}

// A light (index into `lights`) for p and its probability; false where none faces p.
bool light_tree_pick(vec3 p, float u, out uint index, out float pdf) {
    uint node = 0u;
    pdf = 1.0;
    index = 0u;
    for (uint depth = 0u; depth < 32u; ++depth) {
        uint link = light_node_link(node);
        if ((link & LIFT_LIGHT_LEAF) != 0u) {
            index = link & ~LIFT_LIGHT_LEAF;
            return pdf > 0.0;
        }
        float first = light_first_child_probability(p, node);
        if (first < 0.0) return false;
        // u is reused, rescaled to [0, 1) within the chosen child's share.
        if (u < first) {
            u = min(u / first, 0.99999994);
            pdf *= first;
            node = node + 1u;
        } else {
            u = min((u - first) / (1.0 - first), 0.99999994);
            pdf *= 1.0 - first;
            node = link;
        }
    }
    return false;
}

// light_tree_pick's probability of primitive `prim` at p (0: not a light).
float light_tree_pdf(vec3 p, uint prim) {
    // Binary search of the table after the nodes (sorted by primitive).
    uint table = light_node_row(2u * u_num_lights - 1u);
    uint lo = 0u, hi = u_num_lights;
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (floatBitsToUint(lights[table + mid].x) < prim) lo = mid + 1u; else hi = mid;
    }
    if (lo >= u_num_lights) return 0.0;
    vec4 entry = lights[table + lo];
    if (floatBitsToUint(entry.x) != prim) return 0.0;
    uint trail = floatBitsToUint(entry.y), depth = floatBitsToUint(entry.z);
    uint node = 0u;
    float pdf = 1.0;
    for (uint d = 0u; d < depth; ++d) {
        float first = light_first_child_probability(p, node);
        if (first < 0.0) return 0.0;
        if ((trail & (1u << d)) == 0u) {
            pdf *= first;
            node = node + 1u;
        } else {
            pdf *= 1.0 - first;
            node = light_node_link(node);
        }
    }
    return pdf;
}

#endif
