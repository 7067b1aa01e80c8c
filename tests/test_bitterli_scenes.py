"""The five Bitterli scenes of ../shared/scenes_bitterli (Mitsuba 0.5 files written by others
for other renderers) load, report exactly what lift-gl can't honour, and render."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from lift_gl.renderer import Renderer
from lift_gl.scene.loader import SceneWarning, load_scene

# What each file asks that lift-gl doesn't do (the files' own oddities included): one
# warning each, at these lines.
EXPECTED = {
    "cornell-box": {4: "<mode>", 7: "sample_num", 8: "delta"},
    "veach-mis": {4: "<mode>", 7: "sample_num", 8: "delta", 16: "<hide>"},
    "veach-bidir": {4: "<mode>", 7: "sample_num", 8: "delta", 105: "<hide>"},
    "staircase2": {},
    "living-room": {132: "mask"},
}
# Triangles, spheres, emissive materials, textures, environment map.
CONTENTS = {
    "cornell-box": (36, 0, 1, 0, False),
    "veach-mis": (52, 3, 3, 0, False),
    "veach-bidir": (11544, 0, 2, 0, False),
    "staircase2": (31407, 0, 13, 3, False),
    "living-room": (143163, 0, 0, 4, True),
}


@pytest.mark.parametrize("name", list(EXPECTED))
def test_bitterli_scene_loads_and_renders(shared_dir, name):
    path = shared_dir / "scenes_bitterli" / name / "scene.xml"
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        scene = load_scene(path)
    messages = [str(w.message) for w in record if issubclass(w.category, SceneWarning)]
    for line, what in EXPECTED[name].items():
        assert sum(f"scene.xml:{line}:" in m and what in m for m in messages) == 1, (line, what, messages)
    assert len(messages) == len(EXPECTED[name]), messages
    triangles, spheres, emitters, textures, envmap = CONTENTS[name]
    assert scene.triangle_count == triangles and len(scene.spheres) == spheres
    assert sum(m.is_emissive for m in scene.materials) == emitters
    assert len(scene.textures) == textures
    assert (scene.environment is not None and scene.environment.image is not None) == envmap
    r = Renderer(scene, size=(16, 9), seed=1)
    image = r.render(spp=2)
    assert r.stats.dropped_samples == 0
    r.release()
    assert np.isfinite(image).all() and image.mean() > 0


def test_veach_bidir_renders_with_bdpt(shared_dir):
    """Veach's bidirectional room, the scene bdpt is for (its equal-time comparison with pt:
    benchmarks/equal_time.py, docs/bdpt.md): glass, a Beckmann lamp shade, light that reaches
    the room only off the shade and the ceiling."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        scene = load_scene(shared_dir / "scenes_bitterli" / "veach-bidir" / "scene.xml")
    r = Renderer(scene, size=(24, 24), integrator="bdpt", seed=1)
    image = r.render(spp=2)
    assert r.stats.dropped_samples == 0 and r.stats.dropped_splats == 0
    r.release()
    assert np.isfinite(image).all() and image.mean() > 0
