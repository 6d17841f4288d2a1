"""Internal errors as reasons, verdicts only where they mean something (issue 23, items 3-4):
scenes written outside the project that ended in a numpy/LAPACK message, a static stability
verdict under follower loads, or a solve without a time limit."""

from __future__ import annotations

import dataclasses
import time

import pytest

import cases
import reports
from reports.run.timing import DEFAULT_TIME_LIMIT

BEAM = """
[case]
name = "{name}"
title = "{name}"
units = "nondim"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 1.0
y = 0.0

[[members]]
id = "beam"
from = "A"
to = "B"
kind = "flexible"
E = 1.0
I = 1.0
A = 1.0e4
end_a = "{end_a}"

[[supports]]
node = "A"
type = "{root}"
{tip_support}
[[loads]]
node = "B"
fy = -1.0

[analysis]
kind = "load"
steps = 4

[[outputs]]
name = "tip"
node = "B"
"""
TIP_CLAMP = '\n[[supports]]\nnode = "B"\ntype = "clamp"\n'


def beam(name: str, root: str = "clamp", end_a: str = "weld", tip_support: str = "") -> str:
    """The TOML of a unit cantilever (EI = 1, EA = 1e4) under a unit tip force down."""
    return BEAM.format(name=name, root=root, end_a=end_a, tip_support=tip_support)


def test_a_root_support_pin_is_refused_by_the_loader_with_the_reason():
    """A cantilever whose root support is a pin: the beam swings freely (1 rigid-body
    freedom), a scene error naming the supports, before any model runs."""
    with pytest.raises(cases.CaseError, match="supports: too few supports.*1 rigid-body"):
        cases.loads(beam("pin-support", root="pin"), source="pin-support.toml")


def test_elastica_on_a_beam_pinned_at_its_root_is_failed_as_a_mechanism():
    """The beam pinned (end 'pin') to its clamped root has a singular stiffness at factor 0:
    it swings to hang under any tip force, no static load path; the assembler's elastica
    member says so instead of an allocation of 65.4 PiB or "failed from an unstable state"."""
    scene = cases.loads(beam("pinned-end", end_a="pin"), source="pinned-end.toml")
    sol = reports.solve(scene, "elastica")
    assert sol.status == "failed"
    assert "traceback" not in sol.extras
    assert "mechanism" in sol.message and "pinned root" in sol.message


@pytest.mark.parametrize("model", ["elastica", "replay", "fem-8", "linear-8", "bcm", "cbcm-4"])
def test_an_over_clamped_beam_does_not_move(model):
    """Both ends clamped, the tip force taken by the tip's clamp: zero displacement and
    rotation at every factor (no free coordinate: LAPACK and csgraph refuse empty arrays)."""
    scene = cases.loads(beam("over-clamped", tip_support=TIP_CLAMP), source="oc.toml")
    sol = reports.solve(scene, model)
    assert sol.status == "converged", sol.message
    assert [st.factor for st in sol.steps] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    for st in sol.steps:
        for key in ("tip.ux", "tip.uy", "tip.rot"):
            assert st.outputs[key] == pytest.approx(0.0, abs=1e-12)


def test_replay_gives_no_static_verdict_under_follower_loads():
    """A follower tip force has no potential: neither the tangent test nor a settled probe
    decides static stability (as fem-auto: ``stable = None``), said in the message."""
    base = cases.load("cantilever-follower-load")
    scene = dataclasses.replace(base, analysis=dataclasses.replace(base.analysis, steps=4))
    sol = reports.solve(scene, "replay")
    assert sol.status == "converged", sol.message
    assert [st.stable for st in sol.steps] == [None] * 5
    assert "no static stability verdict under follower" in sol.message
    assert "follower" in sol.extras["stability"]


def test_replay_keeps_its_verdict_under_dead_loads():
    sol = reports.solve(cases.loads(beam("dead"), source="dead.toml"), "replay")
    assert sol.status == "converged"
    assert [st.stable for st in sol.steps] == [True] * 5
    assert "stability" not in sol.extras


def test_elastica_bvp_on_a_30x_overloaded_flexure_fails_within_its_time_limit():
    """The steel flexure at 30x its catalog load (PL^2/EI = 300): solve_bvp's continuation
    takes far longer than the limit; the run ends at its wall-clock limit with the reason and
    the states so far, not after minutes without output.  (At 3x, the issue's scene, the
    dimensionless collocation now converges in about a second.)"""
    base = cases.load("steel-flexure-1000")
    load = dataclasses.replace(base.loads[0], fy=30 * base.loads[0].fy)
    scene = dataclasses.replace(base, loads=(load,), references=(), models=())
    limit = 3.0
    t0 = time.perf_counter()
    sol = reports.solve(scene, "elastica-bvp", options={"time_limit_s": limit})
    elapsed = time.perf_counter() - t0
    assert elapsed < limit + 1.0
    assert sol.status == "failed"
    assert f"time limit {limit:g} s reached" in sol.message
    assert all(st.factor < 1.0 for st in sol.steps)


def test_elastica_bvp_time_limit_defaults_to_the_runners():
    from reduced_models.beam.elastica_bvp import ElasticaBVP

    assert ElasticaBVP().time_limit_s == DEFAULT_TIME_LIMIT
