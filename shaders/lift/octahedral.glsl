// octahedral.glsl: a unit vector in one 32-bit word (Meyer et al. 2010, "On floating-point
// normal vectors"; the survey of Cigolle et al., JCGT 2014). The vector is projected onto
// the octahedron |x| + |y| + |z| = 1, the lower half folded over the upper, and the two
// coordinates stored as 16-bit signed normalised integers: about 5e-5 rad of error at most.
// For vectors kept in private memory, where every word counts (bdpt's stored subpath).
#ifndef LIFT_OCTAHEDRAL_GLSL
#define LIFT_OCTAHEDRAL_GLSL

// The signs of v's components, with 0 counted as positive.
vec2 octahedral_sign(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

// A unit vector packed into one word. A zero vector packs to +z (callers that store one never
// read it back as a direction).
uint pack_unit_vector(vec3 n) {
    float l1 = abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = l1 > 0.0 ? n.xy / l1 : vec2(0.0);
    if (n.z < 0.0) e = (1.0 - abs(e.yx)) * octahedral_sign(e);
    return packSnorm2x16(e);
}

// The unit vector pack_unit_vector stored (within about 5e-5 rad).
vec3 unpack_unit_vector(uint word) {
    vec2 e = unpackSnorm2x16(word);
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float fold = max(-n.z, 0.0);
    n.xy -= fold * octahedral_sign(n.xy);
    return normalize(n);
}

#endif
