"""A servo-held replay (a path analysis with a stop output) under follower loads gives no
static stability verdict either (issue 23, item 4): a follower force has no potential, so
neither the tangent test nor a settled probe decides static stability -- as fem-auto and the
load-controlled replay say (``stable = None``).  Before, the servo's wrapper hid the
follower DOFs and every state of Lee's frame under a follower load was reported stable."""

import dataclasses

import cases
import reports


def test_servo_held_replay_under_a_follower_load_has_no_static_verdict():
    base = cases.load("cantilever-follower-load")
    a = dataclasses.replace(
        base.analysis, kind="path", steps=3, stop_output="tip.uy", stop_value=-0.3
    )
    sol = reports.solve(dataclasses.replace(base, analysis=a), "replay", options={"n_elements": 8})
    assert sol.status == "converged", sol.message
    assert "servo-held" in sol.message
    assert len(sol.steps) == 4
    assert all(s.stable is None for s in sol.steps)
