"""shaders/lift/octahedral.glsl: a unit vector packed into one word and back (bdpt's stored
light subpath keeps its normals and directions so). Checked against the vectors themselves:
every direction of the sphere, the axes, both folds of the octahedron and its seams."""
import numpy as np

from lift_gl.glsl_kernel import Kernel

KERNEL = """
layout(std430, binding = 10) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, binding = 11) writeonly buffer Outputs { vec4 outputs[]; };
#include "lift/octahedral.glsl"
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    outputs[i] = vec4(unpack_unit_vector(pack_unit_vector(inputs[i].xyz)), 0.0);
}
"""


def directions() -> np.ndarray:
    rng = np.random.default_rng(5)
    random = rng.normal(size=(20000, 3))
    axes = np.vstack([np.eye(3), -np.eye(3)])
    # the seams: on a coordinate plane, and just off the equator on either side
    seams = rng.normal(size=(3000, 3))
    seams[:1000, 0] = 0.0
    seams[1000:2000, 1] = 0.0
    seams[2000:, 2] = rng.choice([-1e-6, 0.0, 1e-6], size=1000)
    d = np.vstack([random, axes, seams])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_round_trip_is_unit_and_within_1e4_rad():
    d = directions()
    inputs = np.hstack([d, np.zeros((len(d), 1))]).astype(np.float32)
    out = Kernel(KERNEL).run(len(d), inputs={10: inputs}, outputs={11: (len(d), 4)})[11][:, :3]
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-6)
    angle = np.linalg.norm(out - d, axis=1)  # the chord: arccos of a float32 dot product can't resolve 1e-4
    assert angle.max() < 1e-4, angle.max()
    np.testing.assert_allclose(out[20000:20006], d[20000:20006], atol=1e-6)  # the axes exactly
    assert np.all(np.sign(out[d[:, 2] < -1e-3, 2]) < 0)  # the folded lower half stays below


def test_zero_vector_is_finite():
    inputs = np.zeros((1, 4), np.float32)
    out = Kernel(KERNEL).run(1, inputs={10: inputs}, outputs={11: (1, 4)})[11]
    assert np.all(np.isfinite(out))
