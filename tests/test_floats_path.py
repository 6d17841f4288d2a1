"""``FloatsPath`` (the list-of-float path with its arithmetic inlined) takes the same steps
with the same floating-point operations as the generic ``_Path`` on ``Floats``: every state,
iteration count, residual and stability verdict is bit-identical."""

from __future__ import annotations

import numpy as np
import pytest

import cases
from reduced_models.base import load_factors
from reduced_models.beam.prb import PRB2R, PRB3R
from reduced_models.beam.prb_chain import PRBChain, equilibrium_path
from reduced_models.paths import floats_path


def _path(model, case: str):  # noqa: ANN001
    scene = cases.load(case)
    ready = model._prepare(scene)
    if isinstance(ready, str):
        pytest.skip(ready)
    beam, (matrix, _, _) = ready
    chain = PRBChain(matrix, beam.L, beam.EI, beam.EA)
    f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
    return lambda: equilibrium_path(chain, f1, load_factors(scene), guided=beam.guided)


CASES = [
    "cantilever-tip-load",
    "cantilever-inclined-compression",
    "pure-moment-rollup",
    "column-postbuckling",
]


@pytest.mark.parametrize("model", [PRB2R(), PRB3R()], ids=["prb-2r", "prb-3r"])
@pytest.mark.parametrize("case", CASES)
def test_inlined_path_equals_generic_path(model, case: str, monkeypatch) -> None:  # noqa: ANN001
    solve = _path(model, case)
    fast = solve()
    monkeypatch.setattr(floats_path, "plain", lambda A, update: False)
    slow = solve()
    assert fast.ok == slow.ok and fast.reason == slow.reason
    assert fast.stable == slow.stable
    for key in ("factors", "states", "iterations", "cuts", "residuals"):
        np.testing.assert_array_equal(getattr(fast, key), getattr(slow, key))
