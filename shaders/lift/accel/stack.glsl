// lift/accel/stack.glsl: the BVH traversals' stack: how deep, and where it lives (shared
// memory or a local array); the count of rays traced (LIFT_COUNT_RAYS). Internal to
// lift/trace.glsl, which plugins call.
#ifndef LIFT_ACCEL_STACK_GLSL
#define LIFT_ACCEL_STACK_GLSL

// The build limits the tree to 48 levels, so a stack of 48 never overflows: it holds at most
// one postponed sibling per level of the current path. The 4-wide tree (LIFT_BVH_WIDTH 4,
// lift_gl/accel/wide.py) pushes up to 3 children a level; its collapse keeps the deepest
// stack a tree can need within 64 (wide.STACK), or the scene keeps the binary tree.
#if defined(LIFT_BVH_WIDTH) && LIFT_BVH_WIDTH == 4
// The host declares the stack its tree needs (LIFT_BVH_STACK_SIZE, wide.stack_size: at most 64):
// on GPUs it is shared memory, and a smaller one lets more warps run on an SM.
#ifdef LIFT_BVH_STACK_SIZE
#if LIFT_BVH_STACK_SIZE > 64
#error "LIFT_BVH_STACK_SIZE above the 4-wide collapse's bound (wide.STACK)"
#endif
#define LIFT_BVH_STACK LIFT_BVH_STACK_SIZE
#else
#define LIFT_BVH_STACK 64
#endif
#else
#define LIFT_BVH_STACK 48
#endif

// Where the traversal stack lives. A per-invocation array indexed at run time is local
// memory on NVIDIA GPUs (off-chip, one vec4 slot per element in its assembly): on an H100
// that made pt's trace pass 1.7-2.2x slower than the same stack in shared memory
// (docs/gpu.md). A compute host that knows its work-group size defines
// LIFT_BVH_SHARED_STACK to it (lift_gl/passes/trace.py, on GPUs), and each invocation then
// keeps its stack in one column of a shared array (consecutive invocations in consecutive
// words: no bank conflicts). No two traversals of one invocation overlap, so they share it.
// Otherwise (CPU rasterizers, fragment shaders, other hosts) the stack is a local array.
//
// Shared memory is also what bounds how many warps an SM runs at once (a 64-entry stack in
// 8x4 groups: 8 KiB a group), hence a stack only as deep as the scene's tree needs
// (LIFT_BVH_STACK_SIZE above). LIFT_BVH_SHARED_DEPTH n (a host's option) keeps only the top n
// entries of each stack in shared memory and spills the deeper ones to a local array: on the
// H100 that made pt's trace slower (its rays often go deeper than 16 entries and local memory
// is slow) though the light ray-casting kernels gained (docs/gpu.md "A stack as deep as the
// tree needs"), so by default the whole stack is shared. Entries are written with
// LIFT_BVH_STACK_SET(i, v) and read with LIFT_BVH_STACK_GET(i) (i without side effects: it
// may be evaluated twice).
#ifdef LIFT_BVH_SHARED_STACK
#ifndef LIFT_BVH_SHARED_DEPTH
#define LIFT_BVH_SHARED_DEPTH LIFT_BVH_STACK
#endif
#if LIFT_BVH_SHARED_DEPTH >= LIFT_BVH_STACK
shared uint lift_bvh_stack[LIFT_BVH_STACK * LIFT_BVH_SHARED_STACK];
#define LIFT_BVH_STACK_DECLARE
#define LIFT_BVH_SHARED_AT(i) lift_bvh_stack[uint(i) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex]
#define LIFT_BVH_STACK_SET(i, v) LIFT_BVH_SHARED_AT(i) = (v)
#define LIFT_BVH_STACK_GET(i) LIFT_BVH_SHARED_AT(i)
#else
shared uint lift_bvh_stack[LIFT_BVH_SHARED_DEPTH * LIFT_BVH_SHARED_STACK];
#define LIFT_BVH_STACK_DECLARE uint lift_bvh_spill[LIFT_BVH_STACK - LIFT_BVH_SHARED_DEPTH];
#define LIFT_BVH_SHARED_AT(i) lift_bvh_stack[uint(i) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex]
#define LIFT_BVH_STACK_SET(i, v) if ((i) < LIFT_BVH_SHARED_DEPTH) LIFT_BVH_SHARED_AT(i) = (v); else lift_bvh_spill[(i) - LIFT_BVH_SHARED_DEPTH] = (v)
#define LIFT_BVH_STACK_GET(i) ((i) < LIFT_BVH_SHARED_DEPTH ? LIFT_BVH_SHARED_AT(i) : lift_bvh_spill[(i) - LIFT_BVH_SHARED_DEPTH])
#endif
#else
#define LIFT_BVH_STACK_DECLARE uint lift_bvh_stack[LIFT_BVH_STACK];
#define LIFT_BVH_STACK_SET(i, v) lift_bvh_stack[i] = (v)
#define LIFT_BVH_STACK_GET(i) lift_bvh_stack[i]
#endif

// With LIFT_COUNT_RAYS (lift-gl bench), each invocation counts its traversals here and the
// host adds the count to the statistics once, at the end: one atomic per pixel, not per ray.
#ifdef LIFT_COUNT_RAYS
uint lift_rays_traced = 0u;
#define LIFT_COUNT_RAY() (++lift_rays_traced)
#else
#define LIFT_COUNT_RAY()
#endif

#endif
