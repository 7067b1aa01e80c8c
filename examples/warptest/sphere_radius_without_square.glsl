// WRONG on purpose: the radius of the circle at height z is sqrt(1 - z^2), here sqrt(1 - z),
// so the "directions" are not of unit length. warptest counts them as outside the domain.
//   lift-gl warptest examples/warptest/sphere_radius_without_square.glsl --sampler uniform_sphere --domain sphere

const float PI = 3.14159265358979;

vec3 uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z));  // the bug: 1 - z * z
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

float uniform_sphere_pdf(vec3 w) { return 1.0 / (4.0 * PI); }
