"""The denoiser's training side: the scene generator (no torch needed) and, where torch is
installed (the `train` extra), a few steps of training and the export, whose ONNX file must
compute what the torch network computes."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.denoise.train.scenes import TRAIN_SEEDS, VALIDATION_SEEDS, random_scene
from lift_gl.scene.validate import validate_scene


def _fingerprint(scene) -> tuple:
    return (tuple(m.type for m in scene.materials), sum(float(m.positions.sum()) for m in scene.meshes),
            tuple(float(s.radius) for s in scene.spheres), tuple(scene.camera.position))


def test_scenes_are_deterministic_and_valid():
    for seed in (0, 7, VALIDATION_SEEDS[0]):
        a, b = random_scene(seed), random_scene(seed)
        assert _fingerprint(a) == _fingerprint(b)
        validate_scene(a)
        lit = (any(m.is_emissive for m in a.materials) or a.environment is not None or a.distant_lights)
        assert lit, f"scene {seed} has no light"


def test_validation_seeds_are_never_training_seeds():
    assert set(TRAIN_SEEDS).isdisjoint(VALIDATION_SEEDS)


def test_scenes_cover_every_bsdf_family_and_light():
    scenes = [random_scene(seed) for seed in range(40)]
    kinds = {m.type for s in scenes for m in s.materials}
    assert {"diffuse", "conductor", "dielectric", "plastic"} <= kinds
    assert any(m.alpha > 0 and m.type == "conductor" for s in scenes for m in s.materials)
    assert any(m.distribution == "beckmann" and m.alpha > 0 for s in scenes for m in s.materials)
    assert any(m.alpha > 0 and m.type == "dielectric" for s in scenes for m in s.materials)
    assert any(m.texture is not None for s in scenes for m in s.materials)
    assert any(s.environment is not None and s.environment.image is not None for s in scenes)
    assert any(s.distant_lights for s in scenes)
    assert len({_fingerprint(s) for s in scenes}) == len(scenes)


def test_train_export_and_onnx_agree(tmp_path):
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    from lift_gl.denoise.onnx_denoiser import OnnxDenoiser
    from lift_gl.denoise.model_io import network_input
    from lift_gl.denoise.tiling import pad_to_multiple
    from lift_gl.denoise.train.export import export
    from lift_gl.denoise.train.render_data import SPP_LEVELS, example_arrays
    from lift_gl.denoise.train.train import train

    rng = np.random.default_rng(0)
    paths = []
    for i in range(2):  # synthetic examples: the loop and the export are under test, not the data
        ref = rng.uniform(0, 2, (48, 48, 3)).astype(np.float32)
        noisy = [ref * rng.gamma(s, 1 / s, ref.shape).astype(np.float32) for s in SPP_LEVELS]
        albedo = rng.uniform(0, 1, ref.shape).astype(np.float32)
        normal = rng.normal(size=ref.shape).astype(np.float32)
        paths.append(tmp_path / f"ex{i}.npz")
        np.savez(paths[-1], **example_arrays(noisy, albedo, normal, ref))
    result = train(paths[:1], paths[1:], tmp_path, steps=3, batch=2, crop=32, log=lambda m: None)
    assert result["steps"] == 3 and (tmp_path / "checkpoint.pt").is_file()
    resumed = train(paths[:1], paths[1:], tmp_path, steps=4, batch=2, crop=32, log=lambda m: None)
    assert resumed["steps"] == 4  # resumed at step 3, one more step
    # a warm restart at step 4: the warm-up begins again (step 5's LR is 2/200 of the peak, not
    # the 6/200 of the original schedule), as the shipped model's second stage trained
    restarted = train(paths[:1], paths[1:], tmp_path, steps=6, batch=2, crop=32, lr=1e-3, log=lambda m: None,
                      schedule_start=4)
    assert restarted["steps"] == 6 and restarted["resumed_at"] == 4
    last_lr = torch.load(tmp_path / "checkpoint.pt")["optimizer"]["param_groups"][0]["lr"]
    assert last_lr == pytest.approx(1e-3 * 2 / 200)
    model = resumed["model"]
    onnx_path = tmp_path / "model.onnx"
    export(model, onnx_path, {"steps": 4})
    x, _ = network_input(noisy[2][:40, :37], albedo[:40, :37], normal[:40, :37])
    x = pad_to_multiple(x, 16)
    with torch.no_grad():
        expected = model.float().cpu().eval()(torch.from_numpy(x)).numpy()
    d = OnnxDenoiser(onnx_path)
    d._load()
    np.testing.assert_allclose(d._run(x), expected, rtol=1e-4, atol=1e-5 * float(np.abs(expected).max()))


def _digest(seed: int) -> str:
    import hashlib
    s = random_scene(seed)
    parts = [tuple(str(m.type) for m in s.materials), len(s.meshes), len(s.spheres),
             np.round(s.camera.position, 2).tolist(), round(sum(float(m.positions.sum()) for m in s.meshes), 1)]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


def test_generator_still_makes_the_shipped_models_scenes():
    """The shipped weights are reproduced from seeds (assets/denoiser/lift_unet.json): a change
    to the generator that changes a seed's scene breaks that, and must come with new weights."""
    assert {seed: _digest(seed) for seed in (0, 165, 399, 1_000_000)} == {
        0: "b41e57fd79c1d308", 165: "c3eb2a46bee0effc", 399: "45003ee4c82d0531", 1_000_000: "8ecf9c08ccaed2bc"}


def test_log_transform_values_and_gradient():
    """The network's `log` colour transform: the loss's curve in (0 -> 0, eps -> log 2 / log 101,
    1 -> 1), eps * exp(y) out, whose gradient is never zero (a relu there let a network die)."""
    torch = pytest.importorskip("torch")
    from lift_gl.denoise.train.model import LOG_EPS, DenoiseUNet
    model = DenoiseUNet(transform="log")
    t = model._color_in(torch.tensor([0.0, LOG_EPS, 1.0, -3.0]))
    np.testing.assert_allclose(t.numpy(), [0.0, np.log(2) / np.log(101), 1.0, 0.0], atol=1e-6)
    y = torch.tensor([-8.0, -1.0, 0.0, 3.0], requires_grad=True)
    v = model._color_out(y)
    v.sum().backward()
    np.testing.assert_allclose(v.detach().numpy(), LOG_EPS * np.exp(y.detach().numpy()), rtol=1e-6)
    assert bool(torch.all(y.grad > 0))
    with pytest.raises(ValueError, match="transform"):
        DenoiseUNet(transform="pu")


def test_ssim_weight_scales_only_the_ssim_term():
    """denoise_loss(ssim_weight=w) - denoise_loss(ssim_weight=0) is w x (1 - SSIM) of the
    tone-mapped images, SSIM computed here from its definition on a uniform 7x7 window."""
    torch = pytest.importorskip("torch")
    from lift_gl.denoise.train.loss import denoise_loss, tonemap

    g = torch.Generator().manual_seed(0)
    pred, target = torch.rand(2, 3, 20, 24, generator=g), torch.rand(2, 3, 20, 24, generator=g)
    base = denoise_loss(pred, target, ssim_weight=0.0)
    p, t = (torch.clamp(tonemap(x), 0, 1).double() for x in (pred, target))
    windows = lambda x: x.unfold(2, 7, 1).unfold(3, 7, 1).reshape(*x.shape[:2], 14, 18, 49)
    wp, wt = windows(p), windows(t)
    mp, mt = wp.mean(-1), wt.mean(-1)
    vp, vt = ((wp - mp[..., None]) ** 2).mean(-1), ((wt - mt[..., None]) ** 2).mean(-1)
    cov = ((wp - mp[..., None]) * (wt - mt[..., None])).mean(-1)
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    ssim = (((2 * mp * mt + c1) * (2 * cov + c2)) / ((mp ** 2 + mt ** 2 + c1) * (vp + vt + c2))).mean()
    for w in (0.2, 2.0):
        got = float(denoise_loss(pred, target, ssim_weight=w) - base)
        assert got == pytest.approx(w * (1 - float(ssim)), rel=1e-4, abs=1e-6)


def _lag_correlation(residual: np.ndarray, lag: int) -> float:
    """Correlation of the errors of pixels `lag` apart in a row, pooled over rows."""
    return float((residual[..., :-lag] * residual[..., lag:]).mean() / (residual ** 2).mean())


def test_training_inputs_take_each_sampling_and_are_named_by_it():
    """A data set's scenes take the samplings in turn, named by them (independent keeps the
    shipped model's names), and each input carries its sampling's noise: in the furnace (every
    pixel converges to the albedo) coherent sampling's 1-spp errors of neighbours nearly agree,
    interleave2's only two pixels apart, independent sampling's nowhere."""
    from pathlib import Path
    from lift_gl.denoise.train.render_data import SAMPLINGS, example_path, render_views, sampling_of
    from lift_gl.testing import furnace_scene

    order = ("independent", "coherent", "interleave2")
    assert [sampling_of(i, order) for i in range(4)] == ["independent", "coherent", "interleave2", "independent"]
    assert example_path(Path("d"), 7, "independent").name == "scene_0000007.npz"
    assert example_path(Path("d"), 7, "interleave2").name == "scene_0000007_interleave2.npz"
    size, albedo = (64, 64), 0.8
    lag = {}
    for sampling in SAMPLINGS:
        noisy, *_, reference, _ = render_views(furnace_scene(albedo, size=size), size, (1,), 0, seed=3,
                                               sampling=sampling)
        assert reference is None  # ref_spp 0: no target rendered
        residual = noisy[0].mean(axis=-1) - albedo
        lag[sampling] = (_lag_correlation(residual, 1), _lag_correlation(residual, 2))
    # standard error of a correlation over 64 x 63 independent pairs: about 0.016 (one frame of
    # shared numbers has fewer independent groups: the sampler's own tests pool many frames)
    assert abs(lag["independent"][0]) < 0.1 and abs(lag["independent"][1]) < 0.1, lag
    assert lag["coherent"][0] > 0.7, lag
    assert lag["interleave2"][1] > 0.7 and lag["interleave2"][0] < lag["interleave2"][1] - 0.4, lag


@pytest.mark.parametrize("options", [{"passthrough": True}, {"full_res_convs": 2},
                                     {"passthrough": True, "full_res_convs": 2}])
def test_a_grown_unet_starts_as_the_model_it_grew_from(tmp_path, options):
    """plan --init-from M --grow: the new layers start as zero or the identity, so the larger
    model computes M's function (to the passthrough's starting share, sigmoid(-8) = 3.4e-4 of
    the input colour); it exports and runs in onnxruntime as torch computes it."""
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnxruntime")
    from lift_gl.denoise.train.export import export, load_onnx_weights
    from lift_gl.denoise.train.model import build_model

    small = build_model("unet", encoder=(8, 12), bottleneck=16)
    for p in small.parameters():  # away from the initialisation, so that a missed layer shows
        p.data += 0.05 * torch.randn_like(p)
    export(small, tmp_path / "small.onnx", {})
    big = build_model("unet", encoder=(8, 12), bottleneck=16, **options)
    load_onnx_weights(big, tmp_path / "small.onnx", grow=True)
    x = torch.rand(1, 9, 32, 32) * 2
    with torch.no_grad():
        want, got = small.eval()(x), big.eval()(x)
    share = 1 / (1 + np.exp(8.0)) if options.get("passthrough") else 0.0
    bound = share * float((x[:, :3] - want).abs().max()) * 1.01 + 1e-5 * float(want.abs().max())
    assert float((got - want).abs().max()) <= bound
    assert float((got - want).abs().max()) > 0 or not share  # the passthrough did blend
    export(big, tmp_path / "big.onnx", {})
    import onnxruntime as ort
    run = ort.InferenceSession(str(tmp_path / "big.onnx")).run(None, {"input": x.numpy()})[0]
    np.testing.assert_allclose(run, got.numpy(), rtol=1e-4, atol=1e-5 * float(got.abs().max()))
    with pytest.raises(SystemExit, match="architecture"):  # without --grow: refused, as before
        load_onnx_weights(big, tmp_path / "small.onnx")


def test_the_shipped_sidecar_rebuilds_the_shipped_network():
    """assets/denoiser/lift_unet.json's architecture builds the model its .onnx holds (the
    weights load by name and shape): what plan --init-from and a resumed training rely on."""
    pytest.importorskip("torch")
    pytest.importorskip("onnx")
    import json
    from pathlib import Path

    from lift_gl.denoise.train.export import load_onnx_weights
    from lift_gl.denoise.train.model import model_from_arch

    assets = Path(__file__).resolve().parent.parent / "assets" / "denoiser"
    model = model_from_arch(json.loads((assets / "lift_unet.json").read_text())["architecture"])
    load_onnx_weights(model, assets / "lift_unet.onnx")
    assert model.arch["passthrough"] and model.out.out_channels == 4


def test_full_res_convs_is_refused_for_rt_and_grow_needs_a_model(tmp_path, capsys):
    """plan's unet option --full-res-convs on rt, and --grow with no model to grow, are one
    argument error each, before anything is rendered (no torch needed); --passthrough is both
    models'."""
    from lift_gl.denoise.train import plan

    out = ["--out", str(tmp_path / "run")]
    assert plan.arguments(out + ["--model", "rt", "--passthrough"]).passthrough
    for wrong in (["--model", "rt", "--full-res-convs", "2"], ["--grow"]):
        with pytest.raises(SystemExit):
            plan.arguments(out + wrong)
    assert "--grow" in capsys.readouterr().err
    a = plan.arguments(out + ["--model", "unet", "--passthrough", "--grow", "--init-from", "m.onnx"])
    assert a.passthrough and a.grow and a.full_res_convs == 1
