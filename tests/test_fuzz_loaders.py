"""Bad input never escapes: every loader (tests/fuzz_harness.py TARGETS), fed files built from
its format's structure and then broken (tests/fuzz_strategies.py) and mutated corpus seeds
(tests/fuzz_corpus.py), either loads something sound or refuses the input with one LiftError
naming the file, within the harness's time and memory limits. Here a derandomized sample of
each (a few seconds a loader) and every corpus case once; benchmarks/fuzz_loaders.py runs
10,000 cases a loader and counts them."""
from __future__ import annotations

import pytest
from hypothesis import HealthCheck, Phase, given, settings

from fuzz_corpus import KNOWN_ESCAPES, OPEN, SEEDS, known_escape
import fuzz_harness
from fuzz_harness import BY_NAME, TARGETS, Case, Escape, Target, check_case
from lift_gl.errors import SceneError

# Examples a target: a few seconds each on the project's shared 2-core machine.
EXAMPLES = {"TOML scene": 40, "pbrt scene": 40, "Mitsuba XML scene": 40, "glTF scene": 40, "OBJ mesh": 50,
            "PLY mesh": 60, "texture image": 50, "environment map": 50, "reference image": 60,
            "camera path": 60, "plugin manifest": 50}


@pytest.mark.parametrize("target", TARGETS, ids=lambda t: t.name)
def test_fuzzed_inputs_load_or_are_refused_cleanly(target, tmp_path):
    counts = {"loaded": 0, "refused": 0, "refused, no line": 0, "known escape": 0}
    escapes = []

    @settings(max_examples=EXAMPLES[target.name], derandomize=True, deadline=None, database=None,
              phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(case=target.strategy())
    def fuzz(case):
        try:
            counts[check_case(target, case, tmp_path).kind] += 1
        except Escape as escape:
            if known_escape(target.name, escape):
                counts["known escape"] += 1
            else:
                escapes.append(f"{escape} <- {case.describe()}")

    fuzz()
    assert not escapes, f"{len(escapes)} escaped:\n" + "\n".join(escapes[:5])
    # The sample reaches both sides: the inputs are neither all harmless nor all fatal.
    assert counts["loaded"] > 0 and counts["refused"] + counts["refused, no line"] > 0, counts


def _check_expectation(seed, outcome) -> None:
    if seed.expect == "loads":
        assert outcome.kind == "loaded", outcome.message
    elif seed.expect == "refused":
        assert outcome.kind != "loaded", "loaded, but must be refused"
    elif seed.expect == "warns":
        assert outcome.kind != "loaded" or outcome.warned, "loaded without a warning"
    said = outcome.message if outcome.kind != "loaded" else outcome.first_warning
    if seed.line is not None:
        assert f":{seed.line}: " in said, f"must name line {seed.line}: {said}"
    if seed.mentions is not None:
        assert seed.mentions in said, f"must mention {seed.mentions!r}: {said}"


def _marked(seed):
    if seed.name in OPEN:
        return pytest.param(seed, marks=pytest.mark.xfail(strict=True, reason=OPEN[seed.name]))
    return seed


@pytest.mark.parametrize("seed", [_marked(s) for s in SEEDS], ids=lambda s: s.name)
def test_corpus_case(seed, tmp_path):
    """Each seed of the corpus as it is: the fuzzer's property, and what the case must give
    (issue 32's cases: loads, refused, a warning, the line named)."""
    outcome = check_case(BY_NAME[seed.target], seed.case(), tmp_path)
    _check_expectation(seed, outcome)


def test_known_and_open_lists_name_real_targets_and_cases():
    for target, kind, _pattern, _who in KNOWN_ESCAPES:
        assert target in BY_NAME and kind in Escape.KINDS
    assert set(OPEN) <= {s.name for s in SEEDS}


def _no_check(result, path):
    pass


def _internal(path):
    err = SceneError("could not read this file (unexpected KeyError)", path)
    err.internal = True
    raise err


def _spin(path):
    while True:
        pass


def _blocked(path):
    import time
    time.sleep(60)


def _hold_two_gib(path):
    import numpy as np
    return np.ones(1 << 31, np.uint8)


def _print(path):
    import os
    os.write(2, b"Warning: something a C library says\n")


def _print_in_python(path):
    print("Warning: something a binding prints")


def _nan_camera(path):
    from lift_gl.scene.model import Camera
    fuzz_harness.check_camera(Camera(position=[0, 0, 0], target=[0, 1, 0]))


@pytest.mark.parametrize("load, kind", [
    (lambda path: {}["x"], "exception"), (_internal, "internal"),
    (lambda path: (_ for _ in ()).throw(SceneError("no file named")), "unclear"),
    (lambda path: (_ for _ in ()).throw(SceneError("two\nlines", path)), "unclear"),
    (_spin, "hang"), (_blocked, "hang"), (_hold_two_gib, "memory"), (_print, "printed"), (_print_in_python, "printed"),
    (_nan_camera, "value"),
], ids=["exception", "internal", "no file", "two lines", "CPU", "wall clock", "memory", "printed by C",
        "printed by Python", "NaN camera"])
def test_the_harness_catches_every_kind_of_escape(load, kind, tmp_path, monkeypatch):
    """The property is not vacuous: a loader that fails in each of these ways escapes, of
    that kind, within the limits."""
    monkeypatch.setattr(fuzz_harness, "HANG_CPU_SECONDS", 0.5)
    monkeypatch.setattr(fuzz_harness, "HANG_WALL_SECONDS", 1.0)
    target = Target("fake", "scene.toml", load, _no_check, lambda: None)
    with pytest.raises(Escape) as caught:
        check_case(target, Case(b"x"), tmp_path)
    assert caught.value.kind == kind, caught.value


def test_a_refusal_naming_file_and_line_is_not_an_escape(tmp_path):
    def refuse(path):
        raise SceneError("bad value", path, 3)
    outcome = check_case(Target("fake", "scene.toml", refuse, _no_check, lambda: None), Case(b"x"), tmp_path)
    assert (outcome.kind, outcome.message) == ("refused", f"{tmp_path}/case/scene.toml:3: bad value")


def test_a_saved_case_reads_back_the_same(tmp_path):
    from fuzz_harness import Fifo, Folder, Link, load_saved, save_case

    case = Case(b"[camera]\n", {"mesh.ply": b"ply\n", "loop.ply": Link("loop.ply"), "dir.png": Folder(),
                                "pipe.exr": Fifo(), "../outside.glsl": b"x"}, "made up", name="scene.toml")
    target, back = load_saved(save_case(case, tmp_path / "saved", BY_NAME["TOML scene"]))
    assert target.name == "TOML scene"
    assert (back.main, back.files, back.how, back.name) == (case.main, case.files, case.how, case.name)
