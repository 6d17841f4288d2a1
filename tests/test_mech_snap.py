"""Snap-through under load control (``reduced_models/mechanism/snap.py``), DAS-2D Ex. 3 as the
seed runs it (``das2d-ex3-bistable-switch-load``: Fx ramped to 15 N, no shuttle guide).

The reference is fem-auto solved here (its bifurcation factor and far stable state, never
numbers of the reduced models).  Each reduced model must snap where fem-auto snaps and land
on fem-auto's far branch within its own error, re-measured here: a chained-BCM model's
discretisation error is estimated by the distance between cbcm-N/2 and cbcm-N (cbcm-2 by
cbcm-2 to cbcm-4; the sequence converges to the FE beam), and the mixed model (PRB-3R +
cbcm-2) is held to its long links' cbcm-2 estimate plus the case's 5 % (the PRB-3R short
links carry little of the motion).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import cases
from reports.api import solve

CASE = cases.load("das2d-ex3-bistable-switch-load")
FAR = 0.45  # the first load step past fem-auto's snap
KEY = "shuttle_top.ux"


@pytest.fixture(scope="module")
def fem():
    sol = solve(CASE, "fem-auto")
    assert sol.ok, sol.message
    return sol


def _at(sol, factor: float) -> float:
    return next(s.outputs[KEY] for s in sol.steps if abs(s.factor - factor) < 1e-9)


def _snap(sol) -> dict:
    assert sol.ok, sol.message
    assert all(s.stable for s in sol.steps), "load control ended a step on an unstable state"
    snaps = [p for p in sol.extras["critical_points"] if p["kind"] == "snap"]
    assert len(snaps) == 1 and snaps[0]["switched"]
    landed = [s for s in sol.steps if s.info.get("snap")]
    assert [s.factor for s in landed] == [snaps[0]["to"]["factor"]]
    return snaps[0]


@pytest.mark.parametrize("model", ["cbcm-2", "cbcm-8", "mixed"])
def test_snap_load_and_far_state_agree_with_fem_auto(fem, model: str) -> None:
    crit = [p for p in fem.extras["critical_points"] if p["kind"] in ("limit", "bifurcation")]
    lam_fe = crit[0]["factor"]
    sol = solve(CASE, model)
    snap = _snap(sol)
    pair = [
        solve(CASE, m)
        for m in (("cbcm-4", "cbcm-8") if model == "cbcm-8" else ("cbcm-2", "cbcm-4"))
    ]
    # the snap load within the chain's own error (the distance between the pair's snap
    # loads) plus 0.2 % (1 % for mixed's PRB-3R links): with its legs laid out as mirror
    # images (cases.orient) the chain sees fem-auto's symmetric bifurcation,
    # converging from above (cbcm-2/4/8: 0.4374, 0.4342, 0.4330; fem-auto 0.43207)
    est = abs(_snap(pair[0])["factor"] - _snap(pair[1])["factor"])
    allowed = 1.5 * est + (1e-2 if model == "mixed" else 2e-3) * lam_fe
    assert abs(snap["factor"] - lam_fe) <= allowed, (snap["factor"], lam_fe, est)
    assert snap["from"]["outputs"][KEY] < 3.0 < snap["to"]["outputs"][KEY]
    assert snap["to"]["factor"] == pytest.approx(FAR)
    est = abs(_at(pair[0], FAR) - _at(pair[1], FAR))
    allowed = 1.5 * est + (5e-2 if model == "mixed" else 2e-3) * _at(fem, FAR)
    assert abs(_at(sol, FAR) - _at(fem, FAR)) <= allowed, (_at(sol, FAR), _at(fem, FAR), est)


def test_every_fem_auto_mesh_snaps_at_the_bifurcation(fem) -> None:
    """Each mesh switches at the subcritical bifurcation (~0.432, energy descent) and lands
    on the far branch within the step to 0.45, so every step carries an estimate from all
    four meshes, well below the 5 % tolerance (before the descent, the coarse meshes stayed
    on the symmetric path up to its limit point, 0.668, and those steps had none:
    ``tests/test_richardson_branches.py`` covers that rule)."""
    est = fem.extras["error_estimate_steps"][KEY]
    assert not fem.extras.get("off_branch")
    assert all(e < 1e-3 for e in est), est
    assert _at(fem, FAR) > 15.25


GUIDED = cases.load("das2d-ex3-bistable-switch")
LIMIT_FE = 0.6677510  # fem-auto's limit load factor, quoted with provenance in that case file


@pytest.mark.parametrize("model", ["cbcm-2", "cbcm-8", "mixed"])
def test_guided_switch_snaps_at_its_limit_point(model: str) -> None:
    """The guided switch (symmetric path kept) under load control: a limit point, no
    bifurcation; the snap load is the largest factor of fem-auto's distance sweep."""
    a = dataclasses.replace(GUIDED.analysis, kind="load", steps=20, driver=None)
    sol = solve(dataclasses.replace(GUIDED, analysis=a, references=()), model)
    snap = _snap(sol)
    kinds = [p["kind"] for p in sol.extras["critical_points"]]
    assert kinds == ["limit", "snap"]
    assert abs(snap["factor"] - LIMIT_FE) <= 1e-2 * LIMIT_FE, snap["factor"]
    assert snap["to"]["outputs"][KEY] > 15.25  # past the unloaded second stable position


TRUSS = cases.loads(
    """[case]
name = "vm-flex"
title = "von Mises truss of two flexible bars, load control past the limit point"
units = "mm-N-MPa"

[[nodes]]
id = "L"
x = -100.0
y = 0.0

[[nodes]]
id = "C"
x = 0.0
y = 15.0

[[nodes]]
id = "R"
x = 100.0
y = 0.0

[[members]]
id = "left"
from = "L"
to = "C"
kind = "flexible"
E = 2000.0
width = 10.0
thickness = 4.0

[[members]]
id = "right"
from = "C"
to = "R"
kind = "flexible"
E = 2000.0
width = 10.0
thickness = 4.0

[[supports]]
node = "L"
type = "clamp"

[[supports]]
node = "R"
type = "clamp"

[[loads]]
node = "C"
fy = -300.0

[analysis]
kind = "load"
steps = 10

[[outputs]]
name = "apex"
node = "C"
""",
    "vm-flex",
)


@pytest.mark.parametrize("model", ["cbcm-4", "cbcm-8"])
def test_a_clamped_von_mises_truss_snaps_where_fem_auto_does(model: str) -> None:
    """A bistable mechanism written outside the catalog: two clamped flexible bars meeting
    at a loaded apex (rise 15 mm over 200 mm).  The snap load against fem-auto's critical
    factor (1 %), the far state at factor 0.3 within cbcm-4-to-cbcm-8 distance + 0.2 %."""
    fe = solve(TRUSS, "fem-auto")
    assert fe.ok, fe.message
    crit = [p for p in fe.extras["critical_points"] if p["kind"] in ("limit", "bifurcation")]
    sol = solve(TRUSS, model)
    snap = _snap(sol)
    assert abs(snap["factor"] - crit[0]["factor"]) <= 1e-2 * crit[0]["factor"]

    def far(x):
        return next(st.outputs["apex.uy"] for st in x.steps if abs(st.factor - 0.3) < 1e-9)

    est = abs(far(solve(TRUSS, "cbcm-4")) - far(solve(TRUSS, "cbcm-8")))
    assert abs(far(sol) - far(fe)) <= 1.5 * est + 2e-3 * abs(far(fe))


@pytest.mark.slow  # cbcm-auto solves four chained models through the snap (about a minute)
@pytest.mark.parametrize(
    ("model", "finer", "rel"),
    [("bcm", "cbcm-2", None), ("elastica", None, 5e-3), ("cbcm-auto", None, 5e-3)]
    + [("prb-2rpr", None, 5e-2)],
)
def test_every_member_model_that_moves_reports_the_snap(fem, model: str, finer, rel) -> None:
    """Ex. 3 as the seed runs it, the member models beside those above: the snap is
    reported, its load and the far state within the model's own error.  The elastica and
    cbcm-auto are near-exact (0.5 %); PRB-2(RP)R, whose stretching middle links let the legs
    move, is held to the case's 5 % (1 % on the snap load, a small-rotation state); a single
    BCM segment's error is its distance to cbcm-2 (1.5 x, as above): one segment misses the
    tilt of the legs by far."""
    lam_fe = next(p for p in fem.extras["critical_points"] if p["kind"] != "snap")["factor"]
    sol = solve(CASE, model)
    snap = _snap(sol)
    assert "snap at factor" in sol.message
    if finer is None:
        assert abs(snap["factor"] - lam_fe) <= min(rel, 1e-2) * lam_fe
        for f in (FAR, 1.0):
            assert abs(_at(sol, f) - _at(fem, f)) <= rel * _at(fem, f)
        return
    ref = solve(CASE, finer)
    est_lam = abs(snap["factor"] - _snap(ref)["factor"])
    assert abs(snap["factor"] - lam_fe) <= 1.5 * est_lam
    est = abs(_at(sol, FAR) - _at(ref, FAR))
    assert abs(_at(sol, FAR) - _at(fem, FAR)) <= 1.5 * est


@pytest.mark.parametrize(
    "model", ["linear-auto", "prb-fsm-auto", "linear-4", "prb-3r", "prb-2r", "prb-1r", "prb-short"]
)
def test_member_models_that_cannot_move_decline_with_the_reason(model: str) -> None:
    """Inextensible linear / PRB members see no first-order motion under the shuttle push
    (the load is carried by axial inextensibility) and prb-1r has no guided-beam joint: each
    declines (not-applicable) with its reason, the auto families too (they once 'failed')."""
    sol = solve(CASE, model)
    assert sol.status == "not-applicable", (sol.status, sol.message)
    assert "inextensibility" in sol.message or "welded at both ends" in sol.message


SPRING_TRUSS = "von-mises-spring-truss"


def test_a_spring_truss_that_newton_crosses_in_one_step_reports_its_snap() -> None:
    """The von Mises spring truss of the catalog under a dead apex load 8 N (kinetostatic):
    Newton converges from factor 0.7 straight onto the inverted branch at 0.8, both states
    stable (once a silent jump).  Closed form (case file): driving force
    F(w) = 2 k (L - L0)(h - w)/L; the snap at the largest pull -F, 6.0383 N (factor
    6.0383 / 8) at w = 8.5286 mm, the landing where -F(w) = 6.4 N on the inverted branch."""
    from scipy.optimize import brentq, minimize_scalar

    base = cases.load(SPRING_TRUSS)
    a = dataclasses.replace(base.analysis, kind="load", steps=10, driver=None)
    load = cases.schema.Load(id="p", node="C", fy=-8.0)
    scene = dataclasses.replace(base, analysis=a, loads=(load,), references=())
    k, a_, h = 2e4, 0.1, 0.02
    L0 = np.hypot(a_, h)

    def F(w):
        L = np.hypot(a_, h - w)
        return 2 * k * (L - L0) * (h - w) / L

    peak = minimize_scalar(F, bounds=(0.0, h), method="bounded", options={"xatol": 1e-12})
    sol = solve(scene, "kinetostatic")
    snap = _snap(sol)
    assert snap["factor"] == pytest.approx(-peak.fun / 8.0, rel=1e-6)
    assert -snap["from"]["outputs"]["apex.uy"] == pytest.approx(peak.x, rel=2e-3)
    w_far = brentq(lambda w: -F(w) - 6.4, 2 * h, 3 * h)
    assert snap["to"]["factor"] == pytest.approx(0.8)
    assert -snap["to"]["outputs"]["apex.uy"] == pytest.approx(w_far, rel=1e-8)


@pytest.mark.parametrize("model", ["bcm", "cbcm-2"])
def test_the_shallow_von_mises_arch_snaps_at_its_exact_limit_load(model: str) -> None:
    """The catalog's shallow arch (two pinned bars, EA 1000, half-span 1, rise 0.1) under a
    load ramp to 0.5 > P_max with the reduced mechanism models: the snap at the exact limit
    load max P(w) (its bars stay straight, so a BCM segment carries the truss law up to its
    axial model), from w1 to the inverted branch at factor 0.4 (closed form P(w))."""
    from scipy.optimize import brentq

    from tests.test_verify_fem_hard import arch_P

    base = cases.load("shallow-arch-snap")
    a = dataclasses.replace(base.analysis, kind="load", steps=5, factor_end=0.5)
    sol = solve(dataclasses.replace(base, analysis=a, references=()), model)
    (snap,) = [p for p in sol.extras["critical_points"] if p["kind"] == "snap"]
    dP = lambda w: (arch_P(w + 1e-7) - arch_P(w - 1e-7)) / 2e-7  # noqa: E731
    w1 = brentq(dP, 1e-3, 0.099)
    assert snap["factor"] == pytest.approx(arch_P(w1), rel=1e-5)
    assert -snap["from"]["outputs"]["apex.uy"] == pytest.approx(w1, rel=1e-2)
    assert snap["to"]["factor"] == pytest.approx(0.4)
    w_far = brentq(lambda w: arch_P(w) - 0.4, 0.2, 0.3)
    assert -snap["to"]["outputs"]["apex.uy"] == pytest.approx(w_far, rel=1e-4)
    assert "snap at factor" in sol.message


def test_a_start_settled_above_newtons_tolerance_is_located_without_probes(monkeypatch) -> None:
    """A load step that starts on a state ``_relax`` accepted at its round-off floor (above
    Newton's tolerance) cannot be followed by Newton at all: the start is the located point,
    and no bisection probe (each failing only after all its step cuts) is made."""
    from types import SimpleNamespace

    from reduced_models.mechanism import snap
    from reduced_models.mechanism.newton import State

    def no_probe(*args: object) -> None:
        raise AssertionError("bisection probe from a start above the tolerance")

    monkeypatch.setattr(snap, "_reach", no_probe)
    run = SimpleNamespace(solver=SimpleNamespace(tol=1e-10))
    st = State(np.zeros(3), np.zeros(1), 0.45, residual=2e-10)
    lam, found = snap._locate(run, st, 0.45, 0.5)
    assert lam == 0.45 and found is st


def test_located_critical_factor_is_the_same_in_every_encoding() -> None:
    """A bistable switch with flexible legs and a flexible shuttle (cbcm-8): the bisection
    alone stopped where Newton first failed next to the singular point, 1e-7 of the factor
    apart in the scene rotated, renamed or in mm (the outside review).  Refined to the zero
    of the KKT eigenvalue (``snap._refine``) the four encodings agree to 1e-9."""
    fixtures = Path(__file__).parent / "fixtures"
    factors = []
    for enc in ("", "--rot37", "--units-mm-N-MPa_L1000_F1", "--renamed+reversed"):
        path = fixtures / f"bistable-flexshuttle-m-n-pa{enc}.toml"
        sol = solve(cases.load(str(path)), "cbcm-8")
        assert sol.status == "converged", sol.message
        kinds = [p["kind"] for p in sol.extras["critical_points"]]
        assert kinds == ["bifurcation", "snap"], kinds
        factors.append(sol.extras["critical_points"][0]["factor"])
    assert max(factors) - min(factors) <= 1e-9 * max(factors), factors
