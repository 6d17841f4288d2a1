"""Impulse probes of the replay on DAS-2D Ex. 3 (servo-held distance sweep through a snap):
every verdict agrees with the FE tangent test at the settled state (lowest eigenvalue of the
load-controlled tangent), the limit-point state's too: its servo-settled state is finished
by Newton (``fem_reference.replay.finish``), so it is the load-controlled equilibrium itself,
and the kick returns to it (settled within 1e-7 L only, it lay a visible distance from that
equilibrium, amplified by the near-singular tangent, and the probe came to rest there,
undecided), within a bounded probe time (steps sized by the probed mode, not by T1)."""

import cases
from fem_reference.replay.model import Replay


def test_ex3_probe_verdicts_agree_with_the_tangent():
    sol = Replay().solve(cases.load("cases/catalog/das2d-ex3-bistable-switch.toml"))
    assert sol.status == "converged"
    probes = sol.extras["probes"]
    assert all(p["stable"] == (p["eigenvalue"] > 0) for p in probes)
    assert {p["stable"] for p in probes} == {True, False}
    (limit,) = [p for p in probes if 0 < p["eigenvalue"] < 1e-3 * probes[0]["eigenvalue"]]
    assert limit["verdict"] == "returned" and limit["final"] < 0.02 * 1e-3  # kick: 1e-3 L
