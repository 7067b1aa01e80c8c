"""lift_gl.notebook without a notebook: the PNG a cell shows, the widget's render thread
(its own GL context beside the main thread's), and what `import lift_gl` leaves unimported."""
from __future__ import annotations

import io
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

from lift_gl import load_scene
from lift_gl.notebook import Image
from lift_gl.tonemap import to_srgb8

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def decode(png: bytes) -> np.ndarray:
    return np.asarray(PILImage.open(io.BytesIO(png)).convert("RGB"))


def test_image_shows_the_tone_mapped_array():
    rng = np.random.default_rng(1)
    array = rng.gamma(1.0, 0.5, size=(20, 30, 3)).astype(np.float32)
    shown = decode(Image(array, exposure=1.0, tonemap="reinhard")._repr_png_())
    assert np.array_equal(shown, to_srgb8(array, 1.0, "reinhard"))
    assert decode(Image(array, scale=3)._repr_png_()).shape == (60, 90, 3)
    with pytest.raises(ValueError):
        Image(np.zeros((4, 4)))


def test_renderer_shows_its_image_so_far():
    from lift_gl import Renderer

    renderer = Renderer(load_scene(SCENES / "cornell_diffuse.toml"), size=(32, 24))
    assert renderer._repr_png_() is None            # nothing rendered: the text form
    renderer.render(spp=4, progress=True)           # a terminal bar here (not a kernel)
    shown = decode(renderer._repr_png_())
    assert shown.shape == (24, 32, 3) and np.array_equal(shown, renderer.display())
    assert shown.std() > 5
    renderer.release()


def test_viewer_renders_on_its_own_thread_and_orbits():
    pytest.importorskip("anywidget", reason="the notebook extra is not installed (pip install 'lift-gl[notebook]')")
    from lift_gl import Renderer
    from lift_gl.notebook import Viewer

    scene = load_scene(SCENES / "cornell_diffuse.toml")
    main = Renderer(scene, size=(32, 32))           # the main thread's context, made first
    first = main.render(spp=2)
    view = Viewer(scene, size=(32, 32), spp=8)

    def settled(previous: bytes = b"", timeout: float = 120):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if view.samples >= 8 and view.frame and view.frame != previous:
                return view.frame
            time.sleep(0.05)
        raise AssertionError(f"no full frame: {view.samples} spp, status {view.status!r}")

    try:
        before = settled()
        view.orbit(40, 0)
        after = settled(before)
        a, b = (decode(f).astype(float) for f in (before, after))
        assert a.std() > 5 and np.abs(a - b).mean() > 3
        view.spp = 12                               # more samples: it goes on from 8
        deadline = time.monotonic() + 60
        while view.samples < 12 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert view.samples == 12
    finally:
        view.close()
    assert not view.thread.alive
    main.reset(seed=0)
    assert np.array_equal(main.render(spp=2), first)   # the main thread's renderer unharmed


def test_import_lift_gl_loads_no_notebook_or_cluster_package():
    code = ("import sys, lift_gl, lift_gl.cli, lift_gl.notebook, lift_gl.cluster.options; "
            "print([m for m in ('ray', 'anywidget', 'ipywidgets', 'IPython') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
