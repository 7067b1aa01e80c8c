"""Bad input never escapes as a traceback: every loader, fed truncated, mistyped and random
files (tests/fuzz_harness.py), either loads the file or refuses it with one LiftError naming
the file. A few hundred derandomized cases per loader here; benchmarks/fuzz_loaders.py runs
many more and counts them."""
from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzz_harness import LOADERS, check_input, mutate, prepare

EXAMPLES = 300


@pytest.mark.parametrize("loader", LOADERS, ids=lambda f: f.name)
def test_loader_refuses_bad_input_with_one_clear_error(loader, tmp_path):
    assert loader.seeds, f"no seed files for {loader.name}"
    path = prepare(loader, tmp_path)
    outcomes = {"loaded": 0, "refused": 0, "refused, no line": 0}

    @settings(max_examples=EXAMPLES, derandomize=True, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(seed=st.sampled_from(loader.seeds), rng=st.randoms(use_true_random=False))
    def fuzz(seed, rng: random.Random):
        outcomes[check_input(loader, mutate(seed.read_bytes(), rng), path)] += 1

    fuzz()
    # Both outcomes occur: the mutations are neither all harmless nor all fatal.
    assert outcomes["loaded"] > 0 and outcomes["refused"] + outcomes["refused, no line"] > 0, outcomes


@pytest.mark.parametrize("loader", LOADERS, ids=lambda f: f.name)
def test_every_seed_loads_unmutated(loader, tmp_path):
    path = prepare(loader, tmp_path)
    for seed in loader.seeds:
        if seed.parent.name == "data" and seed.suffix == ".toml":
            continue  # tests/data/*.toml are the bad-input examples of test_scene_loading.py
        assert check_input(loader, seed.read_bytes(), path) == "loaded", seed
