"""The yardstick (issue 19): every error on its output's own scale, so that "within 1 %" means
1 % of what a designer judges.

Two small-deflection flexures with linear closed forms (catalog cases, every number derived in
their descriptions):

* ``flexure-parallel-guide``: two leaves 50 x 0.5 x 10 mm, E = 200 GPa, 5 N on the stage;
  stage deflection delta = F L^3 / (24 EI) = 1.250 mm, about 2.5 % of L;
* ``flexure-cross-axis-pivot``: two such leaves crossing at their midpoints, 25 N mm on the
  stage; rotation theta = M L / (2 EI) = 0.0300 rad.

Errors are re-measured here, independently of ``reports.verdicts.errors``: the judged output's
largest
``|model - reference|`` along the path over the largest reference value of that output, against
the closed form at each load factor or against fem-auto's path (paired by load factor).  Costs
in ``recommend`` are deterministic (``tests.test_recommend.unknowns``, or an adversarial
order that puts the models worst on these scenes first), so every pick is stable.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cases
import reports
from cases.load import CaseError
from reports import cli
from reports.run import store
from reports.run.tables import case_meta
from reports.verdicts import errors
from reports.verdicts import yardstick as Y
from reports.verdicts.recommend import recommend
from tests.test_recommend import unknowns

PG, XP = "flexure-parallel-guide", "flexure-cross-axis-pivot"
PG_M = "tests/fixtures/flexure-parallel-guide-m.toml"  # the same guide in m-N-Pa
E, W, T, L = 200000.0, 10.0, 0.5, 50.0  # MPa, mm, mm, mm
EI = E * W * T**3 / 12.0  # N mm^2
DELTA = 5.0 * L**3 / (24.0 * EI)  # two fixed-guided leaves in parallel: 1.250 mm
THETA = 25.0 * L / (2.0 * EI)  # K = 2 EI / L: 0.0300 rad
CLOSED = {PG: DELTA, XP: THETA}
JUDGED = {PG: "stage.uy", XP: "stage.rot"}
# the models furthest off on these two scenes, made the cheapest (an order the recommender
# must not trust: a cheap model qualifies only on its error)
WORST_FIRST = {"prb-3r-force": 0.1, "prb-fsm-2": 0.2, "prb-3r": 0.3, "prb-2rpr": 0.4, "prb-2r": 0.5}


def worst_first(name: str, cpu: float = 0.0) -> float:
    """Deterministic cost: the models worst on these scenes first, else ``unknowns``."""
    return WORST_FIRST.get(name, unknowns(name))


@functools.cache
def solved(case: str, model: str):
    return reports.solve(cases.load(case), model)


def remeasured(case: str, model: str, against: str = "closed-form") -> float:
    """Largest error of the judged output along the path over its largest reference value;
    ``against`` the linear closed form at each step's factor or ``fem-auto``'s path."""
    key, sol = JUDGED[case], solved(case, model)
    assert sol.status == "converged" and sol.steps[-1].factor == pytest.approx(1.0)
    if against == "closed-form":
        ref = [CLOSED[case] * s.factor for s in sol.steps]
    else:
        by_factor = {round(s.factor, 9): s.outputs[key] for s in solved(case, against).steps}
        ref = [by_factor[round(s.factor, 9)] for s in sol.steps]
    diff = [abs(s.outputs[key] - r) for s, r in zip(sol.steps, ref, strict=True)]
    return max(diff) / max(abs(r) for r in ref)


def path_errors(case: str, model: str) -> dict:
    """``reports.verdicts.errors.path_errors`` of ``model`` against fem-auto (what records
    carry)."""
    scene = cases.load(case)
    meta = case_meta(scene)
    ref, _, _ = store.steps_json(solved(case, "fem-auto"))
    steps, _, _ = store.steps_json(solved(case, model))
    return errors.path_errors(steps, ref, meta["length_scale"], None, meta)


# -- the closed forms hold for the references ----------------------------------------------------
@pytest.mark.parametrize("case", [PG, XP])
@pytest.mark.parametrize("model", ["fem-auto", "elastica"])
def test_references_meet_the_linear_closed_form(case: str, model: str):
    """fem-auto and the elastica member law follow delta = F L^3 / (24 EI) and theta =
    M L / (2 EI) along the whole ramp to 3e-4 (the case states 2e-3 and 1e-3)."""
    assert CLOSED[PG] == pytest.approx(1.25) and CLOSED[XP] == pytest.approx(0.03)
    assert remeasured(case, model) <= 3e-4
    (tol,) = [t for t in cases.load(case).tolerances if t.output == JUDGED[case]]
    assert remeasured(case, model) < tol.rel / 10


def test_parasitic_shortening_of_the_guide():
    """The stage's mid-point shortens by -(3/5) delta^2 / L (BCM) within the case's 5 %."""
    (ref,) = [r for r in cases.load(PG).references if r.output == "stage.ux"]
    assert ref.value == pytest.approx(-0.6 * DELTA**2 / L)
    ux = solved(PG, "fem-auto").steps[-1].outputs["stage.ux"]
    assert abs(ux - ref.value) <= ref.tolerance * abs(ref.value)


# -- error_rel against error_L -------------------------------------------------------------------
def test_prb_fsm_2_is_25_percent_off_on_its_own_scale():
    """The issue's scene: prb-fsm-2 moves the stage 0.937 mm, 25 % short of 1.25 mm, which
    is 0.6 % of L.  ``error_rel`` says 25 %, ``error_L`` 0.6 %, both as re-measured here."""
    sol = solved(PG, "prb-fsm-2")
    worst = max(abs(s.outputs["stage.uy"] - DELTA * s.factor) for s in sol.steps)
    assert worst / DELTA == pytest.approx(0.25, abs=0.005)
    pe = path_errors(PG, "prb-fsm-2")
    # fem-auto's path differs from the closed form by 1e-4 relative: 2e-3 covers it
    assert pe["per_output"]["stage.uy"] == pytest.approx(worst / DELTA, rel=2e-3)
    assert pe["per_output_L"]["stage.uy"] == pytest.approx(worst / L, rel=2e-3)
    assert pe["per_output_L"]["stage.uy"] == pytest.approx(0.006, abs=5e-4)
    assert pe["summary"] == pe["per_output"]["stage.uy"], "the case judges stage.uy only"


def test_pivot_error_is_relative_to_the_rotation():
    """On the pivot, prb-3r's rotation is off by a fraction of theta that error_rel reports as
    such (the classic yardstick would report the radians, 30 x smaller)."""
    sol = solved(XP, "prb-3r")
    worst = max(abs(s.outputs["stage.rot"] - THETA * s.factor) for s in sol.steps)
    pe = path_errors(XP, "prb-3r")
    assert pe["per_output"]["stage.rot"] == pytest.approx(worst / THETA, rel=0.02)
    assert pe["per_output_L"]["stage.rot"] == pytest.approx(worst, rel=0.02)


# -- recommend ----------------------------------------------------------------------------------
@functools.cache
def _recommend(case: str, tol: float, cost=unknowns):
    return recommend(cases.load(case), tol, cost=cost)


@pytest.mark.parametrize("case", [PG, XP])
@pytest.mark.parametrize("tol", [1e-2, 1e-3])
@pytest.mark.parametrize("cost", [unknowns, worst_first])
def test_pick_is_within_tolerance_on_the_judged_output(case: str, tol: float, cost):
    """The pick's judged output, re-measured against fem-auto, is within the tolerance of the
    output itself; at 1 % also against the closed form (at 0.1 % the closed form's own
    linearisation error, 0.8-1.2e-4, is a tenth of the budget: on the pivot with ``unknowns``
    the pick prb-2r is 0.098 % off fem-auto and 0.107 % off the linear closed form)."""
    rec = _recommend(case, tol, cost)
    assert rec.recommended, rec.reason
    assert remeasured(case, rec.recommended, "fem-auto") <= tol, rec.reason
    if tol >= 1e-2:
        assert remeasured(case, rec.recommended) <= tol, rec.reason
    for c in rec.candidates:  # no candidate within the tolerance was judged outside it
        if c.status == "converged" and c.model in WORST_FIRST and c.worst_error is not None:
            assert c.qualifies == (remeasured(case, c.model, "fem-auto") <= tol), c.model


def classic(original):
    """The mutant yardstick: translations over L, rotations in rad (the old ``error_L``)."""

    def by_length(ref, length, floors=None):
        stick = original(ref, length, floors)
        points = {Y.point(k) for k in ref} - {None}
        scale = {}
        for k, v in stick.scale.items():
            if k in points or (Y.point(k) and Y.quantity(k) in Y.TRANSLATIONS):
                scale[k] = length
            else:
                scale[k] = 1.0 if Y.quantity(k) == "rot" else v
        return dataclasses.replace(stick, scale=scale)

    return by_length


@pytest.mark.parametrize("case", [PG, XP])
def test_mutant_yardstick_recommends_outside_the_tolerance(case: str, monkeypatch):
    """Proof that the test above has teeth: with translations divided by L again (and
    rotations in rad), the recommender takes the cheap prb-3r-force, which misses the judged
    output by 16.5 % (guide: 0.4 % of L) or 5 % (pivot: 1.5e-3 rad) at a 1 % tolerance."""
    monkeypatch.setattr(Y, "yardstick", classic(Y.yardstick))
    rec = recommend(cases.load(case), 1e-2, cost=worst_first)
    assert rec.recommended in WORST_FIRST, rec.reason
    assert remeasured(case, rec.recommended) > 1e-2


# -- units --------------------------------------------------------------------------------------
def test_fixture_is_the_guide_in_metres():
    mm, m = cases.load(PG), cases.load(PG_M)
    assert (mm.units, m.units) == ("mm-N-MPa", "m-N-Pa")
    for a, b in zip(mm.nodes, m.nodes, strict=True):
        assert (a.id, a.x / 1e3, a.y / 1e3) == pytest.approx((b.id, b.x, b.y))
    for a, b in zip(mm.members, m.members, strict=True):
        assert a.id == b.id and a.kind == b.kind
        if a.kind == "flexible":
            assert (a.EI * 1e-6, a.EA) == pytest.approx((b.EI, b.EA))
    assert [(ld.fx, ld.fy, ld.moment) for ld in mm.loads] == [
        (ld.fx, ld.fy, ld.moment) for ld in m.loads
    ]
    for a, b in zip(mm.references, m.references, strict=True):
        assert a.value / 1e3 == pytest.approx(b.value) and a.tolerance == b.tolerance
    assert mm.tolerances[0].rel == m.tolerances[0].rel


@pytest.mark.parametrize("model", ["prb-fsm-2", "prb-2r", "bcm"])
def test_error_rel_is_the_same_in_metres(model: str):
    pe_mm = path_errors(PG, model)
    pe_m = path_errors(PG_M, model)
    for key in ("stage.ux", "stage.uy"):
        assert pe_m["per_output"][key] == pytest.approx(pe_mm["per_output"][key], rel=1e-5)
    assert pe_m["summary"] == pytest.approx(pe_mm["summary"], rel=1e-5)


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_recommendation_is_the_same_in_metres(tol: float):
    assert _recommend(PG_M, tol).recommended == _recommend(PG, tol).recommended


# -- the yardstick itself -----------------------------------------------------------------------
_paths = st.integers(2, 12).flatmap(
    lambda n: st.lists(
        st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 6), min_size=n, max_size=n
    )
)


def _errors(ref: dict, model: dict, length: float) -> dict[str, float]:
    """error_rel of every output: largest |model - ref| over the yardstick's divisor."""
    stick = Y.yardstick(ref, length)
    return {k: float(np.max(np.abs(model[k] - ref[k]))) / stick.rel(k) for k in ref}


def _split(rows, c: float) -> tuple[dict, dict]:
    """Reference and model paths of a point ``p``: translations scaled by ``c``."""
    a = np.array(rows, dtype=float)
    ref = {"p.ux": c * a[:, 0], "p.uy": c * a[:, 1], "p.rot": a[:, 2]}
    model = {"p.ux": c * a[:, 3], "p.uy": c * a[:, 4], "p.rot": a[:, 5]}
    return ref, model


@settings(max_examples=60, deadline=None)
@given(_paths, st.floats(1e-4, 1e4), st.floats(0.1, 10.0))
def test_error_rel_does_not_depend_on_the_length_unit(rows, c: float, length: float):
    """Every translation (and L) times c > 0, rotations unchanged: the same error_rel (mm vs m
    is c = 1e-3), floors included."""
    ref1, mod1 = _split(rows, 1.0)
    ref_c, mod_c = _split(rows, c)
    e1, ec = _errors(ref1, mod1, length), _errors(ref_c, mod_c, c * length)
    assert ec == pytest.approx(e1, rel=1e-9, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(_paths, st.floats(1e-6, 1e6), st.sampled_from([0.0, 1e-300, 1e-18]))
def test_a_path_that_never_moves_never_divides_by_zero(rows, length: float, tiny: float):
    """A reference whose excursion is zero (or round-off) is judged against a floor: every
    divisor is positive and at least round-off of L (translations) or 1e-6 rad, and every
    error of a finite model is finite."""
    a = np.array(rows, dtype=float)
    ref = {"p.ux": tiny * a[:, 0], "p.uy": np.zeros(len(a)), "p.rot": tiny * a[:, 2]}
    ref["factor"] = np.zeros(len(a))
    stick = Y.yardstick(ref, length)
    assert stick.rel("p.ux") >= Y.ROUNDOFF_FRACTION * length
    assert stick.rel("p.rot") >= Y.ROUNDOFF_FRACTION and stick.rel("factor") > 0
    assert {"p.ux", "p.uy", "p.rot", "p"} <= stick.floored
    model = {k: v + a[:, 3] for k, v in ref.items()}
    assert all(math.isfinite(e) for e in _errors(ref, model, length).values())


# -- tolerances from the command line and from case files ----------------------------------------
def test_cli_tol_1_is_refused(capsys):
    assert cli.main(["recommend", PG, "--tol", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "1%" in err[0] and "0.01" in err[0]


def test_cli_absolute_tolerance(capsys, monkeypatch):
    """``--tol stage.uy=abs:0.01`` (mm) judges the stage deflection absolutely: prb-fsm-2's
    0.31 mm miss is out, the pick is within 0.01 mm of fem-auto."""
    # the module (the attribute reports.recommend is the function)
    module = importlib.import_module("reports.verdicts.recommend")
    monkeypatch.setattr(module, "recommend", functools.partial(recommend, cost=unknowns))
    assert cli.main(["recommend", PG, "--tol", "stage.uy=abs:0.01"]) == 0
    out = capsys.readouterr().out
    pick = out.split("recommended: ")[1].split()[0]
    assert pick not in ("prb-fsm-2", "none")
    assert remeasured(PG, pick, "fem-auto") * DELTA <= 0.01
    assert "stage.uy 0.01 abs" in out


@pytest.mark.parametrize(
    "entry, key, reason",
    [
        ('output = "stage.uz"\nrel = 0.01', "tolerances[0].output", "neither an output key"),
        ('output = "stage.uy"\nrel = 0.01\nabs = 0.1', "tolerances[0]", "exactly one of"),
        ('output = "stage.uy"\nrel = 1.0', "tolerances[0].rel", "not a fraction below 1"),
        ('output = "stage.uy"\nrel = 5', "tolerances[0].rel", "not a fraction below 1"),
    ],
)
def test_bad_case_tolerance_is_one_line(tmp_path, capsys, entry: str, key: str, reason: str):
    text = (cases.CATALOG / f"{PG}.toml").read_text()
    head, _, _ = text.partition("[[tolerances]]")
    path = tmp_path / "guide.toml"
    path.write_text(f'{head}[[tolerances]]\n{entry}\nwhy = "test"\n')
    with pytest.raises(CaseError) as exc:
        cases.load(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg and key in msg and reason in msg
    assert cli.main(["recommend", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0] and reason in err[0]


@pytest.mark.parametrize("output", ["driver.force", "energy"])
def test_case_tolerance_on_the_driving_force(tmp_path, output: str):
    """Ex. 5 is designed for its constant driving force: a case naming ``driver.force`` (or
    the energy) as its judged output gets a recommendation whose judged error is measured."""
    text = (cases.CATALOG / "das2d-ex5-constant-force.toml").read_text()
    path = tmp_path / "ex5.toml"
    path.write_text(f'{text}\n[[tolerances]]\noutput = "{output}"\nrel = 0.01\nwhy = "test"\n')
    rec = recommend(cases.load(path), None, cost=unknowns)
    pick = next(c for c in rec.candidates if c.model == rec.recommended)
    assert pick.worst_output == output and pick.worst_error is not None


def test_absolute_error_is_printed_in_case_units():
    rec = _recommend(PG, "stage.uy=abs:0.01")
    assert "%" not in rec.reason.split("worst error ")[1].split("(")[0], rec.reason


def test_text_names_each_judged_output_and_why():
    """The case's [[tolerances]] say which outputs a designer judges and why: the printed
    evidence names them; a value the user typed replaces the number, not the reason's absence."""
    from reports.verdicts.recommendation import format_text

    text = format_text(_recommend(PG, None))
    assert "judged: stage.uy (why: a designer sizes a parallel guide" in text
    assert "judged:" not in format_text(_recommend(PG, "stage.uy=1%"))
