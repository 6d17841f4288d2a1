"""The replay reaches its report factors along one continuous load ramp (issue 22: "each
increment re-ramped and re-settled" cost 27 time steps per increment on the catalog
cantilever).  Along a slow ramp the steps are as large as the error test allows with a
local error of a few per cent of the increment's predicted motion, up to ``RAMP_DT`` = 2 T1
(four T1 per increment: 2 steps), and each quasi-static sample settles at the static
equilibrium it comes to rest at -- the static FE state of the same mesh to Newton's
tolerance, far inside the replay's settling tolerance (1e-7 L)."""

import dataclasses

import numpy as np

import cases
from fem_reference.models import FEM
from fem_reference.replay.model import Replay


def test_continuous_ramp_steps_and_settled_states():
    sc = cases.load("cantilever-tip-load")  # 20 increments to PL^2/EI = 10
    rp = Replay(16, probe="none").solve(sc)
    fs = FEM(16).solve(sc)
    assert rp.status == "converged" and fs.ok, (rp.message, fs.message)
    steps = rp.extras["settle"]["time_steps"]
    # 2 steps per increment (4 T1 at 2 T1), the first eased in, the last held to rest: ~60
    assert steps <= 4 * 20, steps
    for a, b in zip(fs.steps[:-1], rp.steps[:-1]):  # the last is held (settle_tol)
        assert max(abs(a.outputs[k] - b.outputs[k]) for k in ("tip.x", "tip.y")) < 1e-9
        assert b.info["distance"] < 1e-9
    assert rp.steps[-1].info["distance"] < 1e-7


def test_a_ramp_too_fast_for_quasi_static_samples_is_held_at_every_factor():
    """Ramped in 0.05 T1 per increment, every sample is still far from rest: each factor is
    held until settled (the time history rings down at every one of them)."""
    sc = cases.load("cantilever-tip-load")
    sc = dataclasses.replace(sc, analysis=dataclasses.replace(sc.analysis, steps=4))
    rp = Replay(8, probe="none", ramp_periods=0.05).solve(sc)
    assert rp.status == "converged", rp.message
    T1, h = rp.extras["settle"]["T1"], rp.extras["history"]
    t_settled = np.array([s.info["t_settled"] for s in rp.steps[1:]])
    # held: each factor is settled well after its ramp ended (2 T1 at least of ringing)
    starts = np.r_[0.0, t_settled[:-1]] + 1.5 * 0.05 * T1
    assert np.all(t_settled - starts > 2.0 * T1), (t_settled - starts) / T1
    assert max(h["kinetic"]) > 0.0
