// WRONG on purpose: a sampler that draws cos(theta)^1.1 (cos(theta) = u^(1 / 2.1)) where its
// pdf claims the cosine lobe, cos(theta) / pi. The two differ by at most a few percent over
// most of the hemisphere; warptest rejects the pair at the default sample count.
//   lift-gl warptest examples/warptest/cosine_power_1_1.glsl --sampler cosine_hemisphere --domain hemisphere

const float PI = 3.14159265358979;

vec3 cosine_hemisphere(vec2 u) {
    float cos_theta = pow(u.x, 1.0 / 2.1);  // the bug: sqrt(u.x), i.e. pow(u.x, 1.0 / 2.0)
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

float cosine_hemisphere_pdf(vec3 w) { return max(w.z, 0.0) / PI; }
