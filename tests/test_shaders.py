"""The GLSL assembler: includes (also inside #if blocks), defines, errors mapped to file:line."""
from __future__ import annotations

import pytest

from lift_gl.errors import ShaderError
from lift_gl.gl.context import create_context
from lift_gl.shaders import assemble, compile_compute


def write(folder, name, text):
    path = folder / name
    path.write_text(text)
    return path


def test_include_inside_an_inactive_block_does_not_hide_a_later_include(tmp_path):
    write(tmp_path, "lib.glsl", "#ifndef LIB\n#define LIB\nfloat lib_value() { return 2.0; }\n#endif\n")
    main = write(tmp_path, "main.comp",
                 "layout(local_size_x = 1) in;\n#ifdef NEVER\n#include \"lib.glsl\"\n#endif\n"
                 "#include \"lib.glsl\"\nvoid main() { float x = lib_value(); }\n")
    compile_compute(create_context(), assemble(main)).release()


def test_errors_name_the_included_file_and_line(tmp_path):
    write(tmp_path, "lib.glsl", "// one\n// two\nfloat broken() { return missing_name; }\n")
    main = write(tmp_path, "main.comp", "layout(local_size_x = 1) in;\n#include \"lib.glsl\"\nvoid main() {}\n")
    with pytest.raises(ShaderError) as err:
        compile_compute(create_context(), assemble(main))
    assert err.value.path == str((tmp_path / "lib.glsl").resolve()) and err.value.line == 3
    assert "missing_name" in str(err.value)


def test_errors_after_an_include_keep_the_including_files_lines(tmp_path):
    write(tmp_path, "lib.glsl", "#ifndef LIB\n#define LIB\nfloat ok() { return 1.0; }\n#endif\n")
    main = write(tmp_path, "main.comp",
                 "layout(local_size_x = 1) in;\n#include \"lib.glsl\"\n#include \"lib.glsl\"\n"
                 "void main() { float y = not_declared; }\n")
    with pytest.raises(ShaderError) as err:
        compile_compute(create_context(), assemble(main))
    assert err.value.path.endswith("main.comp") and err.value.line == 4


def test_missing_include_and_cycles_are_clear_errors(tmp_path):
    main = write(tmp_path, "main.comp", "// first\n#include \"nowhere.glsl\"\n")
    with pytest.raises(ShaderError) as err:
        assemble(main)
    assert err.value.line == 2 and "nowhere.glsl" in str(err.value)
    write(tmp_path, "a.glsl", "#include \"b.glsl\"\n")
    write(tmp_path, "b.glsl", "#include \"a.glsl\"\n")
    with pytest.raises(ShaderError, match="includes itself"):
        assemble(write(tmp_path, "c.comp", "#include \"a.glsl\"\n"))


def test_defines_are_emitted_after_the_version_line():
    src = assemble("void main() {}\n", {"HAS_X": True, "COUNT": 3, "OFF": False})
    lines = src.text.splitlines()
    assert lines[0].startswith("#version")
    assert "#define HAS_X" in lines and "#define COUNT 3" in lines
    assert not any("OFF" in line for line in lines)


def test_low_discrepancy_pairs_are_uniform_and_stratified():
    """rng_ld2 over one pixel's 256 samples: every pair puts exactly one point in each cell of
    a 16x16 grid (Sobol's (0,2)-net property survives Owen scrambling), while the same pair
    of another pixel, and another pair of the same pixel, is a different point set; and over
    many pixels each pair is uniform (chi-square)."""
    import numpy as np
    from scipy import stats

    ctx = create_context()
    src = assemble("""
layout(local_size_x = 64) in;
#include "lift/rng.glsl"
layout(std430, binding = 10) buffer Out { vec2 points[]; };
uniform uint u_pairs;
void main() {
    uint pixel = gl_GlobalInvocationID.x / 256u, s = gl_GlobalInvocationID.x % 256u;
    Rng r = rng_init_pixel_sample(uvec2(pixel, 7u), 0u, 0u, s, 3u, 0u);
    for (uint p = 0u; p < u_pairs; ++p) points[gl_GlobalInvocationID.x * u_pairs + p] = rng_ld2(r);
}
""")
    program = compile_compute(ctx, src)
    pixels, pairs = 64, 4
    out = ctx.buffer(reserve=pixels * 256 * pairs * 8)
    out.bind_to_storage_buffer(10)
    program["u_pairs"].value = pairs
    program.run(pixels * 256 // 64)
    points = np.frombuffer(out.read(), np.float32).reshape(pixels, 256, pairs, 2)
    assert points.min() >= 0.0 and points.max() < 1.0
    cells = (points * 16).astype(int)
    flat = cells[..., 0] * 16 + cells[..., 1]
    for pixel in range(pixels):
        for pair in range(pairs):
            assert len(np.unique(flat[pixel, :, pair])) == 256
    assert not np.array_equal(points[0, :, 0], points[1, :, 0])
    assert not np.array_equal(points[0, :, 0], points[0, :, 1])
    # Uniformity over pixels: first points of each pixel, pooled over pairs, on an 8x8 grid.
    first = points[:, 0].reshape(-1, 2)
    counts = np.histogram2d(first[:, 0], first[:, 1], bins=8, range=[[0, 1], [0, 1]])[0].ravel()
    assert stats.chisquare(counts).pvalue > 1e-3


def test_sobol_second_dimension_matches_its_generator_matrix():
    """sobol_dimension_1_reversed (loop-free, lift/rng.glsl), reversed back, equals the XOR of the generator matrix's
    rows v_k = v_(k-1) ^ (v_(k-1) >> 1), v_0 = 2^31, over the index's set bits."""
    import numpy as np

    def by_rows(index: int) -> int:
        x, v = 0, 0x80000000
        while index:
            if index & 1:
                x ^= v
            index >>= 1
            v ^= v >> 1
        return x

    rng = np.random.default_rng(5)
    indices = np.concatenate([np.arange(1024), rng.integers(0, 2**32, 3072)]).astype(np.uint32)
    ctx = create_context()
    src = assemble("""
layout(local_size_x = 64) in;
#include "lift/rng.glsl"
layout(std430, binding = 10) buffer In { uint indices[]; };
layout(std430, binding = 11) buffer Out { uint values[]; };
void main() { values[gl_GlobalInvocationID.x] = bitfieldReverse(sobol_dimension_1_reversed(indices[gl_GlobalInvocationID.x])); }
""")
    program = compile_compute(ctx, src)
    inp = ctx.buffer(indices.tobytes())
    out = ctx.buffer(reserve=indices.nbytes)
    inp.bind_to_storage_buffer(10)
    out.bind_to_storage_buffer(11)
    program.run(len(indices) // 64)
    got = np.frombuffer(out.read(), np.uint32)
    assert [int(g) for g in got] == [by_rows(int(i)) for i in indices]
