// Uniform directions on the unit sphere: z = cos(theta) uniform in [-1, 1] (Archimedes: equal
// heights of a sphere have equal areas), phi uniform in [0, 2 pi).
//   lift-gl warptest examples/warptest/uniform_sphere.glsl --sampler uniform_sphere --domain sphere

const float PI = 3.14159265358979;

vec3 uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Solid-angle density: 1 / (4 pi) everywhere.
float uniform_sphere_pdf(vec3 w) { return 1.0 / (4.0 * PI); }
