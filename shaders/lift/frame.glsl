// lift/frame.glsl: the local shading frame. z is the shading normal; a BSDF works on
// directions expressed in this frame (wo and wi both point away from the surface).
#ifndef LIFT_FRAME_GLSL
#define LIFT_FRAME_GLSL

struct Frame { vec3 t; vec3 b; vec3 n; };  // tangent, bitangent, normal: orthonormal, right-handed

// Branchless orthonormal basis around a unit normal (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited"): continuous everywhere except across n.z = 0 sign changes,
// and no special case near the poles.
Frame frame_from_normal(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    f.b = vec3(b, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

// World space -> shading frame.
vec3 to_local(Frame f, vec3 v) { return vec3(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }

// Shading frame -> world space.
vec3 to_world(Frame f, vec3 v) { return f.t * v.x + f.b * v.y + f.n * v.z; }

#endif
