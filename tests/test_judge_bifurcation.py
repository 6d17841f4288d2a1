"""The FE reference follows the stable branch past a bifurcation (issue 11, item 1).

Perfect cantilever columns (no imperfection) loaded to 1.5-8 times the Euler load
Pe = pi^2 EI / (4 L^2): ``fem-auto`` must detect the loss of stability, report the critical
factor, switch to the buckled branch and match the inextensible elastica's post-buckled tip
(closed form in complete elliptic integrals, Timoshenko & Gere, Theory of Elastic Stability,
1961, Sec. 2.7: P/Pe = (2 K(k) / pi)^2, tip deflection 2 k L / K(k), tip x
(2 E(k) / K(k) - 1) L, tip angle 2 asin k) within its own error estimate plus the axial
strain P/EA the inextensible elastica ignores.  The FE is extensible: its critical load
solves P (1 - P/EA) = Pe (the column shortens by P/EA before it buckles), which is checked to
1e-6 relative, and Euler's within 1e-4 for every slenderness.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

import cases
import reports
from tests.test_verify_linear_bcm import beam_scene

PE = math.pi**2 / 4  # EI = L = 1


def elastica_post(ratio: float) -> tuple[float, float, float]:
    """(|tip y|, tip x, |tip angle|) of the post-buckled cantilever column at P = ratio Pe."""
    m = brentq(lambda m: (2.0 * ellipk(m) / math.pi) ** 2 - ratio, 1e-14, 1.0 - 1e-14)
    k = math.sqrt(m)
    return 2.0 * k / ellipk(m), 2.0 * ellipe(m) / ellipk(m) - 1.0, 2.0 * math.asin(k)


# (A, load / Pe): slenderness L/r = sqrt(A / I) = 100, 1000, 10000
COLUMNS = [(1e4, 1.5), (1e6, 3.0), (1e8, 8.0)]


@pytest.mark.parametrize(("area", "ratio"), COLUMNS)
def test_fem_auto_follows_the_buckled_branch(area, ratio, pick_a_mirror_branch):
    sol = reports.solve(beam_scene(-ratio * PE, 0.0, A=area, steps=8), "fem-auto")
    assert sol.status == "converged" and sol.message == ""
    last = sol.steps[-1]
    assert last.stable is True
    (cp,) = sol.extras["critical_points"]
    assert cp["kind"] == "bifurcation" and cp["switched"]
    p_ext = area * (1.0 - math.sqrt(1.0 - 4.0 * PE / area)) / 2.0  # P (1 - P/EA) = Pe
    assert cp["factor_extrapolated"] * ratio * PE == pytest.approx(p_ext, rel=1e-6)
    assert cp["factor_extrapolated"] * ratio == pytest.approx(1.0, rel=1e-4 + 2 * PE / area)
    y, x, rot = elastica_post(ratio)
    est = sol.extras["error_estimate"]
    strain = ratio * PE / area  # inextensible elastica vs extensible FE: O(P/EA) L
    o = last.outputs
    assert abs(abs(o["tip.uy"]) - y) <= est["tip.uy"] + strain
    assert abs(o["tip.x"] - x) <= est["tip.x"] + strain
    assert abs(abs(o["tip.rot"]) - rot) <= est["tip.rot"] + strain


def test_catalog_imperfect_column_has_no_critical_point():
    """An imperfect column never loses stability: nothing is detected or switched."""
    sol = reports.solve(cases.load("column-postbuckling"), "fem-16")
    assert sol.status == "converged" and sol.extras["critical_points"] == []
    assert all(s.stable for s in sol.steps)


def test_unstable_end_is_said(monkeypatch):
    """With branch switching disabled, the run must say it ends on an unstable state."""
    import fem_reference.statics.bifurcation as B

    monkeypatch.setattr(B.Watch, "_switch", lambda self, *a: None)
    sol = reports.solve(beam_scene(-2.0 * PE, 0.0, A=1e4, steps=4), "fem-8")
    assert sol.status == "converged" and "unstable" in sol.message
    assert np.isclose(sol.steps[-1].outputs["tip.uy"], 0.0)


def test_runner_does_not_score_against_an_unstable_reference():
    from reports.verdicts.errors import choose_reference

    steps = [{"factor": 1.0, "outputs": {"tip.uy": 0.0}}]
    bad = {"status": "converged", "steps": steps, "message": "ends unstable"}
    bad["extras"] = {"reference_usable": False}
    good = {"status": "converged", "steps": steps, "message": "", "extras": {}}
    name, note = choose_reference({"reference_model": "fem-auto"}, {"fem-auto": bad})
    assert name is None
    name, note = choose_reference(
        {"reference_model": "fem-auto"}, {"fem-auto": bad, "elastica": good}
    )
    assert name == "elastica" and "unusable" in note


@pytest.mark.parametrize("model", ["elastica", "linear-8", "bcm", "cbcm-4", "prb-3r", "prb-fsm-8"])
def test_reduced_models_on_a_perfect_column_say_when_unstable(model):
    """Past Euler's load a model either follows the buckled branch (as fem-auto), declines,
    fails, or says that its answer is an unstable equilibrium: never silent."""
    scene = cases.load("tests/data/traps/column-3x-euler.toml")
    sol = reports.solve(scene, model)
    if sol.status != "converged":
        assert sol.message
        return
    buckled = abs(sol.steps[-1].outputs["tip.uy"]) > 0.1
    assert buckled or (sol.steps[-1].stable is False and "unstable" in sol.message)


def test_tiny_imperfection_follows_its_own_buckled_branch():
    """1e-9 P transverse imperfection: load control crosses onto the complementary
    (unstable) branch; the watch switches to the stable branch on the imperfection's side."""
    scene = cases.load("tests/data/traps/column-3x-euler-imperfect.toml")
    sol = reports.solve(scene, "fem-16")
    assert sol.status == "converged" and sol.message == ""
    y, _, _ = elastica_post(3.0)
    last = sol.steps[-1]
    assert last.stable is True and last.outputs["tip.uy"] == pytest.approx(y, rel=2e-2)


def test_spring_restrained_column_critical_factor_and_pinned_mechanism(pick_a_mirror_branch):
    """Pin + ground torsion spring k at the root, axial tip load: buckles where
    beta L tan(beta L) = k L / EI, beta^2 = P / EI (Timoshenko & Gere 1961, Sec. 2.2).  The
    same beam pinned without the spring is a mechanism: the loader refuses it (exit 2), so
    no inverted pendulum is ever returned as converged."""
    path = "tests/data/traps/spring-root-column.toml"
    sol = reports.solve(cases.load(path), "fem-auto")
    assert sol.status == "converged" and sol.steps[-1].stable is True
    (cp,) = sol.extras["critical_points"]
    bl = brentq(lambda b: b * math.tan(b) - 2.0, 0.1, 1.5)
    assert cp["factor_extrapolated"] * 3.0 == pytest.approx(bl**2, rel=1e-4)
    text = open(path).read()
    start, end = text.index("[[torsion_springs]]"), text.index("[analysis]")
    with pytest.raises(cases.CaseError, match="rigid-body"):
        cases.loads(text[:start] + text[end:])


def test_path_analysis_of_a_perfect_column_switches_and_traces_the_buckled_branch():
    """Arc-length path to tip rotation 1.5 rad (no factor_end): the elastica gives
    P/Pe = (2 K(k) / pi)^2 with k = sin(0.75) there."""
    import dataclasses

    sc = beam_scene(-PE, 0.0, A=1e8, steps=20)
    a = dataclasses.replace(
        sc.analysis, kind="path", stop_output="tip.rot", stop_value=1.5, factor_end=math.inf
    )
    sol = reports.solve(dataclasses.replace(sc, analysis=a), "fem-16")
    assert sol.status == "converged" and sol.steps[-1].outputs["tip.rot"] == pytest.approx(1.5)
    (cp,) = sol.extras["critical_points"]
    assert cp["kind"] == "bifurcation" and cp["switched"]
    k = math.sin(0.75)
    exact = (2.0 * ellipk(k * k) / math.pi) ** 2
    assert sol.steps[-1].factor == pytest.approx(exact, rel=1e-3)  # 16 elements: 5e-4


def test_critical_factor_located_when_newton_fails_next_to_it(monkeypatch):
    """Next to a perfect column's bifurcation the tangent is singular to round-off, and the
    re-solve of the fundamental path inside Brent's bracket can fail there (the replay's
    bistable-toggle, by round-off, 7e-9 from the critical factor).  Planted here: Newton
    fails wherever the lowest eigenvalue is below 1e-9 of its value at the first solve.
    The critical factor still solves P (1 - P/EA) = Pe to 1e-6 (main fell back to the
    eigenvalue's interpolation across the whole load step: 1.6e-3 off)."""
    from fem_reference.statics import bifurcation as B
    from fem_reference.statics.descent import lowest_mode

    newton, first = B.S.newton, {}

    def failing_newton(system, u, lam, opts, *args, **kw):
        st = newton(system, u, lam, opts, *args, **kw)
        e = abs(lowest_mode(system, st.u, st.lam)[0])
        first.setdefault(id(system), e)
        if e < 1e-9 * first[id(system)]:
            raise B.S.SolveError("planted: singular tangent next to the critical point")
        return st

    monkeypatch.setattr(B.S, "newton", failing_newton)
    area, ratio = 1e4, 1.5
    sol = reports.solve(beam_scene(-ratio * PE, 0.0, A=area, steps=8), "fem-auto")
    (cp,) = sol.extras["critical_points"]
    p_ext = area * (1.0 - math.sqrt(1.0 - 4.0 * PE / area)) / 2.0  # P (1 - P/EA) = Pe
    assert cp["factor_extrapolated"] * ratio * PE == pytest.approx(p_ext, rel=1e-6)


def test_an_unlocated_critical_factor_is_interpolated_across_the_narrowest_bracket(monkeypatch):
    """Where Newton fails next to the critical factor, the eigenvalue is interpolated across
    the narrowest bracket the re-solved states give, not across the whole load step (DAS-2D
    Ex. 3's replay, drawn in m: 1e-6 off the same scene in mm).  A curved eigenvalue
    e(lam) = d + 30 d^2 (d = lam* - lam) over a step of +-0.05 with re-solved states at
    +-1e-4: the root to 1e-6 (across the step: 2e-3 off)."""
    from types import SimpleNamespace

    from fem_reference.statics import bifurcation as B

    root = 0.4
    eig = lambda lam: (root - lam) + 30.0 * (root - lam) ** 2  # noqa: E731
    watch = B.Watch.__new__(B.Watch)
    watch.sys = None
    monkeypatch.setattr(watch, "_eig", lambda st, scale=None: eig(st.lam), raising=False)
    monkeypatch.setattr(B, "lowest_mode", lambda *a, **k: (0.0, np.zeros(1), None))
    prev, cur = (SimpleNamespace(lam=root + d, u=np.zeros(1)) for d in (-0.05, 0.05))
    seen = [(root + d, eig(root + d), None) for d in (-0.05, -1e-4, 1e-4)]
    found = watch._interpolated(prev, cur, np.ones(1), seen)
    assert not found.located
    assert found.factor == pytest.approx(root, abs=1e-6)
