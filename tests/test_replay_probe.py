"""Impulse probes of the replay on DAS-2D Ex. 3 (servo-held distance sweep through a snap):
every decided verdict agrees with the FE tangent test at the settled state (lowest eigenvalue
of the load-controlled tangent), and the limit-point state -- whose load-controlled
equilibrium lies a visible distance from the servo-settled one -- comes to rest there and is
left undecided, within a bounded probe time (steps sized by the probed mode, not by T1)."""

import cases
from fem_reference.replay.model import Replay


def test_ex3_probe_verdicts_agree_with_the_tangent():
    sol = Replay().solve(cases.load("cases/catalog/das2d-ex3-bistable-switch.toml"))
    assert sol.status == "converged"
    probes = sol.extras["probes"]
    decided = [p for p in probes if p["stable"] is not None]
    assert len(decided) == len(probes) - 1
    assert all(p["stable"] == (p["eigenvalue"] > 0) for p in decided)
    assert {p["stable"] for p in decided} == {True, False}
    (limit,) = [p for p in probes if p["stable"] is None]
    assert 0 < limit["eigenvalue"] < 1e-3 * max(p["eigenvalue"] for p in probes)
    assert limit["at_rest_distance"] > 0.02 * 1e-3  # rests beyond 2 % of the kick (1e-3 L)
