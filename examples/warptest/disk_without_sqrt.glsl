// WRONG on purpose: polar coordinates with r = u.x. The area of a ring grows with r, so a
// uniform r crowds the points towards the centre (density 1 / (2 pi r)); the right radius is
// sqrt(u.x). warptest rejects it: the histogram has too many points in the middle.
//   lift-gl warptest examples/warptest/disk_without_sqrt.glsl --sampler polar_disk --domain disk

const float PI = 3.14159265358979;

vec2 polar_disk(vec2 u) {
    float r = u.x;  // the bug: sqrt(u.x)
    float phi = 2.0 * PI * u.y;
    return r * vec2(cos(phi), sin(phi));
}

float polar_disk_pdf(vec2 p) { return 1.0 / PI; }
