"""Run a GLSL compute snippet on the headless context and read its results back as numpy.

Tests and `lift-gl warptest` call shader functions on many inputs at once with it. A snippet
declares its inputs and outputs as std430 SSBOs at bindings >= FIRST_FREE_BINDING
(scene_data.glsl owns bindings 0..8; a snippet that does not read the scene leaves them
unbound) and writes one result per invocation; `invocation_index()` is its 1-D index (spread
over x and y work groups when there are more than 65535) and `u_count` the invocation count.
With `library=True` (the default) the snippet sees the BSDF library and the rng, and the
material under test as the uniform `u_material` (four vec4, the layout of struct Material),
returned by `test_material()`.

    kernel = Kernel(BODY, defines={"HAS_CONDUCTOR": True})
    out = kernel.run(count, outputs={10: (count, 4)}, uniforms={"u_material": material(...)})
"""
from __future__ import annotations

import numpy as np

from .gl.context import create_context
from .shaders import assemble, compile_compute

FIRST_FREE_BINDING = 10
LOCAL_SIZE = 64
MAX_GROUPS = 65535

MAT_DIFFUSE, MAT_CONDUCTOR, MAT_DIELECTRIC, MAT_PLASTIC = 0, 1, 2, 3

# Every material variant but Beckmann's: the defines a scene with all materials would set.
ALL_MATERIALS = {"HAS_CONDUCTOR": True, "HAS_ROUGH_CONDUCTOR": True,
                 "HAS_DIELECTRIC": True, "HAS_ROUGH_DIELECTRIC": True}

LIBRARY_PRELUDE = """
#include "lift/bsdf.glsl"
#include "lift/rng.glsl"
uniform vec4 u_material[4];
Material test_material() { return Material(u_material[0], u_material[1], u_material[2], u_material[3]); }
"""
INDEX_PRELUDE = """
layout(local_size_x = %d) in;
uniform uint u_count;
uint invocation_index() { return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * %du; }
""" % (LOCAL_SIZE, LOCAL_SIZE)


def material(type: int, color=(1.0, 1.0, 1.0), alpha: float = 0.0, eta=(-1.0, -1.0, -1.0),
             k=(0.0, 0.0, 0.0), ior: float = 1.5, emission=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The four vec4 of struct Material (scene_data.glsl), as float32 (4, 4)."""
    return np.array([[*color, float(type)], [*emission, alpha], [*eta, ior], [*k, 0.0]], dtype=np.float32)


def kernel_source(body: str, defines: dict | None = None, *, library: bool = True, include_dirs=(),
                  name: str = "<kernel>"):
    prelude = (LIBRARY_PRELUDE if library else "") + INDEX_PRELUDE
    return assemble(prelude + body, defines=defines, include_dirs=include_dirs, main_name=name)


_programs: dict[tuple[str, str], object] = {}  # (assembled text, backend) -> compiled program


class Kernel:
    """A compiled compute snippet. Programs are cached on their assembled text, so an edited
    include file compiles again and an unchanged one does not."""

    def __init__(self, body: str, defines: dict | None = None, *, library: bool = True, include_dirs=(),
                 name: str = "<kernel>", backend: str = "auto"):
        self.ctx = create_context(backend)
        source = kernel_source(body, defines, library=library, include_dirs=include_dirs, name=name)
        key = (source.text, backend)
        if key not in _programs:
            _programs[key] = compile_compute(self.ctx, source)  # a ShaderError names the file and line
        self.program = _programs[key]

    def run(self, count: int, outputs: dict[int, tuple], inputs: dict[int, np.ndarray] | None = None,
            uniforms: dict | None = None) -> dict[int, np.ndarray]:
        """Dispatch `count` invocations; outputs maps a binding to its float32 array shape."""
        prog = self.program
        for name, value in {**(uniforms or {}), "u_count": count}.items():
            uniform = prog.get(name, None)
            if uniform is None:
                continue  # optimised away
            if isinstance(value, np.ndarray):
                # An array's unused tail may be optimised away: write the part that is left.
                data = np.ascontiguousarray(value).tobytes()
                uniform.write(data[:uniform.array_length * uniform.element_size])
            else:
                uniform.value = value
        buffers = []
        for binding, array in (inputs or {}).items():
            buf = self.ctx.buffer(np.ascontiguousarray(array).tobytes())
            buf.bind_to_storage_buffer(binding)
            buffers.append(buf)
        out_buffers = {}
        for binding, shape in outputs.items():
            buf = self.ctx.buffer(reserve=max(4, int(np.prod(shape)) * 4))
            buf.bind_to_storage_buffer(binding)
            out_buffers[binding] = (buf, shape)
        groups = -(-count // LOCAL_SIZE)
        gx = max(1, min(groups, MAX_GROUPS))
        gy = -(-groups // gx)
        if groups:
            prog.run(gx, gy, 1)
        result = {b: np.frombuffer(buf.read(), dtype=np.float32)[:int(np.prod(shape))].reshape(shape).copy()
                  for b, (buf, shape) in out_buffers.items()}
        for buf in buffers + [b for b, _ in out_buffers.values()]:
            buf.release()
        return result
