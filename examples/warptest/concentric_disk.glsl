// Uniform points on the unit disk by Shirley and Chiu's concentric map: each square ring of
// [-1,1]^2 goes to a circular ring of the same relative area, so the density is 1/pi.
//   lift-gl warptest examples/warptest/concentric_disk.glsl --sampler concentric_disk --domain disk

const float PI = 3.14159265358979;

vec2 concentric_disk(vec2 u) {
    vec2 p = 2.0 * u - 1.0;
    if (p.x == 0.0 && p.y == 0.0) return vec2(0.0);
    float r, phi;
    if (abs(p.x) > abs(p.y)) {
        r = p.x;
        phi = (PI / 4.0) * (p.y / p.x);
    } else {
        r = p.y;
        phi = PI / 2.0 - (PI / 4.0) * (p.x / p.y);
    }
    return r * vec2(cos(phi), sin(phi));
}

// Area density on the unit disk (warptest takes it as 0 outside).
float concentric_disk_pdf(vec2 p) { return 1.0 / PI; }
