"""Denoise modes in the Renderer and the CLI: off changes nothing, final denoises once at the
end, every denoises each frame's display; the denoised image is the à-trous filter of the
noisy mean on the unjittered G-buffer guides; missing denoisers give one clear error."""
import sys
from pathlib import Path

import numpy as np
import pytest

from lift_gl.cli import main
from lift_gl.denoise import choose_denoiser, get_denoiser
from lift_gl.denoise.demodulate import safe_albedo
from lift_gl.denoise.variance import LUMINANCE, luminance_variance
from lift_gl.errors import DenoiserError
from lift_gl.frame_settings import DenoiseSettings
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

ATROUS_FINAL = DenoiseSettings("final", "atrous")

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml"
SIZE = (40, 32)


@pytest.fixture(scope="module")
def scene():
    return load_scene(SCENE)


def frame_guides(renderer):
    """The last frame's own G-buffer (jittered), row 0 = top: albedo, normal, depth."""
    w, h = renderer.size
    g = renderer.gbuffer
    albedo = np.frombuffer(g.albedo.read(), np.float16).reshape(h, w, 4)[::-1, :, :3].astype(np.float32)
    nd = np.frombuffer(g.normal_depth.read(), np.float32).reshape(h, w, 4)[::-1]
    return np.ascontiguousarray(albedo), np.ascontiguousarray(nd[..., :3]), np.ascontiguousarray(nd[..., 3])


def expected_denoised(renderer, guides=None) -> np.ndarray:
    """The numpy-level à-trous of the renderer's noisy mean, guides and variance: the same
    filter reached by the other road (numpy demodulation and half-buffer variance, guides
    read back as AOVs, or `guides` given). The numpy interface takes the variance of the
    radiance's luminance and divides it by lum(albedo)^2; the GPU path demodulates the halves'
    gap per channel, so the variance handed over here is the GPU's, times lum(albedo)^2."""
    albedo, normal, depth = guides or (renderer.aov("albedo"), renderer.aov("normal"), renderer.aov("depth")[..., 0])
    divisor = safe_albedo(albedo)
    acc = renderer.accumulate
    variance = luminance_variance(acc.read_totals(), acc.read_half_difference(), divisor[::-1])[::-1]
    variance = variance * np.square(divisor @ LUMINANCE)
    return get_denoiser("atrous", ctx=renderer.ctx).denoise(renderer.noisy_image(), albedo, normal, depth, variance)


def test_off_is_the_renderer_as_before(scene):
    plain = Renderer(scene, size=SIZE, seed=3)
    off = Renderer(scene, size=SIZE, seed=3, denoise="off")
    a, b = plain.render(spp=3), off.render(spp=3)
    assert a.tobytes() == b.tobytes()
    assert plain.display().tobytes() == off.display().tobytes()
    assert off.denoise_pass is None and "denoise" not in [p.name for p in off.passes]
    assert "denois" not in off.stats.summary() and "BIASED" not in off.explain()
    assert not [line for line in off.explain().splitlines() if line.strip().startswith("denoise")]
    for r in (plain, off):
        r.release()


def test_final_denoises_once_at_the_end(scene):
    off = Renderer(scene, size=SIZE, seed=3)
    final = Renderer(scene, size=SIZE, seed=3, denoise=ATROUS_FINAL)
    noisy = off.render(spp=4)
    # Samples added without the final step: nothing is denoised yet, the mean is shown.
    partial = final.render(spp=2, final=False)
    assert final.stats.denoise_runs == 0 and not final.denoised_current
    assert partial.tobytes() == final.noisy_image().tobytes()
    denoised = final.render(spp=2)
    assert final.stats.denoise_runs == 1 and final.denoised_current
    # The accumulation is untouched by the denoiser: the noisy mean is the off renderer's.
    assert final.noisy_image().tobytes() == noisy.tobytes()
    assert not np.array_equal(denoised, noisy)
    np.testing.assert_allclose(denoised, expected_denoised(final), rtol=1e-4, atol=1e-6)
    # Display: the denoised image; its noisy twin is the off renderer's display.
    assert final.display(source="noisy").tobytes() == off.display().tobytes()
    assert final.display().tobytes() != off.display().tobytes()
    assert "BIASED" in final.explain() and "BIASED" in final.stats.summary()
    for r in (off, final):
        r.release()


def test_every_denoises_each_frame(scene):
    """After each frame, on the frame's own G-buffer as its guides (no second G-buffer)."""
    every = Renderer(scene, size=SIZE, seed=3, denoise=DenoiseSettings("every", "atrous"), timers=True)
    assert "guides from the frame's own G-buffer" in every.explain()
    for frame in range(1, 4):
        image = every.render(spp=1, final=False)  # "every" does not wait for a final step
        assert every.stats.denoise_runs == frame and every.denoised_current
        np.testing.assert_allclose(image, expected_denoised(every, frame_guides(every)), rtol=1e-4, atol=1e-6)
        assert every.display().tobytes() != every.display(source="noisy").tobytes()
    assert every.stats.pass_ms.get("denoise", 0.0) > 0.0
    # A render() that ends a final image denoises it on guides through the pixel centres, as
    # final does: the same image as a final-mode renderer's.
    final = Renderer(scene, size=SIZE, seed=3, denoise=ATROUS_FINAL, ctx=every.ctx)
    every.reset()
    np.testing.assert_array_equal(every.render(spp=3), final.render(spp=3))
    final.release()
    every.release()


def test_bad_mode_and_unknown_denoiser(scene):
    with pytest.raises(DenoiserError, match="mode"):
        Renderer(scene, size=SIZE, denoise="sometimes")
    with pytest.raises(DenoiserError, match="atrous"):
        get_denoiser("bm3d")


def test_missing_oidn_is_one_clear_error(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # as if the oidn extra were not installed
    with pytest.raises(DenoiserError, match=r"pip install 'lift-gl\[oidn\]'"):
        get_denoiser("oidn")
    code = main(["render", str(SCENE), "--spp", "1", "--size", "8x8", "--denoise", "final", "--denoiser", "oidn",
                 "--out", str(tmp_path / "x.npy")])
    err = capsys.readouterr().err
    assert code == 2 and "pyoidn" in err and "Traceback" not in err
    assert not (tmp_path / "x.npy").exists()


def test_missing_onnx_model_module_is_one_clear_error(monkeypatch):
    """Until lift_gl/denoise/onnx_denoiser.py lands (or where it is removed), asking for the
    onnx denoiser names what is missing instead of crashing."""
    monkeypatch.setitem(sys.modules, "lift_gl.denoise.onnx_denoiser", None)
    with pytest.raises(DenoiserError, match="onnx"):
        get_denoiser("onnx")


def test_glsl_without_onnx_is_one_clear_error(monkeypatch):
    """The glsl denoiser reads its model with the onnx package: without it, get_denoiser names
    the package at once, not at the first frame."""
    monkeypatch.setitem(sys.modules, "onnx", None)
    with pytest.raises(DenoiserError, match="pip install onnx"):
        get_denoiser("glsl")


def test_oidn_when_installed(scene):
    pytest.importorskip("pyoidn", reason="the oidn extra (pyoidn) is not installed: pip install 'lift-gl[oidn]'")
    reference = Renderer(scene, size=SIZE, seed=9)
    clean = reference.render(spp=256)
    r = Renderer(scene, size=SIZE, seed=1, denoise=DenoiseSettings("final", "oidn"))
    denoised = r.render(spp=4)
    noisy = r.noisy_image()
    err = lambda x: float(np.mean((x - clean) ** 2))  # noqa: E731
    assert np.isfinite(denoised).all() and err(denoised) < err(noisy)
    for x in (reference, r):
        x.release()


def test_cli_writes_denoised_and_noisy(tmp_path, capsys):
    out, noisy = tmp_path / "d.npy", tmp_path / "n.npy"
    code = main(["render", str(SCENE), "--spp", "2", "--size", "24x16", "--denoise", "final",
                 "--out", str(out), "--noisy-out", str(noisy)])
    text = capsys.readouterr().out
    chosen = choose_denoiser("final", software_gl=True)[0]  # --denoiser auto, on llvmpipe
    assert code == 0 and f"denoised ({chosen}, final frame, 1 run" in text and "BIASED" in text
    d, n = np.load(out), np.load(noisy)
    assert d.shape == n.shape == (16, 24, 3) and not np.array_equal(d, n)
    record = (tmp_path / "d.npy.json").read_text()
    assert '"denoise": "final"' in record and '"biased"' in record


def test_auto_chooses_the_network_for_the_final_image_and_per_device_for_every_frame(scene, monkeypatch):
    """denoiser auto: the final image gets the trained network (onnxruntime), every frame the
    network in GLSL on a GPU and the à-trous filter on a CPU rasterizer; without onnxruntime
    the final image falls back; --explain says which and why."""
    pytest.importorskip("onnxruntime")
    assert choose_denoiser("final", software_gl=True)[0] == "onnx"
    assert choose_denoiser("final", software_gl=False)[0] == "onnx"
    assert choose_denoiser("every", software_gl=True)[0] == "atrous"
    assert choose_denoiser("every", software_gl=False)[0] == "glsl"
    r = Renderer(scene, size=SIZE, seed=3, denoise="final")
    assert r.denoiser == "onnx" and "denoiser auto: the final image: the trained network" in r.explain()
    r.set_denoise(mode="every")   # auto again, for the new mode
    assert r.denoiser == "atrous" and "every frame on a CPU rasterizer" in r.explain()
    r.set_denoise(denoiser="glsl")  # named: kept across modes
    r.set_denoise(mode="final")
    assert r.denoiser == "glsl" and "denoiser auto" not in r.explain()
    r.release()
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "onnxruntime" else real(name, *a))
    assert choose_denoiser("final", software_gl=True) == (
        "atrous", "the final image: the trained network needs onnxruntime (pip install 'lift-gl[denoise]')")
    assert choose_denoiser("final", software_gl=False)[0] == "glsl"
    with pytest.raises(DenoiserError, match="name"):
        DenoiseSettings("final", "auto", {"iterations": 3})
