"""Replay honesty: its mesh error against fem-auto is stated, a stalled replay ends
(issue 11, item 7)."""

from __future__ import annotations

import cases
import reports
from fem_reference.replay.model import Replay


def test_replay_states_its_mesh_error_against_fem_auto():
    scene = cases.load("cantilever-tip-load")
    rp = Replay(8, probe="none").solve(scene)
    assert rp.status == "converged" and "mesh error vs fem-auto" in rp.message
    worst = rp.extras["mesh_error_worst"]
    ref = reports.solve(scene, "fem-auto")
    diff = max(abs(rp.steps[-1].outputs[k] - ref.steps[-1].outputs[k]) for k in ("tip.x", "tip.y"))
    # the estimate is of the right size: the true gap lies within it, not 10x below it
    assert worst / 10.0 <= diff <= 1.5 * worst + 1e-6, (diff, worst)


def test_a_replay_past_its_time_limit_fails_with_the_reason():
    rp = Replay(8, probe="none", time_limit_s=0.01).solve(cases.load("cantilever-tip-load"))
    assert rp.status == "failed" and "time limit" in rp.message
