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


def test_servo_held_follower_path_ends_at_factor_end_as_fem_auto():
    """Lee's frame under a follower load: the path reaches factor_end = 100 before the stop
    output's -100.  fem-auto ends there; the replay used to stop at the last report value
    below it (factor 15.6, "path cut") and now settles where the factor is factor_end, on
    fem-auto's state within its own stated mesh error."""
    base = cases.load("lee-frame")
    load = dataclasses.replace(base.loads[0], follower=True)
    sc = dataclasses.replace(
        base, loads=(load,), analysis=dataclasses.replace(base.analysis, steps=20)
    )
    sol = reports.solve(sc, "replay", options={"n_elements": 16, "probe": "none"})
    assert sol.status == "converged", sol.message
    assert "path ends where the factor reaches factor_end = 100" in sol.message
    assert "no static stability verdict" in sol.message
    assert abs(sol.steps[-1].factor - 100.0) <= 1e-8
    assert all(s.stable is None for s in sol.steps)
    ref = reports.solve(sc, "fem-auto")
    assert ref.status == "converged" and ref.steps[-1].factor == 100.0
    est = sol.extras["mesh_error_estimate"]
    for k in ("corner.ux", "corner.uy"):
        assert abs(sol.steps[-1].outputs[k] - ref.steps[-1].outputs[k]) <= est[k], k
