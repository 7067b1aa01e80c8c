// lift/finite.glsl: the NaN/Inf test the hosts' guards and the splats use.
#ifndef LIFT_FINITE_GLSL
#define LIFT_FINITE_GLSL
// False when any component's exponent bits are all ones: NaN or infinity (a bit test, robust
// even where a compiler assumes fast math and folds isnan away).
bool lift_is_finite(vec3 v) {
    uvec3 bits = floatBitsToUint(v) & 0x7f800000u;
    return all(notEqual(bits, uvec3(0x7f800000u)));
}
#endif
