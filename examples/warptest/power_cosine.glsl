// Directions about +z with density proportional to cos(theta)^n (a Phong lobe): the CDF of
// cos(theta) is cos^(n+1), so cos(theta) = u^(1 / (n + 1)); normalised, the solid-angle
// density is (n + 1) / (2 pi) cos(theta)^n.
//   lift-gl warptest examples/warptest/power_cosine.glsl --sampler power_cosine --domain hemisphere

const float PI = 3.14159265358979;
const float EXPONENT = 8.0;

vec3 power_cosine(vec2 u) {
    float cos_theta = pow(u.x, 1.0 / (EXPONENT + 1.0));
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

float power_cosine_pdf(vec3 w) { return (EXPONENT + 1.0) / (2.0 * PI) * pow(max(w.z, 0.0), EXPONENT); }
