// Uniform points in the unit square: the identity warp, density 1.
//   lift-gl warptest examples/warptest/uniform_square.glsl --sampler uniform_square --domain square

vec2 uniform_square(vec2 u) { return u; }

// Area density on [0,1]^2.
float uniform_square_pdf(vec2 p) { return 1.0; }
