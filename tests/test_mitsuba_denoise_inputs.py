"""benchmarks/mitsuba_denoise_inputs.py: Mitsuba 3's renders as the denoisers' input (needs the
mitsuba package, not a dependency of lift-gl, and ../shared's references)."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from conftest import REPO

mi = pytest.importorskip("mitsuba", reason="pip install mitsuba: the same-input test's renderer")
CBOX = REPO.parent / "shared" / "refs" / "mitsuba" / "cbox"


def _module():
    spec = importlib.util.spec_from_file_location("mitsuba_denoise_inputs", REPO / "benchmarks" / "mitsuba_denoise_inputs.py")
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def test_views_are_mitsubas_render_with_its_guides():
    if not CBOX.exists():
        pytest.skip(f"{CBOX}: ../shared is not here")
    reference = np.load(CBOX / "reference.npy")
    arrays = _module().scene_arrays("cbox", CBOX / "scene.xml", reference, seed=1)
    assert {f"cbox/{k}{s}" for k in ("noisy", "albedo", "normal") for s in (1, 4, 16)} <= set(arrays)
    noisy16 = arrays["cbox/noisy16"].astype(np.float32)
    assert noisy16.shape == reference.shape and np.isfinite(noisy16).all()
    # Mitsuba's own estimate: its mean is the reference's within a few per cent at 16 spp
    assert abs(noisy16.mean() / reference.mean() - 1.0) < 0.05
    albedo = arrays["cbox/albedo4"].astype(np.float32)
    assert albedo.min() >= 0.0 and albedo.max() <= 1.0 and albedo.mean() > 0.1
    n = np.linalg.norm(arrays["cbox/normal4"].astype(np.float32), axis=-1)
    assert np.median(n) == pytest.approx(1.0, abs=0.01)
