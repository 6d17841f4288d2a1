"""A held-settled replay state is finished by Newton (``fem_reference.replay.finish``): the
state the replay reports is the static equilibrium of its mesh and load to round-off, at
rest -- not a state somewhere within the settling tolerance (1e-7 L) of it, where round-off
(the scene's encoding) puts it.  The exact answer: the FE residual r(q, lam) = 0."""

import dataclasses

import numpy as np

import cases
from fem_reference.assembly import build
from fem_reference.replay.model import Replay
from fem_reference.replay.probe import stability
from fem_reference.replay.run import ReplayOptions, replay_system


def test_held_states_are_static_equilibria_to_round_off():
    """Ramped in 0.05 T1 per increment, no sample is quasi-static: every factor is held
    until settled (``test_replay_ramp``), then finished."""
    sc = cases.load("cantilever-tip-load")
    sc = dataclasses.replace(sc, analysis=dataclasses.replace(sc.analysis, steps=4))
    system = build(sc, 8)
    seen = []

    def record(run, s, chk, want, scene):  # the state each step is reported at
        seen.append((s.q.copy(), s.v.copy(), s.lam, s.t))
        return stability(run, s, chk, want, scene)

    opts = ReplayOptions(probe="none", ramp_periods=0.05)
    factors = np.linspace(0.0, 1.0, 5)
    sol = replay_system(system, factors, scene=sc, options=opts, stability=record)
    assert sol.status == "converged", sol.message
    assert [st.info["finished"] for st in sol.steps] == [1.0] * 5
    T1 = sol.extras["settle"]["T1"]
    for (q, v, lam, t), prev in zip(seen[1:], seen):
        assert t - prev[3] > 2.0 * T1  # held: rang down after its (0.05 T1) ramp
        assert not v.any()  # at rest
        f = lam * np.asarray(system.external(q))
        r = np.asarray(system.residual(q, lam))
        # settled alone (no finish): ~1e-6 of the load; an equilibrium: round-off
        assert np.max(np.abs(r)) <= 1e-10 * np.max(np.abs(f)), np.max(np.abs(r))


def test_a_deploy_with_locked_booms_is_finished_to_its_constrained_equilibrium():
    """The thesis six-bar (config 4): the booms lock as bars (exact constraints, Lagrange
    multipliers); Newton bordered by their rows finishes the settled state to a static
    distance at round-off (held alone: up to 1e-7 L)."""
    sol = Replay().solve(cases.load("thesis-sixbar-config4"))
    assert sol.status == "converged" and sol.extras["boom_reached"], sol.message
    (st,) = sol.steps
    assert st.info["finished"] == 1.0, sol.message
    assert st.info["distance"] <= 1e-12
