"""Fuzz: mutated catalog cases end in one of the three allowed outcomes, within a time bound.

CI runs a bounded number of hypothesis examples (one file, one model each).  ``pytest -m
fuzz`` runs many more files, each through all six models of ``tests.fuzz_cases.MODELS``
(count: ``FLEXBENCH_FUZZ_FILES``, default 2000; seed ``FLEXBENCH_FUZZ_SEED``), and prints the
counts per outcome.
"""

from __future__ import annotations

import collections
import json
import os
import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzz_cases import MODELS, mutate, outcome

CI_EXAMPLES = 30


@settings(
    max_examples=CI_EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=list(HealthCheck),
)
@given(rng=st.randoms(use_true_random=False), model=st.sampled_from(MODELS))
def test_mutated_cases_end_in_an_allowed_outcome(rng, model, tmp_path_factory):
    case, text, applied = mutate(rng)
    path = tmp_path_factory.mktemp("fuzz") / f"{case}.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    result = outcome(path, model, time_limit=10.0)
    assert not result.startswith("BAD"), (result, case, applied, model)


@pytest.mark.fuzz
def test_fuzz_many_files_all_models(tmp_path, capsys, request):
    if "fuzz" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("the long fuzz run: pytest -m fuzz")
    n = int(os.environ.get("FLEXBENCH_FUZZ_FILES", "2000"))
    seed = int(os.environ.get("FLEXBENCH_FUZZ_SEED", "15"))
    rng = random.Random(seed)
    counts: collections.Counter = collections.Counter()
    bad, slow = [], []
    for i in range(n):
        case, text, applied = mutate(rng)
        path = tmp_path / f"{i:05d}-{case}.toml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        if i % 100 == 0:
            (tmp_path / "progress.json").write_text(json.dumps([i, dict(counts)]))
        for model in MODELS:
            result = outcome(path, model)
            counts[result.split(":")[0]] += 1
            if result == "time-limit":
                slow.append((path.name, model, applied))
            if result.startswith("BAD"):
                bad.append((path.name, model, applied, result))
                (tmp_path / "bad").mkdir(exist_ok=True)
                (tmp_path / "bad" / path.name).write_text(text, errors="surrogatepass")
    with capsys.disabled():
        print(f"\nfuzz: {n} files x {len(MODELS)} models, seed {seed}: {dict(counts)}")
        for b in bad[:50]:
            print("  ", *b)
        for b in slow[:50]:
            print("   time limit:", *b)
    assert not bad
