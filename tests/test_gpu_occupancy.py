"""benchmarks/gpu_occupancy.py's probe of the warps an SM holds (docs/gpu.md "How many warps an
SM holds"). Its builtins are NVIDIA's (GL_NV_shader_thread_group); here llvmpipe runs the probe
with them replaced by stand-ins (one SM, warps of 32 invocations of a work group), which checks
its bookkeeping: every warp counted in and out, the summary read from the right words, and a
trace program with the probe rendering the same image as without."""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def _module(name):
    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


occupancy = _module("gpu_occupancy")
sys.modules.setdefault("gpu_occupancy", occupancy)
variants = _module("gpu_pt_variants")


def stand_ins(source: str) -> str:
    """GL_NV_shader_thread_group's builtins replaced for a driver without it: one SM, a warp
    being 32 consecutive invocations of a work group, an SM of 64 warps."""
    source = source.replace("#extension GL_NV_shader_thread_group : require\n", "")
    for name, value in (("gl_ThreadInWarpNV", "(gl_LocalInvocationIndex % 32u)"), ("gl_SMIDNV", "0u"),
                        ("gl_WarpIDNV", "(gl_LocalInvocationIndex / 32u)"), ("gl_WarpsPerSMNV", "64u"),
                        ("gl_SMCountNV", "1u")):
        source = source.replace(name, value)
    return source


def test_summary_reads_the_probe_buffer():
    words = np.zeros(occupancy.OCCUPANCY_WORDS, np.uint32)
    sms = occupancy.OCCUPANCY_SMS
    words[sms + 0], words[sms + 1], words[sms + 5] = 16, 12, 16    # three SMs ran
    words[2 * sms + 1] = 20                                          # a warp slot id + 1
    words[3 * sms], words[3 * sms + 1] = 64, 132
    s = occupancy.occupancy_summary(words)
    assert (s["warps_per_sm_max"], s["warps_per_sm_min"], s["sms_seen"]) == (16, 12, 3)
    assert abs(s["warps_per_sm_mean"] - 44 / 3) < 1e-9
    assert (s["warp_slot_max"], s["warps_per_sm_hw"], s["sm_count"]) == (20, 64, 132)


def test_probe_counts_every_warp_in_and_out(monkeypatch):
    from lift_gl.gl.context import create_context

    ctx = create_context()
    real = occupancy.synthetic_source
    monkeypatch.setattr(occupancy, "synthetic_source", lambda live, local: stand_ins(real(live, local)))
    probe_words = {}
    real_summary = occupancy.occupancy_summary

    def keep(words):
        probe_words["words"] = words.copy()
        return real_summary(words)

    monkeypatch.setattr(occupancy, "occupancy_summary", keep)
    row = occupancy.measure(ctx, live=8, local=64, invocations=1 << 10, iters=4)
    words = probe_words["words"]
    assert not words[:occupancy.OCCUPANCY_SMS].any()          # each warp in was counted out
    assert row["sms_seen"] == 1 and 1 <= row["warps_per_sm_max"] <= 32    # 32 warps in all
    assert row["warp_slot_max"] == 2                           # two warps a work group of 64
    assert (row["warps_per_sm_hw"], row["sm_count"]) == (64, 1)


def test_trace_program_with_the_probe_renders_the_same(monkeypatch, shared_dir, tmp_path):
    real = variants.occupancy

    def probed(edit=None):
        made = real(edit)
        out = lambda text: stand_ins(made(text))  # noqa: E731
        out.local = made.local
        return out

    monkeypatch.setattr(variants, "occupancy", probed)
    out = tmp_path / "occ.json"
    scene = shared_dir / "scenes_lift" / "cornell-box" / "scene.pbrt"
    variants.main([str(scene), "--size", "16x16", "--variants", "base,occ_base", "--reps", "1", "--out", str(out)])
    result = json.loads(out.read_text())["results"][0]["variants"]
    assert result["occ_base"]["max_abs_diff_vs_first"] == 0.0
    assert result["occ_base"]["occupancy"]["warps_per_sm_max"] >= 1
    assert "occupancy" not in result["base"]
