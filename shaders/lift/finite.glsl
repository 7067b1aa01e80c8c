// lift/finite.glsl: the NaN/Inf test of the hosts' guard (lift/sample_guard.glsl) and the splats.
#ifndef LIFT_FINITE_GLSL
#define LIFT_FINITE_GLSL
// False when any component is NaN or infinite. Two tests, because two compilers each defeat
// one of them:
// - the exponent bits (all ones: NaN or Inf) survive a compiler that assumes fast math and
//   folds isnan away (NVIDIA);
// - isnan catches what llvmpipe makes of a division by a constant zero (`L / 0.0`): gallivm
//   emits an LLVM undef there instead of a division, and an undef may read as a different
//   value at each use: 0.0 where the sum adds it, 0 in the bit test, but always "unordered"
//   in isnan's comparison (Mesa keeps isnan exact), so the sample is dropped and counted
//   instead of silently averaged in as black.
bool lift_is_finite(vec3 v) {
    uvec3 bits = floatBitsToUint(v) & 0x7f800000u;
    return all(notEqual(bits, uvec3(0x7f800000u))) && !any(isnan(v));
}
#endif
