"""A plugin parameter named like a GLSL keyword, a built-in function, a name of the host's or a
name the GLSL library declares is an error at its plugin.toml line (lift_gl/glsl_names.py),
and the library's names are read from its files (lift_gl/glsl_library.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from conftest import REPO
from lift_gl.errors import PluginError
from lift_gl.glsl_library import library_names, parse_file
from lift_gl.plugins import discover, load_manifest

MANIFEST = """name = "mine"
language = "glsl"
entry = "mine.glsl"

[params.gain]
type = "float"
default = 1.0

[params.{name}]
type = "int"
default = 2
"""
HEADER_LINE = 9  # [params.{name}]


def manifest_error(tmp_path, name: str) -> PluginError:
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST.format(name=name))
    (folder / "mine.glsl").write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(gain); }\n")
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    return err.value


@pytest.mark.parametrize("name, words", [
    ("float", "is a GLSL keyword"), ("in", "is a GLSL keyword"), ("sample", "is a GLSL keyword"),
    ("uniform", "is a GLSL keyword"), ("filter", "is a GLSL keyword"),   # reserved for future use
    ("texture", "is a GLSL built-in function"), ("dot", "is a GLSL built-in function"),
    ("mix", "is a GLSL built-in function"),
    ("sample_light", "is a function the GLSL library declares (shaders/lift/lights.glsl:"),
    ("surface_at", "is a function the GLSL library declares (shaders/lift/surface.glsl:"),
    ("Ray", "is a struct the GLSL library declares (shaders/lift/trace.glsl:"),
    ("NO_HIT", "is a constant the GLSL library declares"),
    ("MAT_DIFFUSE", "is a #define the GLSL library declares (shaders/lift/scene_data.glsl:"),
    ("stats", "is a buffer the GLSL library declares"),   # a member of an unnamed block
    ("g_ray_time", "is a variable the GLSL library declares"),
    ("radiance", "is a function the host calls"),
    ("u_frame", "starts like the host's"), ("lift_gain", "starts like the host's"),
    ("HAS_SPHERES", "starts like the host's"), ("gl_Position", "starts like the host's"),
    ("my__gain", "contains '__'"),
])
def test_reserved_parameter_names_fail_at_their_line(tmp_path, name, words):
    err = manifest_error(tmp_path, name)
    assert err.path.endswith("plugin.toml") and err.line == HEADER_LINE, str(err)
    assert str(err).startswith(f"{err.path}:{HEADER_LINE}: parameter '{name}' {words}"), str(err)


def test_a_define_named_like_a_keyword_fails(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST.format(name="depth") + 'define = "while"\n')
    (folder / "mine.glsl").write_text("vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(gain); }\n")
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    assert err.value.line == HEADER_LINE and "define 'while' is a GLSL keyword" in str(err.value)


def test_ordinary_names_and_every_shipped_manifest_pass():
    assert library_names().get("max_depth") is None   # a parameter convention, not a library name
    broken = {}
    discover([], broken)
    assert broken == {}
    manifests = [p.parent for p in REPO.glob("**/plugin.toml") if ".venv" not in p.parts and "tmp" not in p.parts]
    assert len(manifests) >= 8
    for folder in manifests:
        load_manifest(folder)   # raises on a name that is not allowed


def test_library_names_are_read_from_the_files(tmp_path):
    (tmp_path / "mini.glsl").write_text("""// mini.glsl: a small library file.
#ifndef LIFT_MINI_GLSL
#define LIFT_MINI_GLSL
#define MINI_SCALE 2.0   // a constant of the preprocessor
struct Pair {
    float a;   // first
    vec2 b, c; // the others
#ifdef HAS_MORE
    uint more;
#endif
};
const uint MINI_NONE = 0u;
float mini_global = 0.0;
uniform vec3 u_mini;
layout(std430, binding = 3) readonly buffer MiniBlock { vec4 mini_rows[]; };
layout(std430, binding = 4) readonly buffer Named { vec4 hidden[]; } named;

// Sums a pair
// over two lines.
float mini_sum(Pair p,
               float weight) {
    if (p.a > 0.0) { return p.a; }
    return weight * (p.b.x + p.c.y);
}
#ifdef HAS_MORE
vec3 mini_later(vec3 v);   // declared here, defined below
#endif
vec3 mini_later(vec3 v) { return v; }
#endif
""")
    names = library_names(tmp_path)
    assert set(names) == {"MINI_SCALE", "Pair", "MINI_NONE", "mini_global", "u_mini", "MiniBlock", "mini_rows",
                          "Named", "mini_sum", "mini_later"}
    parsed = parse_file(tmp_path / "mini.glsl")
    assert parsed.header == "mini.glsl: a small library file."
    by_name = {d.name: d for d in parsed.declarations}
    assert by_name["mini_sum"].signature == "float mini_sum(Pair p, float weight)"
    assert by_name["mini_sum"].comment == "Sums a pair\nover two lines."
    assert by_name["mini_sum"].line == 20
    assert by_name["MINI_SCALE"].comment == "a constant of the preprocessor"
    assert [(f.name, f.type, f.comment, f.condition) for f in by_name["Pair"].fields] == [
        ("a", "float", "first", ""), ("b", "vec2", "the others", ""), ("c", "vec2", "the others", ""),
        ("more", "uint", "", "HAS_MORE")]
    assert [(d.kind, d.condition) for d in parsed.declarations if d.name == "mini_later"] == [
        ("prototype", "HAS_MORE"), ("function", "")]


def test_the_contract_names_are_found_in_the_library():
    # DESIGN.md's list of what plugins call: each is read from the library's own files
    names = library_names()
    for name in ("surface_at", "material_at", "bsdf_eval", "bsdf_pdf", "bsdf_sample", "bsdf_eval_pdf",
                 "sample_light", "light_pdf", "trace_closest", "trace_occluded", "trace_shadow_and_next",
                 "spawn_ray", "power_heuristic", "rng_next", "rng_next2", "rng_next3", "rng_ld2",
                 "Material", "Surface", "Hit", "Ray", "BsdfSample", "LightSample", "Rng", "Frame"):
        assert name in names, name
        assert Path(names[name].path).parent == REPO / "shaders" / "lift"
