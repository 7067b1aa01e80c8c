// Tonemap: the accumulated mean radiance to display sRGB, mirroring lift_gl/tonemap.py step
// for step (sanitise, exposure, operator, sRGB OETF).
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 1) uniform readonly image2D u_sum;
layout(rgba32f, binding = 2) uniform readonly image2D u_compensation;
layout(rgba8, binding = 3) uniform writeonly image2D u_display;
uniform float u_exposure;  // stops
uniform int u_operator;    // 0 aces, 1 reinhard, 2 clamp
uniform float u_gamma;     // 0: the sRGB curve; g > 0: x^(1/g) (a display gamma)

const float MAX_INPUT = 1.0e4;

vec3 aces_narkowicz(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 x) {
    vec3 low = 12.92 * x;
    vec3 high = 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055;
    return mix(high, low, lessThanEqual(x, vec3(0.0031308)));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_display)))) return;
    vec4 total = imageLoad(u_sum, p) + imageLoad(u_compensation, p);
    vec3 x = total.a > 0.0 ? total.rgb / total.a : vec3(0.0);
    // NaN fails every comparison, so it becomes 0 here like the negatives.
    x = mix(vec3(0.0), min(x, vec3(MAX_INPUT)), greaterThan(x, vec3(0.0)));
    x *= exp2(u_exposure);
    vec3 mapped = u_operator == 0 ? aces_narkowicz(x) : (u_operator == 1 ? x / (1.0 + x) : clamp(x, 0.0, 1.0));
    mapped = clamp(mapped, 0.0, 1.0);
    vec3 encoded = u_gamma > 0.0 ? pow(mapped, vec3(1.0 / u_gamma)) : srgb_encode(mapped);
    imageStore(u_display, p, vec4(encoded, 1.0));
}
