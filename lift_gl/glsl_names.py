"""Names a plugin parameter cannot take. A parameter becomes a uniform of its name in the
shader the host generates, declared before the plugin's code and after the GLSL library's:
a GLSL keyword there is a syntax error, a built-in function's name hides that function, and a
name the library declares is declared twice, each failing far from the manifest that caused
it. `name_conflict` says which, so that the manifest's line gets the error instead.

The keywords and built-in functions are the GLSL 4.30 specification's (sections 3.6 and 8,
reserved words included); the library's names are read from shaders/lift/*.glsl
(lift_gl/glsl_library.py), so that they follow the library.
"""
from __future__ import annotations

# GLSL 4.30, section 3.6: keywords, then the words reserved for future use.
GLSL_KEYWORDS = frozenset("""
attribute const uniform varying buffer shared coherent volatile restrict readonly writeonly
atomic_uint layout centroid flat smooth noperspective patch sample break continue do for while
switch case default if else subroutine in out inout float double int void bool true false
invariant precise discard return struct lowp mediump highp precision
mat2 mat3 mat4 dmat2 dmat3 dmat4 mat2x2 mat2x3 mat2x4 dmat2x2 dmat2x3 dmat2x4 mat3x2 mat3x3
mat3x4 dmat3x2 dmat3x3 dmat3x4 mat4x2 mat4x3 mat4x4 dmat4x2 dmat4x3 dmat4x4
vec2 vec3 vec4 ivec2 ivec3 ivec4 bvec2 bvec3 bvec4 dvec2 dvec3 dvec4 uint uvec2 uvec3 uvec4
sampler1D sampler2D sampler3D samplerCube sampler1DShadow sampler2DShadow samplerCubeShadow
sampler1DArray sampler2DArray sampler1DArrayShadow sampler2DArrayShadow isampler1D isampler2D
isampler3D isamplerCube isampler1DArray isampler2DArray usampler1D usampler2D usampler3D
usamplerCube usampler1DArray usampler2DArray sampler2DRect sampler2DRectShadow isampler2DRect
usampler2DRect samplerBuffer isamplerBuffer usamplerBuffer sampler2DMS isampler2DMS
usampler2DMS sampler2DMSArray isampler2DMSArray usampler2DMSArray samplerCubeArray
samplerCubeArrayShadow isamplerCubeArray usamplerCubeArray
image1D iimage1D uimage1D image2D iimage2D uimage2D image3D iimage3D uimage3D image2DRect
iimage2DRect uimage2DRect imageCube iimageCube uimageCube imageBuffer iimageBuffer uimageBuffer
image1DArray iimage1DArray uimage1DArray image2DArray iimage2DArray uimage2DArray imageCubeArray
iimageCubeArray uimageCubeArray image2DMS iimage2DMS uimage2DMS image2DMSArray iimage2DMSArray
uimage2DMSArray
common partition active asm class union enum typedef template this resource goto inline
noinline public static extern external interface long short half fixed unsigned superp input
output hvec2 hvec3 hvec4 fvec2 fvec3 fvec4 sampler3DRect filter sizeof cast namespace using
""".split())

# GLSL 4.30, section 8 (and the derivative variants of 4.50).
GLSL_BUILTIN_FUNCTIONS = frozenset("""
radians degrees sin cos tan asin acos atan sinh cosh tanh asinh acosh atanh
pow exp log exp2 log2 sqrt inversesqrt
abs sign floor trunc round roundEven ceil fract mod modf min max clamp mix step smoothstep
isnan isinf floatBitsToInt floatBitsToUint intBitsToFloat uintBitsToFloat fma frexp ldexp
packUnorm2x16 packSnorm2x16 packUnorm4x8 packSnorm4x8 unpackUnorm2x16 unpackSnorm2x16
unpackUnorm4x8 unpackSnorm4x8 packDouble2x32 unpackDouble2x32 packHalf2x16 unpackHalf2x16
length distance dot cross normalize faceforward reflect refract
matrixCompMult outerProduct transpose determinant inverse
lessThan lessThanEqual greaterThan greaterThanEqual equal notEqual any all not
uaddCarry usubBorrow umulExtended imulExtended bitfieldExtract bitfieldInsert bitfieldReverse
bitCount findLSB findMSB
textureSize textureQueryLod textureQueryLevels textureSamples texture textureProj textureLod
textureOffset texelFetch texelFetchOffset textureProjOffset textureLodOffset textureProjLod
textureProjLodOffset textureGrad textureGradOffset textureProjGrad textureProjGradOffset
textureGather textureGatherOffset textureGatherOffsets
atomicCounterIncrement atomicCounterDecrement atomicCounter
atomicAdd atomicMin atomicMax atomicAnd atomicOr atomicXor atomicExchange atomicCompSwap
imageSize imageSamples imageLoad imageStore imageAtomicAdd imageAtomicMin imageAtomicMax
imageAtomicAnd imageAtomicOr imageAtomicXor imageAtomicExchange imageAtomicCompSwap
dFdx dFdy dFdxFine dFdyFine dFdxCoarse dFdyCoarse fwidth fwidthFine fwidthCoarse
interpolateAtCentroid interpolateAtSample interpolateAtOffset
noise1 noise2 noise3 noise4
EmitStreamVertex EndStreamPrimitive EmitVertex EndPrimitive
barrier memoryBarrier memoryBarrierAtomicCounter memoryBarrierBuffer memoryBarrierShared
memoryBarrierImage groupMemoryBarrier
""".split())

# What the host's program declares besides the library: the plugin's entry points, and its
# uniforms and helpers (u_frame, u_seed, lift_sample_rng, ...: shaders/lift/host_main.comp).
# Defines of these prefixes are the host's feature switches (HAS_SPHERES, LIFT_PIXEL_QUEUE, ...),
# and GLSL reserves gl_ and GL_.
HOST_NAMES = frozenset({"main", "radiance"})
HOST_PREFIXES = ("u_", "lift_", "Lift", "LIFT_", "HAS_", "PRIMARY_", "gl_", "GL_")


def name_conflict(name: str) -> str | None:
    """Why `name` cannot name a plugin parameter (or a parameter's define), or None when it can."""
    if name in GLSL_KEYWORDS:
        return "is a GLSL keyword"
    if name in GLSL_BUILTIN_FUNCTIONS:
        return "is a GLSL built-in function (a uniform of that name would hide it)"
    if "__" in name:
        return "contains '__', which GLSL reserves"
    if name in HOST_NAMES:
        return "is a function the host calls in the plugin's shader"
    if name.startswith(HOST_PREFIXES):
        return f"starts like the host's and the library's own names ({', '.join(HOST_PREFIXES)})"
    from .glsl_library import library_names

    declared = library_names().get(name)
    if declared is not None:
        kind = {"define": "a #define", "block": "a buffer", "prototype": "a function"}.get(declared.kind,
                                                                                           f"a {declared.kind}")
        return f"is {kind} the GLSL library declares (shaders/lift/{declared.where})"
    return None
