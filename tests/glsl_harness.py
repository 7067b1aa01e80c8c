"""Run a GLSL compute snippet on the headless context and read its results back as numpy.

The BSDF tests use it to call shader functions on many inputs at once: a kernel declares its
inputs and outputs as std430 SSBOs at bindings >= FIRST_TEST_BINDING (scene_data.glsl owns
bindings 0..8; the test kernels never touch those buffers, so they are left unbound), takes
the material under test as the uniform `u_material` (four vec4, the layout of struct Material)
and writes one result per invocation.

    kernel = Kernel(BODY, defines={"HAS_CONDUCTOR": True})
    out = kernel.run(count, outputs={10: (count, 4)}, uniforms={"u_material": material(...)})
"""
from __future__ import annotations

import functools

import numpy as np

from lift_gl.gl.context import create_context
from lift_gl.shaders import assemble, compile_compute

FIRST_TEST_BINDING = 10
LOCAL_SIZE = 64
MAX_GROUPS = 65535

MAT_DIFFUSE, MAT_CONDUCTOR, MAT_DIELECTRIC = 0, 1, 2

# Every material variant: the defines a scene with all materials would set.
ALL_MATERIALS = {"HAS_CONDUCTOR": True, "HAS_ROUGH_CONDUCTOR": True,
                 "HAS_DIELECTRIC": True, "HAS_ROUGH_DIELECTRIC": True}

# Prepended to each kernel body: the BSDF library, the rng, the material uniform and the
# invocation index (1-D, spread over x and y work groups when there are more than 65535).
PRELUDE = """
#include "lift/bsdf.glsl"
#include "lift/rng.glsl"
layout(local_size_x = %d) in;
uniform vec4 u_material[4];
uniform uint u_count;
Material test_material() { return Material(u_material[0], u_material[1], u_material[2], u_material[3]); }
uint invocation_index() { return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * %du; }
""" % (LOCAL_SIZE, LOCAL_SIZE)


def context():
    return create_context()


def material(type: int, color=(1.0, 1.0, 1.0), alpha: float = 0.0, eta=(-1.0, -1.0, -1.0),
             k=(0.0, 0.0, 0.0), ior: float = 1.5, emission=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The four vec4 of struct Material (scene_data.glsl), as float32 (4, 4)."""
    return np.array([[*color, float(type)], [*emission, alpha], [*eta, ior], [*k, 0.0]], dtype=np.float32)


def source(body: str, defines: dict | None = None):
    return assemble(PRELUDE + body, defines=defines, main_name="<test kernel>")


@functools.lru_cache(maxsize=None)
def _compile(body: str, defines_key: tuple):
    return compile_compute(context(), source(body, dict(defines_key)))


class Kernel:
    """A compiled compute snippet (compiled once per body and define set, then cached)."""

    def __init__(self, body: str, defines: dict | None = None):
        self.program = _compile(body, tuple(sorted((defines or {}).items())))

    def run(self, count: int, outputs: dict[int, tuple], inputs: dict[int, np.ndarray] | None = None,
            uniforms: dict | None = None) -> dict[int, np.ndarray]:
        """Dispatch `count` invocations; outputs maps a binding to its float32 array shape."""
        ctx = context()
        prog = self.program
        for name, value in {**(uniforms or {}), "u_count": count}.items():
            if name not in prog:
                continue  # optimised away
            if isinstance(value, np.ndarray):
                # An array's unused tail may be optimised away: write the part that is left.
                uniform = prog[name]
                data = np.ascontiguousarray(value).tobytes()
                uniform.write(data[:uniform.array_length * uniform.element_size])
            else:
                prog[name].value = value
        buffers = []
        for binding, array in (inputs or {}).items():
            buf = ctx.buffer(np.ascontiguousarray(array).tobytes())
            buf.bind_to_storage_buffer(binding)
            buffers.append(buf)
        out_buffers = {}
        for binding, shape in outputs.items():
            buf = ctx.buffer(reserve=max(4, int(np.prod(shape)) * 4))
            buf.bind_to_storage_buffer(binding)
            out_buffers[binding] = (buf, shape)
        groups = -(-count // LOCAL_SIZE)
        gx = min(groups, MAX_GROUPS)
        gy = -(-groups // gx)
        prog.run(gx, gy, 1)
        result = {b: np.frombuffer(buf.read(), dtype=np.float32).reshape(shape).copy()
                  for b, (buf, shape) in out_buffers.items()}
        for buf in buffers + [b for b, _ in out_buffers.values()]:
            buf.release()
        return result
