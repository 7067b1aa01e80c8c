// WRONG on purpose: the uniform sphere with pi written as 3 in its pdf, which is then 4.7%
// too large. The sampler is right; the pdf integrates to pi / 3 = 1.047 over the sphere.
//   lift-gl warptest examples/warptest/sphere_pi_is_3.glsl --sampler uniform_sphere --domain sphere

vec3 uniform_sphere(vec2 u) {
    const float PI = 3.14159265358979;
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

float uniform_sphere_pdf(vec3 w) { return 1.0 / (4.0 * 3.0); }  // the bug: 3 for pi
