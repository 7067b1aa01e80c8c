// Cosine-weighted directions about +z (Malley's method): uniform points on the unit disk,
// lifted up to the hemisphere. The solid-angle density is cos(theta) / pi.
//   lift-gl warptest examples/warptest/cosine_hemisphere.glsl --sampler cosine_hemisphere --domain hemisphere

const float PI = 3.14159265358979;

vec3 cosine_hemisphere(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    vec2 d = r * vec2(cos(phi), sin(phi));
    return vec3(d, sqrt(max(0.0, 1.0 - dot(d, d))));
}

float cosine_hemisphere_pdf(vec3 w) { return max(w.z, 0.0) / PI; }
