"""Buffer binding points (lift_gl/bindings.py): one table, no number used twice, and every
buffer block of the shaders declared through it."""
from __future__ import annotations

import re
from pathlib import Path

from conftest import REPO
from lift_gl import bindings, shaders
from lift_gl.bindings import STORAGE_BUFFERS, UNIFORM_BLOCKS, binding_defines

# A buffer block's layout: `layout(std430, binding = X) readonly buffer Name` (or a uniform block).
BLOCK = re.compile(r"layout\s*\(\s*std(?:430|140)\s*,\s*binding\s*=\s*(\w+)\s*\)\s*"
                   r"(?:(?:readonly|writeonly|coherent|restrict)\s+)*(?:buffer|uniform)\s+(\w+)")
# Where the renderer's GLSL lives: the library, the passes' shaders, the plugins, and the GLSL
# that passes write in Python strings.
SOURCES = [*sorted((REPO / "shaders").rglob("*.glsl")), *sorted((REPO / "shaders").rglob("*.comp")),
           *sorted((REPO / "shaders").rglob("*.vert")), *sorted((REPO / "shaders").rglob("*.frag")),
           *sorted((REPO / "plugins").rglob("*.glsl")), *sorted((REPO / "lift_gl").rglob("*.py"))]
# A kernel of lift_gl/glsl_kernel.py (tests, warptest) is a program of its own, dispatched alone
# right after its buffers are bound: it numbers them itself, from glsl_kernel.FIRST_FREE_BINDING.
KERNELS = {REPO / "lift_gl" / "glsl_kernel.py", REPO / "lift_gl" / "warp_kernels.py"}


def blocks() -> list[tuple[Path, str, str]]:
    """(file, binding as written, block name) of every buffer block in SOURCES."""
    found = []
    for path in SOURCES:
        if path in KERNELS:
            continue
        for m in BLOCK.finditer(path.read_text(encoding="utf-8")):
            found.append((path, m.group(1), m.group(2)))
    return found


def test_no_two_buffers_share_a_binding_point():
    numbers = list(STORAGE_BUFFERS.values())
    assert len(numbers) == len(set(numbers)), {n for n in numbers if numbers.count(n) > 1}
    assert len(set(UNIFORM_BLOCKS.values())) == len(UNIFORM_BLOCKS)
    # a uniform block keeps its array's storage-buffer number, in the other kind of binding point
    assert all(STORAGE_BUFFERS[name] == number for name, number in UNIFORM_BLOCKS.items())


def test_the_heap_fits_the_binding_points_after_the_other_buffers():
    heap = [STORAGE_BUFFERS[f"heap{k}"] for k in range(bindings.MAX_HEAP_CHUNKS)]
    assert heap == list(range(bindings.HEAP_FIRST_BINDING, bindings.HEAP_FIRST_BINDING + bindings.MAX_HEAP_CHUNKS))
    others = [n for name, n in STORAGE_BUFFERS.items() if not name.startswith("heap")]
    assert max(others) < bindings.HEAP_FIRST_BINDING


def test_the_gl_has_every_binding_point():
    from lift_gl.gl.context import create_context

    ctx = create_context("auto")
    most = ctx.info["GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS"]
    assert max(STORAGE_BUFFERS.values()) < most
    assert max(UNIFORM_BLOCKS.values()) < ctx.info["GL_MAX_UNIFORM_BUFFER_BINDINGS"]


# Blocks of the trace host that still write the number itself, checked against the table.
PENDING = {"LiftPixelQueue": "pixel_queue", "LiftCarry": "carry"}


def test_every_buffer_block_takes_its_number_from_the_table():
    found = blocks()
    assert len(found) > 40   # scene_data.glsl alone declares 33
    defined = binding_defines()
    literal = [f"{path.relative_to(REPO)}: {name} at binding {number}" for path, number, name in found
               if number not in defined and not (name in PENDING and number == str(STORAGE_BUFFERS[PENDING[name]]))]
    assert not literal, "buffer blocks with a binding number of their own, not from lift_gl/bindings.py:\n" + \
        "\n".join(literal)


def test_blocks_that_share_a_name_share_a_binding():
    """A block declared in two files (splats: the library and the resolve pass) is one buffer."""
    by_name = {}
    for path, number, name in blocks():
        by_name.setdefault(name, set()).add(number)
    assert {name: numbers for name, numbers in by_name.items() if len(numbers) > 1} == {}


def test_every_program_gets_the_binding_defines():
    source = shaders.assemble("void main() {}\n")
    for name, number in binding_defines().items():
        assert f"#define {name} {number}\n" in source.text
    # a host's own define of the same name wins (a program may move one of its buffers)
    assert "#define LIFT_BINDING_STATS 3\n" in shaders.assemble("void main() {}\n", {"LIFT_BINDING_STATS": 3}).text


def test_the_passes_bind_the_tables_numbers():
    """The Python side binds what the shaders declare: the constants the passes use are the table's."""
    from lift_gl.passes import carry, common, net_denoise, splat, trace
    from lift_gl.passes.motion_history import PREV_POSITIONS_BINDING

    assert splat.SPLAT_BINDING == STORAGE_BUFFERS["splats"]
    assert common.STATS_BINDING == STORAGE_BUFFERS["stats"]
    assert common.MOTION_BINDING == STORAGE_BUFFERS["motion"]
    assert common.SCENE_BINDINGS == bindings.SCENE_BINDINGS
    assert net_denoise.EXPOSURE_BINDING == STORAGE_BUFFERS["net_exposure"]
    assert PREV_POSITIONS_BINDING == STORAGE_BUFFERS["prev_positions"]
    assert trace.PIXEL_QUEUE_BINDING == STORAGE_BUFFERS["pixel_queue"]
    assert carry.CARRY_BINDING == STORAGE_BUFFERS["carry"]
