"""The chain's fast load path (``reduced_models.beam.chain_path``) against closed forms.

* A linear chain under a pure end moment: every segment carries the moment alone, so
  ``G [y, a] = [0, M h/EI]`` gives a = M h/EI, y = a/2 in each segment's base frame and the
  tip is the exact sum ``h sum_i e^{i (i - 1) a} (1 + i a/2)`` -- through a full roll-up.
* Euler's column: a straight chain under axial compression is stable below the chain's
  buckling load (within a few % of pi^2/4 EI/L^2 at N = 8) and not 20 % above it, where
  the fast path must hand the path back to the general continuation.
* The path tangent used by the predictor: its start saves Newton iterations against the
  general engine on the same path.
* linear-1 (``chain_small.solve_linear_segment``): linear beam theory, one solve per path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cases
from reduced_models.base import load_factors
from reduced_models.beam import single_beam
from reduced_models.beam.bcm import ChainedBCM
from reduced_models.beam.chain_path import ChainPath
from reduced_models.beam.linear import LinearChain


def _path(model, scene):
    prob = model.problem(single_beam.cantilever_of(scene))
    return prob, ChainPath(prob).follow(load_factors(scene).tolist())


@pytest.mark.parametrize("n", [2, 8, 16])
def test_linear_chain_under_end_moment_is_the_exact_polygon(n):
    scene = cases.load("pure-moment-rollup")
    prob, res = _path(LinearChain(n), scene)
    assert res is not None and all(res.stable)
    tips = res.states[:, -4:]
    for lam, (X, Y, phi, p) in zip(res.factors, tips):
        a = lam * 2.0 * math.pi / n  # M h / EI per segment
        exact = sum(np.exp(1j * i * a) * (1.0 + 0.5j * a) for i in range(n)) / n
        assert X == pytest.approx(exact.real, abs=1e-10)  # xtol
        assert Y == pytest.approx(exact.imag, abs=1e-10)  # xtol
        assert phi == pytest.approx(lam * 2.0 * math.pi, abs=1e-10)  # xtol
        assert p == pytest.approx(0.0, abs=1e-10)  # xtol


@pytest.mark.parametrize("make", [LinearChain, ChainedBCM])
def test_compressed_column_stable_below_buckling_handed_back_above(make):
    base = cases.load("cantilever-tip-load")
    b = single_beam.cantilever_of(base)
    model = make(8)
    factors = np.linspace(0.0, 1.0, 5).tolist()
    for ratio, fast in ((0.8, True), (1.2, False)):
        prob = model.problem(b)
        prob.loads[:] = (-ratio * math.pi**2 / 4, 0.0, 0.0)  # straight column, Euler pi^2/4
        res = ChainPath(prob).follow(factors)
        assert (res is not None) is fast
        if fast:
            assert all(res.stable)
            assert np.abs(res.states[:, 1::4]).max() == 0.0  # stays straight
        else:  # the general stability test on the straight state at the last factor
            straight = prob.x0.copy()
            straight[7::4] = prob.loads[0] * prob.h**2  # axial forces: the applied one
            assert prob.stability(straight, 1.0, None) is False


@pytest.mark.parametrize("name", ["linear-8", "cbcm-16"])
def test_fast_path_agrees_with_the_engine_in_fewer_iterations(name):
    scene = cases.load("cantilever-tip-load")
    model = LinearChain(8) if name == "linear-8" else ChainedBCM(16)
    prob, res = _path(model, scene)
    eng = model._path(model.problem(single_beam.cantilever_of(scene)), load_factors(scene))
    assert res is not None and all(res.stable)
    assert np.abs(res.states - eng.states).max() < 1e-9
    assert res.iterations.sum() < 0.75 * eng.iterations.sum()


@pytest.mark.parametrize("case", ["cantilever-tip-load", "fixed-guided-beam"])
def test_linear_1_is_one_solve_and_linear_beam_theory(case):
    """linear-1 under the catalog's dead loads: Y = F L^3/3EI (free) or F L^3/12EI (guided)
    at every factor, from one solve for the whole path."""
    scene = cases.load(case)
    b = single_beam.cantilever_of(scene)
    model = LinearChain(1)
    sol = model.solve(scene)
    assert sum(st.iterations for st in sol.steps) == 1
    ey = abs(b.fy) * b.L**3 / ((12.0 if b.guided else 3.0) * b.EI)
    for st in sol.steps:  # one segment: its largest transverse deflection is the tip's
        assert st.info["max_segment_y"] * b.L == pytest.approx(st.factor * ey, rel=1e-12)
