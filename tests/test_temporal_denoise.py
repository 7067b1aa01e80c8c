"""A temporal denoiser model (13 input channels: the previous frame's output and its validity)
on arrays: lift_gl/denoise/model_io.py's input and both executors' `previous`/`valid`."""
from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("onnxruntime")

from lift_gl.denoise.model_io import network_input  # noqa: E402


@pytest.fixture(scope="module")
def temporal_model(tmp_path_factory):
    from lift_gl.denoise.train.export import export
    from lift_gl.denoise.train.model import build_model

    torch.manual_seed(3)
    path = tmp_path_factory.mktemp("temporal") / "rt_temporal.onnx"
    export(build_model("rt", temporal=True).eval(), path, {"steps": 0})
    return path


def _frame(seed, h=21, w=35):
    rng = np.random.default_rng(seed)
    albedo = rng.uniform(0.05, 1.0, (h, w, 3)).astype(np.float32)
    color = (albedo * rng.exponential(1.0, (h, w, 1))).astype(np.float32)
    normal = rng.standard_normal((h, w, 3)).astype(np.float32)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    previous = (albedo * rng.uniform(0.5, 1.5, (h, w, 1))).astype(np.float32)
    return color, albedo, normal, previous


def test_network_input_holds_the_history_where_valid_and_zeros_elsewhere():
    color, albedo, normal, previous = _frame(0)
    valid = np.zeros(color.shape[:2], np.float32)
    valid[:, ::2] = 1.0
    x, exposure = network_input(color, albedo, normal, previous, valid, temporal=True)
    assert x.shape == (1, 13) + color.shape[:2]
    plain, same_exposure = network_input(color, albedo, normal)
    assert exposure == same_exposure and np.array_equal(x[:, :9], plain)  # this frame's exposure, guides as before
    history = x[0, 9:12].transpose(1, 2, 0)
    np.testing.assert_allclose(history[:, ::2], (previous / albedo * np.float32(exposure))[:, ::2], rtol=1e-6)
    assert not history[:, 1::2].any() and np.array_equal(x[0, 12], valid)


@pytest.mark.parametrize("name", ["onnx", "glsl"])
def test_valid_zero_is_the_network_run_with_zeros(temporal_model, name):
    """No history (valid 0 everywhere, or previous and valid absent) is bit for bit the network
    run on zeros in those channels, whatever `previous` holds; a valid history changes it."""
    from lift_gl.denoise import get_denoiser
    from lift_gl.denoise.model_io import network_output

    options = {"providers": ["CPUExecutionProvider"]} if name == "onnx" else {}
    denoiser = get_denoiser(name, model_path=temporal_model, ensemble=1, **options)
    color, albedo, normal, previous = _frame(1)
    zeros = np.zeros(color.shape[:2], np.float32)
    absent = denoiser.denoise(color, albedo, normal)
    ignored = denoiser.denoise(color, albedo, normal, previous=previous, valid=zeros)
    assert np.array_equal(absent, ignored)
    x, exposure = network_input(color, albedo, normal)  # 9 channels, then the 4 zeros by hand
    x = np.concatenate([x, np.zeros((1, 4) + x.shape[2:], np.float32)], axis=1)
    run = denoiser._run_padded if name == "onnx" else denoiser.net.run_numpy
    assert np.array_equal(absent, network_output(run(x), exposure, albedo))
    held = denoiser.denoise(color, albedo, normal, previous=previous, valid=np.ones_like(zeros))
    assert np.abs(held - absent).max() > 1e-4 * np.abs(absent).max()
    if name == "glsl":
        denoiser.release()


# ---- the renderer: the previous frame reprojected on the GPU (passes/net_denoise.py) ----
REPO = __import__("pathlib").Path(__file__).resolve().parent.parent
SIZE = (40, 32)


def _tensor(renderer) -> tuple[np.ndarray, float]:
    """The network's input tensor as the renderer built it: (13, H', W'), rows top-first; the exposure."""
    net_pass = renderer.denoise_pass.net
    w, h = net_pass.padded
    data = np.frombuffer(net_pass.net.input_texture.read(), np.float32).reshape(4, h, w, 4)
    exposure = float(np.frombuffer(net_pass.exposure_buffer.read(4), np.float32)[0])
    return data.transpose(0, 3, 1, 2).reshape(16, h, w)[:13], exposure


def test_renderer_feeds_the_previous_frame_reprojected(temporal_model):
    """denoise every with a temporal model: the first frame has no history (valid 0); after a
    known camera move the history channels are the previous output warped through the camera
    model (an independent projection, as tests/test_temporal.py checks the motion vectors),
    valid exactly where the accumulation's reprojection kept a tap; a reset clears it."""
    import dataclasses
    import math

    from lift_gl.frame_settings import DenoiseSettings
    from lift_gl.passes.camera import frame_jitter
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    r = Renderer(scene, size=SIZE, seed=4, temporal="reproject",
                 denoise=DenoiseSettings("every", "glsl", {"model_path": temporal_model}))
    try:
        w, h = SIZE
        r.render(spp=1, final=False)
        x, _ = _tensor(r)
        assert not x[9:13].any()  # the first frame: no history anywhere
        history = np.frombuffer(r.denoise_pass.net.history.read(), np.float32).reshape(h, w, 4)[..., :3].astype(np.float64)
        assert history.max() > 0
        step = np.array([0.15, 0.0, 0.0])
        old, new = scene.camera, dataclasses.replace(scene.camera, position=scene.camera.position + step,
                                                     target=scene.camera.target + step)
        r.set_camera(new)
        r.render(spp=1, final=False)
        x, exposure = _tensor(r)
        previous, valid = x[9:12, :h, :w][:, ::-1].transpose(1, 2, 0), x[12, :h, :w][::-1]  # rows bottom-up, as GL's

        # where this frame's first hits were in the old camera (tests/test_temporal.py's projection)
        depth = np.frombuffer(r.gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)[..., 3].astype(np.float64)
        jx, jy = frame_jitter(r.frame_index - 1, r.seed)
        ys, xs = np.mgrid[0:h, 0:w]
        right, up, forward = new.basis()
        t = math.tan(math.radians(new.fov_deg) / 2)
        world = new.position + depth[..., None] * (forward + (((xs + jx) / w * 2 - 1) * t * w / h)[..., None] * right
                                                   + (((ys + jy) / h * 2 - 1) * t)[..., None] * up)
        o_right, o_up, o_forward = old.basis()
        rel = world - old.position
        z = np.where(depth > 0, rel @ o_forward, 1.0)
        # the old pixel (texel centres at integers): p + the motion vector test_temporal.py expects
        px = ((rel @ o_right) / (z * t * w / h) * 0.5 + 0.5) * w - jx
        py = ((rel @ o_up) / (z * t) * 0.5 + 0.5) * h - jy
        x0, y0 = np.floor(px).astype(int), np.floor(py).astype(int)
        fx, fy = (px - x0)[..., None], (py - y0)[..., None]
        inside = (depth > 0) & (x0 >= 0) & (y0 >= 0) & (x0 + 1 < w) & (y0 + 1 < h)
        cx, cy = np.clip(x0, 0, w - 2), np.clip(y0, 0, h - 2)
        taps = [history[cy, cx], history[cy, cx + 1], history[cy + 1, cx], history[cy + 1, cx + 1]]
        warp = (taps[0] * (1 - fx) * (1 - fy) + taps[1] * fx * (1 - fy) + taps[2] * (1 - fx) * fy + taps[3] * fx * fy)

        rejected = r.reproject.read_rejection()[::-1].sum(axis=2)  # rows bottom-up
        all_kept = inside & (rejected == 0)
        assert all_kept.mean() > 0.5
        # validity is the reprojection's rule: some tap kept (kept weight above its 1e-3)
        np.testing.assert_array_equal(valid > 0, (depth > 0) & (1 - rejected > 1e-3))
        # the motion vectors match the projection within 2e-3 px (tests/test_temporal.py), so the
        # bilinear warp may differ by that times the taps' spread, plus float32 rounding
        spread = np.max(taps, axis=0) - np.min(taps, axis=0)
        bound = 2e-3 * spread + 1e-5 * np.abs(warp) + 1e-7
        got = previous[all_kept] / exposure
        assert np.all(np.abs(got - warp[all_kept]) <= bound[all_kept]), np.abs(got - warp[all_kept]).max()

        r.reset()  # a camera cut: no history on the next frame
        r.render(spp=1, final=False)
        assert not _tensor(r)[0][9:13].any()
    finally:
        r.release()
