"""Leave out what the scene doesn't need: the trace shader of a diffuse-only scene holds no
conductor or glass code, and `--explain` says which passes and features were chosen."""
from __future__ import annotations

import moderngl
import pytest

from conftest import furnace_scene
from lift_gl.renderer import Renderer
from lift_gl.scene import Material
from lift_gl.scene.features import SceneFeatures

# One function that only exists with each feature (shaders/lift/bsdf.glsl).
PROBES = {
    "conductor": "vec3 probe(Material m) { return conductor_fresnel(m, 1.0); }",
    "rough conductor": "vec3 probe(Material m, vec3 w) { return conductor_rough_eval(m, w, w); }",
    "dielectric": "float probe(Material m) { return dielectric_etap(m, vec3(0.0, 0.0, 1.0)); }",
    "rough dielectric": "vec3 probe(Material m, vec3 w) { return dielectric_rough_eval(m, w, w); }",
    "plastic": "vec3 probe(Material m, vec3 w) { return plastic_eval(m, w, w); }",
    "rough plastic": "vec3 probe(Material m, vec3 w) { float pdf; return plastic_specular_eval_pdf(m, w, w, 0.1, pdf); }",
    "textures": "vec4 probe(vec2 uv) { return texture_lookup(0u, uv); }",
    "environment map": "float probe(vec3 w) { return env_map_pdf(w); }",
    "beckmann": "vec3 probe(Material m, vec3 w) { return conductor_beckmann_eval(m, w, w); }",
}


def compiles(ctx, text):
    try:
        ctx.compute_shader(text).release()
        return True
    except moderngl.Error:
        return False


def test_diffuse_scene_compiles_no_conductor_or_glass_code():
    renderer = Renderer(furnace_scene(Material("d", "diffuse")), size=(8, 8))
    assert renderer.features == SceneFeatures(spheres=True, environment=True)
    source = renderer.trace.source.text
    for name, probe in PROBES.items():
        assert not compiles(renderer.ctx, source + probe + "\n"), f"{name} code was compiled in"
    assert "#define HAS_TEXTURES" not in source


@pytest.mark.parametrize("material, present", [
    (Material("c", "conductor", alpha=0.3), ["conductor", "rough conductor"]),
    (Material("g", "dielectric", alpha=0.0), ["dielectric"]),
])
def test_features_follow_the_materials(material, present):
    renderer = Renderer(furnace_scene(material), size=(8, 8))
    source = renderer.trace.source.text
    for name, probe in PROBES.items():
        assert compiles(renderer.ctx, source + probe + "\n") == (name in present), name


def test_everything_compiles_every_feature():
    renderer = Renderer(furnace_scene(Material("d")), size=(8, 8), features=SceneFeatures.everything())
    for name, probe in PROBES.items():
        assert compiles(renderer.ctx, renderer.trace.source.text + probe + "\n"), name


def test_explain_lists_passes_and_features():
    text = Renderer(furnace_scene(Material("d")), size=(8, 8)).explain()
    assert "gbuffer" in text and "trace" in text and "accumulate" in text
    assert "+ spheres" in text and "- conductor" in text and "- dielectric" in text
    camera_text = Renderer(furnace_scene(Material("d")), size=(8, 8), integrator="pt",
                           samples_per_frame=1).explain()
    assert "primary hit from gbuffer" in camera_text


def test_every_feature_compiled_in_renders_the_same_image():
    """Code for features a scene lacks is dead code: compiling it in (--all-features) must
    not change a single random number or pixel, here with the new features in use."""
    import numpy as np

    from conftest import REPO
    from lift_gl.scene.loader import load_scene
    scene = load_scene(REPO / "scenes" / "showcase.toml")
    images = []
    for features in (None, SceneFeatures.everything()):
        r = Renderer(scene, size=(24, 16), seed=4, features=features)
        images.append(r.render(spp=2))
        r.release()
    assert np.array_equal(images[0], images[1])
