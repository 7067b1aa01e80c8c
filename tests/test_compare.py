"""`lift-gl compare`: configurations and statistics by hand, then whole runs on tiny scenes
whose outputs are checked against independent recomputations (metrics of the written images,
a plain render of the same seed, a direct render of the cached reference)."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from lift_gl import metrics
from lift_gl.cli import main
from lift_gl.errors import LiftError
from lift_gl.frame_settings import DenoiseSettings
from lift_gl.image_io import read_image
from lift_gl.renderer import Renderer
from lift_gl.report.configurations import parse_configurations
from lift_gl.report.progressive import spp_checkpoints, time_checkpoints
from lift_gl.report.reference import REFERENCE_SEED
from lift_gl.report.statistics import log_interval, ratio_interval, time_to_reach
from lift_gl.scene.loader import load_scene

FURNACE = REPO / "scenes" / "furnace.toml"


# ---------------------------------------------------------------- pieces, by hand
def test_configurations():
    configs = parse_configurations("pt,pt:max_depth=3:rr_depth=2,mine", "off", {"pt": {"rr_depth": "5"}})
    assert [c.label for c in configs] == ["pt", "pt:max_depth=3:rr_depth=2", "mine"]
    assert configs[0].params == {"rr_depth": "5"}
    assert configs[1].params == {"rr_depth": "2", "max_depth": "3"}  # the spec's own setting wins
    assert configs[2].params == {} and configs[2].integrator == "mine"
    assert configs[1].file_stem == "pt_max_depth=3_rr_depth=2"


@pytest.mark.parametrize("integrators, denoise, words", [
    ("pt,,bdpt", "off", "empty"),
    ("pt:max_depth", "off", "NAME=VALUE"),
    (":max_depth=3", "off", "no plugin name"),
    ("pt,pt", "off", "more than once"),
    ("pt", "off,,final", "empty"),
    ("pt", "sometimes", "unknown mode"),
])
def test_bad_configurations(integrators, denoise, words):
    with pytest.raises(LiftError, match=words):
        parse_configurations(integrators, denoise)


def test_checkpoints():
    assert spp_checkpoints(1) == [1]
    assert spp_checkpoints(100) == [1, 2, 4, 8, 16, 32, 64, 100]
    assert spp_checkpoints(16, per_doubling=2) == [1, 2, 3, 4, 6, 8, 11, 16]
    times = time_checkpoints(8.0, decades=1)  # 8 s down to 0.8 s: 8 / 2^k for k = 4 .. 0
    assert times == [0.5, 1.0, 2.0, 4.0, 8.0]


def test_time_to_reach_by_hand():
    times, errors = [1.0, 2.0, 4.0], [0.4, 0.1, 0.05]
    # Between (1, 0.4) and (2, 0.1) on log-log axes: log error falls by 2 log 2 per log 2 of
    # time, so error 0.2 (one log 2 below 0.4) is reached at 2^(1/2) s.
    assert time_to_reach(times, errors, 0.2) == pytest.approx(math.sqrt(2))
    assert time_to_reach(times, errors, 0.1) == pytest.approx(2.0)
    assert time_to_reach(times, errors, 0.5) == 1.0       # there at the first checkpoint
    assert time_to_reach(times, errors, 0.01) == math.inf  # never


def test_intervals_by_hand():
    # Geometric mean of 1, 4, 16 is 4; log values 0, 2 ln 2, 4 ln 2 have sd 2 ln 2;
    # the 95% t quantile with 2 degrees of freedom is 4.302653.
    interval = log_interval([1.0, 4.0, 16.0])
    half = 4.302653 * 2 * math.log(2) / math.sqrt(3)
    assert interval.mean == pytest.approx(4.0)
    assert interval.lo == pytest.approx(4.0 * math.exp(-half), rel=1e-5)
    assert interval.hi == pytest.approx(4.0 * math.exp(half), rel=1e-5)
    assert log_interval([2.0]).lo == log_interval([2.0]).hi == 2.0
    assert log_interval([1.0, math.inf]).mean == math.inf
    ratio = ratio_interval([2.0, 2.0, 2.0], [1.0, 1.0, 1.0])
    assert (ratio.mean, ratio.lo, ratio.hi) == pytest.approx((2.0, 2.0, 2.0))
    assert ratio_interval([2.0, 8.0], [1.0, 1.0]).mean == pytest.approx(4.0)


# ---------------------------------------------------------------- whole runs
def run_cli(capsys, *args):
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.out, captured.err


SIZE = (24, 24)


@pytest.fixture(scope="module")
def furnace_reference(tmp_path_factory):
    """An independent pt render (another seed, 16x the compare budget) as the reference file."""
    r = Renderer(load_scene(FURNACE), size=SIZE, seed=99)
    image = r.render(spp=256)
    assert r.stats.dropped_samples == 0
    r.release()
    path = tmp_path_factory.mktemp("ref") / "reference.npy"
    np.save(path, image)
    return path


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_compare_equal_spp(capsys, tmp_path, furnace_reference):
    out = tmp_path / "cmp"
    code, stdout, err = run_cli(capsys, "compare", FURNACE, "--integrators", "pt,pt:max_depth=0", "--spp", 16,
                                "--seeds", 2, "--size", "24x24", "--ref", furnace_reference, "--out", out)
    assert code == 0, err
    for name in ("metrics.csv", "convergence.png", "convergence.svg", "contact_sheet.png", "report.md",
                 "summary.json", "images/pt.exr", "images/pt_max_depth=0.exr", "images/reference.exr"):
        assert (out / name).is_file(), name
    rows = read_csv(out / "metrics.csv")
    assert len(rows) == 2 * 2 * 5  # configurations x seeds x checkpoints (1, 2, 4, 8, 16 spp)
    for label in ("pt", "pt:max_depth=0"):
        for seed in ("1", "2"):
            run = [r for r in rows if r["configuration"] == label and r["seed"] == seed]
            assert [int(r["spp"]) for r in run] == [1, 2, 4, 8, 16]
            render = [float(r["render_seconds"]) for r in run]
            assert render == sorted(render) and all(float(r["wall_seconds"]) >= s for r, s in zip(run, render))
            assert all(r["dropped_samples"] == "0" for r in run)
    # The written image is what a plain render of the same seed gives: checkpoints do not change it.
    written = read_image(out / "images" / "pt.exr")
    plain = Renderer(load_scene(FURNACE), size=SIZE, seed=1)
    np.testing.assert_array_equal(written, plain.render(spp=16))
    plain.release()
    # The CSV's metrics are those of that image against the reference file.
    reference = np.load(furnace_reference)
    last = next(r for r in rows if r["configuration"] == "pt" and r["seed"] == "1" and r["spp"] == "16")
    assert float(last["rel_mse"]) == pytest.approx(metrics.rel_mse(written, reference), rel=1e-5)
    assert float(last["dssim"]) == pytest.approx(metrics.dssim(written, reference), rel=1e-5)
    # pt's error against an independent render is noise: relMSE / its estimate is about
    # 1 + 16/256 (the reference's own noise), give or take the estimates' ~10% scatter.
    # max_depth=0 shows the sphere black (emission only): its error is bias, which the
    # estimate does not see.
    final = json.loads((out / "summary.json").read_text())["final"]
    noise_share = {label: f["rel_mse"]["mean"] / f["est_rel_mse"]["mean"] for label, f in final.items()}
    assert 0.5 < noise_share["pt"] < 2 and noise_share["pt:max_depth=0"] > 10, noise_share
    report = (out / "report.md").read_text()
    assert "## Verdict" in report and "reaches relMSE" in report and "convergence.png" in report
    assert "pt:max_depth=0" in report and "reaches DSSIM" in report


def test_compare_denoise_modes(capsys, tmp_path, furnace_reference):
    """--denoise off,final,every: three configurations; final and every end on the same
    accumulation, so on the same denoised image, the one a plain final-mode render gives;
    the report marks both as biased."""
    out = tmp_path / "cmp"
    code, stdout, err = run_cli(capsys, "compare", FURNACE, "--denoise", "off,final,every", "--denoiser", "atrous",
                                "--spp", 8,
                                "--seeds", 1, "--size", "24x24", "--ref", furnace_reference, "--out", out)
    assert code == 0, err
    rows = read_csv(out / "metrics.csv")
    assert sorted({r["configuration"] for r in rows}) == ["pt", "pt+denoise=every:atrous", "pt+denoise=final:atrous"]
    final = read_image(out / "images" / "pt+denoise=final_atrous.exr")
    np.testing.assert_array_equal(final, read_image(out / "images" / "pt+denoise=every_atrous.exr"))
    plain = Renderer(load_scene(FURNACE), size=SIZE, seed=1, denoise=DenoiseSettings("final", "atrous"))
    np.testing.assert_array_equal(final, plain.render(spp=8))
    plain.release()
    noisy = read_image(out / "images" / "pt.exr")
    assert not np.array_equal(final, noisy)
    report = (out / "report.md").read_text()
    assert "**BIASED** `pt+denoise=final:atrous`" in report and "**BIASED** `pt+denoise=every:atrous`" in report
    assert "**BIASED** `pt`:" not in report


def test_compare_equal_time(capsys, tmp_path, furnace_reference):
    out = tmp_path / "cmp"
    code, stdout, err = run_cli(capsys, "compare", FURNACE, "--time", 0.25, "--seeds", 1, "--size", "24x24",
                                "--ref", furnace_reference, "--flip", "--out", out)
    assert code == 0, err
    rows = read_csv(out / "metrics.csv")
    assert all(0 < float(r["flip"]) < 1 for r in rows)
    assert "| FLIP |" in (out / "report.md").read_text()
    render = [float(r["render_seconds"]) for r in rows]
    spp = [int(r["spp"]) for r in rows]
    assert len(rows) >= 2 and render == sorted(render) and spp == sorted(set(spp))
    assert render[-1] >= 0.25


def test_compare_pt_with_hybrid_writes_its_report(capsys, tmp_path, furnace_reference):
    """The reduced-resolution `hybrid` plugin (two more passes, a `[reduced]` manifest) runs
    under compare like any plugin. In the furnace all light is direct (nothing leaving the
    convex sphere comes back), so hybrid's filtered indirect half is zero and, like pt, its
    error against the reference is noise: relMSE over its own estimate is near 1."""
    out = tmp_path / "cmp"
    code, stdout, err = run_cli(capsys, "compare", FURNACE, "--integrators", "pt,hybrid:indirect_scale=4",
                                "--spp", 16, "--seeds", 2, "--size", "24x24", "--ref", furnace_reference,
                                "--out", out)
    assert code == 0, err
    for name in ("metrics.csv", "convergence.png", "contact_sheet.png", "report.md", "summary.json",
                 "images/hybrid_indirect_scale=4.exr"):
        assert (out / name).is_file(), name
    rows = [r for r in read_csv(out / "metrics.csv") if r["configuration"] == "hybrid:indirect_scale=4"]
    assert sorted({int(r["spp"]) for r in rows}) == [1, 2, 4, 8, 16] and len(rows) == 10
    assert all(r["dropped_samples"] == "0" for r in rows)
    # The written image is a plain hybrid render of the same seed.
    plain = Renderer(load_scene(FURNACE), size=SIZE, seed=1, integrator="hybrid", params={"indirect_scale": 4})
    np.testing.assert_array_equal(read_image(out / "images" / "hybrid_indirect_scale=4.exr"), plain.render(spp=16))
    plain.release()
    final = json.loads((out / "summary.json").read_text())["final"]
    share = final["hybrid:indirect_scale=4"]["rel_mse"]["mean"] / final["hybrid:indirect_scale=4"]["est_rel_mse"]["mean"]
    assert 0.5 < share < 2, share
    report = (out / "report.md").read_text()
    assert "## Verdict" in report and "`hybrid:indirect_scale=4`" in report


def test_reference_is_rendered_once_then_read_from_the_cache(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("LIFT_GL_CACHE_DIR", str(tmp_path / "cache"))
    args = ["compare", FURNACE, "--spp", 2, "--seeds", 1, "--size", "16x16", "--out", tmp_path / "cmp"]
    code, first, err = run_cli(capsys, *args, "--ref-spp", 8)
    assert code == 0, err
    assert "reference: pt, 8 spp\n" in first
    code, second, err = run_cli(capsys, *args, "--ref-spp", 8)
    assert code == 0 and "reference: pt, 8 spp (cached)" in second
    cached = list((tmp_path / "cache" / "references").glob("*.npy"))
    assert len(cached) == 1
    # The cached file is a pt render of the reference seed: render it directly.
    r = Renderer(load_scene(FURNACE), size=(16, 16), seed=REFERENCE_SEED)
    np.testing.assert_array_equal(np.load(cached[0]), r.render(spp=8))
    r.release()
    # Other settings, another reference.
    code, third, err = run_cli(capsys, *args, "--ref-spp", 4)
    assert code == 0 and "(cached)" not in third
    assert len(list((tmp_path / "cache" / "references").glob("*.npy"))) == 2


@pytest.mark.parametrize("extra, words", [
    (["--denoise", "final,sometimes"], "unknown mode 'sometimes'"),
    (["--denoise", "final", "--denoiser", "bm3d"], "invalid choice: 'bm3d'"),
    (["--integrators", "pt:max_dept=3"], "'max_dept'"),
    (["--integrators", "nosuchplugin"], "no plugin named 'nosuchplugin'"),
    (["--seeds", "0"], "--seeds"),
])
def test_bad_input_is_one_clear_error(capsys, tmp_path, extra, words):
    code, _, err = run_cli(capsys, "compare", FURNACE, "--spp", 2, "--size", "8x8", "--out", tmp_path / "cmp", *extra)
    assert code == 2
    lines = [line for line in err.splitlines() if "error" in line]
    assert len(lines) == 1 and words in lines[0], err


def test_reference_of_another_size_names_the_file(capsys, tmp_path):
    path = tmp_path / "ref.npy"
    np.save(path, np.ones((10, 10, 3), np.float32))
    code, _, err = run_cli(capsys, "compare", FURNACE, "--spp", 2, "--size", "8x8", "--ref", path, "--out", tmp_path / "c")
    assert code == 2 and f"{path}: the reference is 10x10" in err


def test_compare_tells_bias_from_noise(capsys, tmp_path, monkeypatch):
    """A biased configuration (pt:max_depth=0: the sphere black) is marked biased and never the
    winner; a far noisier unbiased one (every sample kept with chance 0.05, weighted 20x) is
    consistent. Against a rendered reference, whose own noise comes from its halves."""
    monkeypatch.setenv("LIFT_GL_CACHE_DIR", str(tmp_path / "cache"))
    noisy = Path(__file__).resolve().parent.parent / "examples" / "grading" / "class" / "hank"
    out = tmp_path / "cmp"
    code, stdout, err = run_cli(capsys, "compare", FURNACE, "--integrators", f"pt,pt:max_depth=0,{noisy}:keep=0.05",
                                "--spp", 32, "--seeds", 2, "--size", "24x24", "--ref-spp", 256, "--out", out)
    assert code == 0, err
    summary = json.loads((out / "summary.json").read_text())
    c = summary["consistency"]
    assert c["pt"]["consistent_with_reference"] is True
    assert c[f"{noisy}:keep=0.05"]["consistent_with_reference"] is True
    assert c["pt:max_depth=0"]["consistent_with_reference"] is False and c["pt:max_depth=0"]["bias_z"] < -10
    for v in summary["verdicts"]:
        assert v["winner"] != "pt:max_depth=0"
    report = (out / "report.md").read_text()
    assert "**BIASED** `pt:max_depth=0` (the bias test" in report
    assert f"**BIASED** `{noisy}" not in report


def test_a_bound_is_printed_as_a_bound():
    """A target met at a run's first checkpoint gives an upper bound on its time, so a ratio
    against it is a bound too."""
    from lift_gl.report.summary import verdict

    def run(errors, times=(1.0, 2.0, 4.0)):
        return [{"render_seconds": t, "rel_mse": e} for t, e in zip(times, errors)]

    runs = {"fast": [run([0.01, 0.005, 0.002])] * 2, "slow": [run([0.2, 0.1, 0.05])] * 2}
    v = verdict(runs, "rel_mse", target=0.05)
    assert v.winner == "fast"
    assert "at most 1 s" in v.sentence() and "at least 4.00× as long" in v.sentence()
    biased = verdict(runs, "rel_mse", target=0.05, consistent={"fast": False, "slow": True})
    assert biased.winner == "slow" and "**biased**" in biased.sentence()


def test_pixel_variance_is_in_image_row_order(tmp_path):
    """The furnace's sphere in the top half, sky (which has no variance at all) below: the
    variance of each pixel's mean that the bias test reads (from the accumulation, which keeps
    row 0 at the bottom) must be zero where the seeds' images do not vary, and not elsewhere."""
    from lift_gl.report.bias import pixel_variance

    scene = tmp_path / "high_sphere.toml"
    scene.write_text(FURNACE.read_text().replace("target = [0, 0, 0]", "target = [0, -0.9, 0]"))
    r = Renderer(load_scene(scene), size=(32, 32), seed=1)
    images = []
    for seed in range(1, 5):
        r.reset(seed=seed)
        images.append(r.render(spp=8))
    variance = pixel_variance(r)
    r.release()
    varies = np.ptp(np.stack(images), axis=0).max(axis=-1) > 0
    assert varies[:8].mean() > 0.5 and not varies[-8:].any()  # the sphere above, the sky below
    noisy = variance[..., 3] > 0
    assert not (noisy & ~varies).any()   # no variance where the seeds never differ (the sky)
    assert (noisy == varies).mean() > 0.95  # (an edge pixel one seed's frames all saw the same way: none)
