"""denoiser="glsl" in the renderer stays on the GPU (lift_gl/passes/net_denoise.py): its result
equals the readback road (the mean and guides read back, GlslDenoiser.denoise in numpy, as
DenoisePass._run_numpy did) within denoiser_bound, the float32 rounding bound that
tests/test_glsl_net.py derives for the network and its output transform; and a frame with
denoise="every" reads nothing back."""
from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np
import pytest

pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")

from lift_gl.frame import guides, guides_done  # noqa: E402
from lift_gl.frame_settings import DenoiseSettings  # noqa: E402
from lift_gl.renderer import Renderer  # noqa: E402
from lift_gl.scene.loader import load_scene  # noqa: E402
from test_glsl_net import SHIPPED, denoiser_bound  # noqa: E402

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml"
SIZE = (37, 29)  # odd: padded to 48x32, cropped back


@pytest.fixture(scope="module")
def renderer():
    if not SHIPPED.is_file():
        pytest.skip(f"{SHIPPED} is absent (trained by lift_gl/denoise/train)")
    r = Renderer(load_scene(SCENE), size=SIZE, seed=5, denoise=DenoiseSettings("every", "glsl"))
    yield r
    r.release()


def read_inputs(renderer, gbuffer):
    """What the readback road hands the numpy denoiser (DenoisePass._run_numpy)."""
    w, h = renderer.size
    albedo = np.frombuffer(gbuffer.albedo.read(), np.float16).reshape(h, w, 4)[::-1, :, :3].astype(np.float32)
    normal = np.frombuffer(gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)[::-1, :, :3]
    return renderer.accumulate.read_mean(), np.ascontiguousarray(albedo), np.ascontiguousarray(normal)


def test_gpu_path_equals_readback_path(renderer):
    renderer.render(spp=2)
    compare_roads(renderer)


def test_picture_smaller_than_an_exposure_block():
    """13x9: one exposure block of the whole picture (model_io.autoexposure's min(16, side))."""
    r = Renderer(load_scene(SCENE), size=(13, 9), seed=2, denoise=DenoiseSettings("final", "glsl"))
    try:
        r.render(spp=1)
        compare_roads(r)
    finally:
        r.release()


def compare_roads(renderer):
    assert renderer.denoise_pass.net is not None  # the GPU road is taken
    gbuffer = guides(renderer)
    renderer.denoise_pass.run(renderer.accumulate, gbuffer)
    got = renderer.denoise_pass.read()
    color, albedo, normal = read_inputs(renderer, gbuffer)
    guides_done(renderer)
    want = renderer.numpy_denoiser.denoise(color, albedo, normal)
    bound = denoiser_bound(color, albedo, normal, want)
    assert got.shape == want.shape == (renderer.size[1], renderer.size[0], 3)
    assert np.abs(want - color).mean() > 1e2 * bound.mean()  # denoising changed far more than the bound (~800x here)
    worst = (np.abs(got - want) / bound).max()
    print(f"largest |GPU - readback| {np.abs(got - want).max():.3g}, {worst:.3g} of the bound; "
          f"outputs up to {want.max():.3g}")
    assert (np.abs(got - want) <= bound).all(), f"worst difference {worst:.3g} x the bound"
    # a flipped row, a shifted pad or a wrong exposure is far outside it
    assert not (np.abs(got[::-1] - want) <= bound).all()


def test_every_frame_reads_nothing_back(renderer, monkeypatch):
    """Reads made while the denoise pass runs (render() itself reads a few counters back at its
    end, with or without a denoiser: those are not the denoiser's)."""
    reads, inside = [], []
    for cls in (moderngl.Texture, moderngl.Buffer, moderngl.TextureArray):
        def counted(self, *args, _original=cls.read, **kwargs):
            if inside:
                reads.append(type(self).__name__)
            return _original(self, *args, **kwargs)
        monkeypatch.setattr(cls, "read", counted)
    denoise_pass = renderer.denoise_pass

    def run(*args, _original=denoise_pass.run):
        inside.append(True)
        try:
            return _original(*args)
        finally:
            inside.pop()
    monkeypatch.setattr(denoise_pass, "run", run)
    runs = renderer.stats.denoise_runs
    renderer.render(spp=2, final=False)
    assert renderer.stats.denoise_runs == runs + 2  # denoised after each frame ...
    assert reads == []  # ... without a readback
    # the counter sees the readback road's reads (the check can fail)
    inside.append(True)
    denoise_pass._run_numpy(renderer.accumulate, guides(renderer))
    guides_done(renderer)
    assert len(reads) >= 3
    monkeypatch.undo()
    assert np.isfinite(denoise_pass.read()).all()
