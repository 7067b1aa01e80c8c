"""docs/glsl-library.md is what lift_gl/glsl_docs.py makes from shaders/lift/*.glsl now, and it
documents every library function the template and pt plugins call."""
from __future__ import annotations

import re

from conftest import REPO
from lift_gl.glsl_docs import documented_names, generate
from lift_gl.glsl_library import library, parse_file
from lift_gl.glsl_names import GLSL_BUILTIN_FUNCTIONS, GLSL_KEYWORDS

PAGE = REPO / "docs" / "glsl-library.md"


def test_the_committed_page_is_what_the_generator_makes():
    assert PAGE.read_text(encoding="utf-8") == generate(), (
        "docs/glsl-library.md is stale: run  python -m lift_gl.glsl_docs > docs/glsl-library.md")


def _called(path) -> set[str]:
    """Names the file calls: identifiers before '(' in its code, comments left out."""
    text = re.sub(r"/\*.*?\*/", "", path.read_text(), flags=re.S)
    text = "\n".join(re.sub(r"//.*", "", line) for line in text.splitlines() if not line.lstrip().startswith("#"))
    return set(re.findall(r"\b([A-Za-z_]\w*)\s*\(", text))


def test_every_library_function_the_template_and_pt_call_is_documented():
    library_functions = {d.name: d for f in library() for d in f.declarations if d.kind in ("function", "prototype")}
    page = PAGE.read_text(encoding="utf-8")
    checked = set()
    for plugin in ("template", "pt"):
        for path in (REPO / "plugins" / plugin).glob("*.glsl"):
            own = {d.name for d in parse_file(path).declarations}
            for name in _called(path) - own - GLSL_BUILTIN_FUNCTIONS - GLSL_KEYWORDS:
                assert name in library_functions, f"{path.name} calls {name}, which the library does not declare"
                assert name in documented_names(), f"{name} ({path.name} calls it) is not on the page"
                entry = page.split(f"#### `{name}`\n", 1)[1].split("\n####", 1)[0]
                prose = [part for part in entry.split("\n\n") if part.strip() and not part.startswith(("```", "*"))]
                assert prose, f"{name} ({path.name} calls it) has no description: write a comment above it"
                checked.add(name)
    # the contract DESIGN.md names, among them
    assert {"surface_at", "material_at", "bsdf_sample", "bsdf_eval_pdf", "sample_light", "light_pdf",
            "trace_shadow_and_next", "spawn_ray", "power_heuristic", "rng_next"} <= checked, checked


def test_the_material_fields_and_the_structs_are_on_the_page():
    page = PAGE.read_text(encoding="utf-8")
    material = page.split("#### `Material`\n\n```glsl\nstruct Material\n```", 1)[1].split("\n####", 1)[0]
    for field in ("color_type", "emission_alpha", "eta_ior", "k_pad"):
        assert f"| `{field}` | `vec4` |" in material
    for struct in ("Surface", "Hit", "Ray", "BsdfSample", "LightSample", "Rng", "Frame", "PathState"):
        assert f"#### `{struct}`\n\n```glsl\nstruct {struct}\n```" in page


def test_the_guide_and_the_template_link_to_it():
    plugins_md = (REPO / "docs" / "plugins.md").read_text(encoding="utf-8")
    library_section = plugins_md.split("### The library", 1)[1].split("\n## ", 1)[0]
    assert "(glsl-library.md)" in library_section
    header = (REPO / "plugins" / "template" / "template.glsl").read_text().split("\n\n", 1)[0]
    assert "docs/glsl-library.md" in header


def test_every_link_within_the_page_has_its_heading():
    """Links to #name land on a heading whose GitHub anchor is name (lower case, punctuation
    other than - and _ dropped, spaces as -)."""
    import re

    page = PAGE.read_text(encoding="utf-8")
    anchors = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
               for h in re.findall(r"^#+ (.*)$", page, re.M)}
    targets = set(re.findall(r"\]\(#([^)]+)\)", page))
    assert targets and not targets - anchors, sorted(targets - anchors)[:10]
