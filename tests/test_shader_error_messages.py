"""A shader that fails to compile reaches the user with the driver's whole message: every
candidate of an overload that did not match and every other error, each at the file and line
a person wrote (lift_gl/shaders.py)."""
from __future__ import annotations

from conftest import REPO
from lift_gl.cli import main

CORNELL = str(REPO / "scenes" / "cornell.toml")
SHADER = """vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.5);
    L = mix(L, 0.5);               // line 3: mix needs a third argument
    float u = rng_next(rng, 2.0);  // line 4: the library's rng_next takes the Rng only
    return L * u;
}
"""


def test_overload_mismatch_keeps_every_candidate_and_every_error(tmp_path, capsys):
    folder = tmp_path / "plugins" / "badcall"
    folder.mkdir(parents=True)
    (folder / "plugin.toml").write_text('name = "badcall"\nlanguage = "glsl"\nentry = "badcall.glsl"\n'
                                        'primary = "gbuffer"\n')
    (folder / "badcall.glsl").write_text(SHADER)
    code = main(["render", CORNELL, "--plugins", str(tmp_path / "plugins"), "--integrator", "badcall",
                 "--spp", "1", "--size", "8x8", "--out", str(tmp_path / "x.npy")])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err
    shader = (folder / "badcall.glsl").resolve()
    lines = err.splitlines()
    assert lines[0].startswith(f"lift-gl: error: {shader}:3: ") and "mix(vec3, float)" in lines[0], err
    # the candidates follow, indented, one a line: the three-argument float and vector ones at least
    candidates = [line.strip() for line in lines[1:] if line.startswith("    ")]
    for signature in ("float mix(float, float, float)", "vec3 mix(vec3, vec3, float)", "vec3 mix(vec3, vec3, vec3)"):
        assert signature in candidates, err
    # the second error keeps its own place, and its candidate
    second = next(i for i, line in enumerate(lines) if line.startswith(f"{shader}:4: "))
    assert "rng_next(Rng, float)" in lines[second] and lines[second + 1].strip() == "float rng_next(Rng)", err
