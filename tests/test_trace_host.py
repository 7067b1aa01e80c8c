"""The trace host is a shader file (shaders/lift/host_main.comp) that every built-in plugin's
program compiles with, with every scene feature compiled in, in each of its variants (the
path-steps loop, the pixel queue, carried paths, coherent sampling, a shared BVH stack); the
variant's own file is in the program exactly where the options chose it. Python writes only
the program's head: the work group, the plugin's parameters, the include of its entry file."""
from __future__ import annotations

import pytest

from conftest import REPO
from lift_gl.options import Options
from lift_gl.passes.trace import generate_main, program_head
from lift_gl.plugins import BUILTIN_DIR, find_plugin
from lift_gl.renderer import Renderer
from lift_gl.scene.features import SceneFeatures
from lift_gl.testing import cornell_scene

LIFT = REPO / "shaders" / "lift"
BUILTIN_GLSL = sorted(p.parent.name for p in BUILTIN_DIR.glob("*/plugin.toml")
                      if 'language = "glsl"' in p.read_text())


def _files(r: Renderer) -> set[str]:
    return {p.name for p in r.trace.source.files if p.is_file()}


def test_the_builtins_are_all_here():
    assert {"ao", "bdpt", "debug", "drt", "hybrid", "pt", "template"} <= set(BUILTIN_GLSL)


@pytest.mark.parametrize("name", BUILTIN_GLSL)
def test_every_builtin_compiles_with_every_feature(name):
    r = Renderer(cornell_scene(), size=(8, 8), integrator=name, features=SceneFeatures.everything())
    try:
        files = _files(r)
        assert {"host.glsl", "host_main.comp", "sample_guard.glsl", "host_tiles.glsl"} <= files
        assert ("LIFT_PIXEL_QUEUE" in r.trace.defines) == (r.trace.pixel_queue is not None)
        if r.reduced is not None:
            assert "host_reduced.comp" in {p.name for p in r.reduced.source.files}
    finally:
        r.release()


@pytest.mark.parametrize("options, queue, carry", [
    ({"pixel_queue": "off"}, False, False),
    ({"pixel_queue": "on"}, True, False),
    ({"pixel_queue": "on", "carry_paths": "on"}, True, True),
    ({"pixel_queue": "on", "coherent_sampling": "on", "coherent_interleave": 2}, True, False),
    ({"pixel_queue": "on", "bvh_stack": "shared", "trace_paired": "on"}, True, False),
    ({"coherent_sampling": "on", "bvh_stack": "shared"}, False, False),
])
def test_pt_compiles_in_every_variant_with_every_feature(options, queue, carry):
    r = Renderer(cornell_scene(), size=(8, 8), integrator="pt", features=SceneFeatures.everything(),
                 options=Options(**options))
    try:
        files = _files(r)
        # (the assembler expands every #include, used or not: the defines say which variant runs)
        assert {"host_main.comp", "host_pixel_queue.glsl", "host_carry.glsl"} <= files
        assert ("LIFT_PIXEL_QUEUE" in r.trace.defines) == queue == (r.trace.pixel_queue is not None)
        assert ("LIFT_CARRY_PATHS" in r.trace.defines) == carry == (r.trace.carry is not None)
    finally:
        r.release()


def test_python_writes_only_the_head():
    """The generated text is a few lines: the library, the work group, the parameters, the
    plugin's file, the host's file; the sample loop is not in it."""
    pt = find_plugin("pt")
    text = generate_main(pt, (8, 4))
    assert text.startswith(program_head(pt, (8, 4)))
    assert "layout(local_size_x = 8, local_size_y = 4) in;" in text
    assert all(f"uniform {'float' if p.type == 'float' else p.type} {name};" in text
               for name, p in pt.params.items() if p.type in ("int", "float", "bool"))
    assert text.rstrip().endswith('#include "lift/host_main.comp"')
    assert "radiance(" not in text and "void main" not in text
    assert len(text.splitlines()) <= 8 + len(pt.params)   # 8: the comments, includes and layout
    host = (LIFT / "host_main.comp").read_text()
    assert "radiance(ray, hit, rng)" in host and "lift_add_sample(" in host


def test_no_shader_comment_names_an_include():
    """moderngl follows `#include "..."` wherever it stands, comments too: a host file that
    showed its program's head that way would fail to compile."""
    for path in [*LIFT.glob("host*"), LIFT / "sample_guard.glsl"]:
        for line in path.read_text().splitlines():
            code, _, comment = line.partition("//")
            assert '#include "' not in comment, f"{path.name}: {line}"
