// lift/bvh.glsl: the old name of lift/trace.glsl (ray queries: Ray, Hit, trace_closest,
// trace_occluded, trace_shadow_and_next), kept so that plugins that include it still compile.
#include "lift/trace.glsl"
