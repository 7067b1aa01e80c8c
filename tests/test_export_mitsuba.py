"""benchmarks/export_mitsuba.py: a lift-gl scene written as Mitsuba 3 XML, read back by
lift-gl's own Mitsuba loader (lift_gl/scene/mitsuba_loader.py), gives the same scene."""
from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene

REPO = Path(__file__).resolve().parent.parent


def _exporter():
    spec = importlib.util.spec_from_file_location("export_mitsuba", REPO / "benchmarks" / "export_mitsuba.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _loaded(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


def test_the_glass_caustic_scene_comes_back_with_its_glass_and_lights(tmp_path):
    scene = _loaded(REPO / "scenes" / "glass_caustic.toml")
    back = _loaded(_exporter().export(scene, tmp_path, (64, 64)))
    glass = [m for m in back.materials if m.type == "dielectric"]
    assert len(glass) == 1 and glass[0].ior == pytest.approx(1.5) and glass[0].alpha == 0
    np.testing.assert_allclose(glass[0].base_color, 1.0)
    emissions = sorted(float(m.emission.max()) for m in back.materials if m.is_emissive)
    assert emissions == pytest.approx([0.04, 150.0])
    assert len(back.spheres) == 1 and back.spheres[0].radius == pytest.approx(0.5)
    assert back.max_depth == scene.max_depth


def test_rough_glass_is_refused_by_name(tmp_path):
    scene = _loaded(REPO / "scenes" / "glass_caustic.toml")
    glass = next(m for m in scene.materials if m.type == "dielectric")
    glass.alpha = 0.2
    with pytest.raises(SystemExit, match=glass.name):
        _exporter().export(scene, tmp_path, (64, 64))
