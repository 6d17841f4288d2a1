"""Speed work must not change answers: every model on every catalog case vs a recorded run.

``tests/fixtures/speed_regression.json`` is a REGRESSION fixture, not a verification
reference: it holds what the code of branch ``main`` (commit 2adc420, before the speed work of
issue 12) returned, so that faster solvers, reused factorisations and PRB post-processing
moved out of the solve are shown to leave every reported number where it was, within the
solvers' own tolerances.  Correctness is verified elsewhere (``test_verify_*``) against exact
solutions, published values and the FE reference.  Regenerate only for an intended change of
answers: ``python -m tests.test_speed_regression --write [CASE|MODEL ...]``.  Entries updated
by issue 11 (judge), intended changes of answers only: the FE's stability watch moved the sampled
column-postbuckling fem-N runs from the unstable complementary branch (uy = -0.003 at
1.33 Pcr) onto the stable post-buckled one (uy = 0.739); follower loads get no static
stability verdict (None).  Issue 14: the FE's rigid links are exact constraints, no longer
stiff elements; on scenes with rigid links fem-N answers moved by the old links' compliance
(~1e-6 of the scene's stiffness, up to 8e-6 mm on DAS-2D Ex. 2) and are compared at 1e-5.
Issue 23: the 36 pairs the fixture recorded as not-applicable and the mechanism assembler
answers since issue 9 (they were skipped) were recorded as they are now (``--write`` with
those pairs); nothing is skipped.  Issue 23, item 5: lee-frame|elastica rewritten: the
arc-length corrector polishes its converged state to round-off, so a drawing's iteration
counts no longer differ at tol level; the path is sampled differently after its 82nd step
(step 83 at factor -0.69298 instead of -1.36001, on the same curve).  Issue 23, item 5: an
output's rot at a node whose member ends are all pinned is their mean (cases.node_rotation),
not the first listed member's: only those ``.rot`` values were rewritten (shallow-arch-snap's
apex, 0 by symmetry; thesis-sixbar-config4(-stall)'s J2, J3, J5, J6 under fem-N).  Issue 23,
item 5: chained members are laid out from their ground end (``cases.orient``),
not from the drawn ``from`` end: bistable-toggle|bcm, cbcm-2, cbcm-8 (its right leg) and
lee-frame|linear-2, linear-8, bcm, cbcm-2, cbcm-8 (the beam from the load point to the far
pin) rewritten.  Issue 23, item 5: the arc-length step grows after a corrector that reached
1e3 x its tolerance within 3 iterations (``pathfollow.EASY_RES``), counted above the
residual's round-off floor, not after at most 4 iterations to the tolerance itself: lee-frame's
mechanism paths (elastica, linear-2, linear-8, bcm, cbcm-2, cbcm-8) are sampled at other
points of the same curves (88-202 steps, 0-5 more), their last states unchanged.  The FE's
first arc-length step is rounded to two significant digits (``FEM.ds0``: K^-1 f carried the
tangent's round-off into every later sample): shallow-arch-snap|fem-8, fem-24 sampled at
other points of the same curve, 8 steps as before, the last state unchanged; so is the
mechanism path's first step (``pathfollow.run_path``): shallow-arch-snap|elastica, bcm,
cbcm-2, cbcm-8, prb-2rpr rewritten, their last states unchanged.  The FE's arc-length step
grows or shrinks by the iterations to 1e3 x its tolerance, plus one (``arclength.EASY_RES``),
not by the iterations to its energy test at round-off: lee-frame|fem-8, fem-24 and
shallow-arch-snap|fem-8, fem-24 sampled at other points of the same curves (the shallow
arch's last state unchanged; Lee's frame, cut at 40 steps here, ends elsewhere on its curve;
lee-frame|fem-24 again once a corrector of more than 12 iterations cuts the step).  The
FE's arc-length step counts its iterations to 1e3 x the tolerance interpolated between
iterations, against a tolerance floor measured from the nodes' centroid, and is rounded to
two significant digits (``arclength._crossing``: a column drawn 3.7 off the origin,
mirrored, or turned 37 deg was sampled elsewhere): lee-frame|fem-8, fem-24 (cut at 40
steps: they end elsewhere on their curves) and shallow-arch-snap|fem-8, fem-24 (last
states unchanged) rewritten.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import pytest

import cases
import reports

FIXTURE = Path(__file__).parent / "fixtures" / "speed_regression.json"
MODELS = (
    "elastica",
    "elastica-bvp",
    "linear-2",
    "linear-8",
    "bcm",
    "cbcm-2",
    "cbcm-8",
    "prb-short",
    "prb-1r",
    "prb-2r",
    "prb-3r",
    "prb-3r-force",
    "prb-3r-moment",
    "prb-2rpr",
    "prb-fsm-4",
    "prb-fsm-16",
    "fem-8",
    "fem-24",
)
_FIXTURE = json.loads(FIXTURE.read_text()) if FIXTURE.exists() else {}


# the dynamic replay is slow: two short scenes
REPLAY_CASES = ("cantilever-tip-load", "pure-moment-rollup")


def scene_for(case: str, model: str) -> cases.Scene:
    """The catalog scene, its load ramp shortened to 6 steps (paths to 40) for the FE."""
    scene = cases.load(case)
    if not model.startswith(("fem", "replay", "elastica-bvp")):
        return scene
    a = scene.analysis
    a = dataclasses.replace(a, steps=min(a.steps, 6), max_steps=min(a.max_steps, 40))
    return dataclasses.replace(scene, analysis=a)


# the cases the fixture records (those of the catalog when it was first written); cases added
# since are verified by their own tests (``test_verify_*``)
RECORDED = (
    "bistable-toggle",
    "cantilever-follower-load",
    "cantilever-inclined-compression",
    "cantilever-inclined-tension",
    "cantilever-tip-load",
    "column-postbuckling",
    "das2d-ex2-parallelogram",
    "fixed-guided-beam",
    "lee-frame",
    "pure-moment-rollup",
    "shallow-arch-snap",
    "steel-flexure-1000",
    "thesis-sixbar-config4",
    "thesis-sixbar-config4-stall",
    "thesis-sixbar-config4-sweep-rest",
    "thesis-sixbar-config4-sweep-stiffness",
)


def pairs() -> list[tuple[str, str]]:
    """Every recorded pair: each model on each recorded case, the replay on two.  Fixed by
    this list, not by the fixture: a pair the fixture lacks (or a missing fixture) fails."""
    return [(c, m) for c in RECORDED for m in MODELS] + [(c, "replay") for c in REPLAY_CASES]


def record(case: str, model: str) -> dict:
    """Status and every step's factor, outputs, energy, stability and stress."""
    sol = reports.solve(scene_for(case, model), model)
    steps = [
        {
            "factor": _r(s.factor),
            "outputs": {k: _r(v) for k, v in s.outputs.items()},
            "energy": _r(s.energy),
            "stable": s.stable,
            "max_stress": _r(s.max_stress),
            "limit_point": bool(s.info.get("limit_point")),
        }
        for s in sol.steps
    ]
    return {"status": sol.status, "n_steps": len(steps), "steps": _sample(steps)}


def _r(v: float | None) -> float | None:
    """12 significant digits: far below every tolerance used here, half the fixture size."""
    return None if v is None else float(f"{v:.12g}")


def _sample(steps: list) -> list:
    """First, last and about every fifth step (keeps the fixture small)."""
    keep = sorted({0, len(steps) - 1, *range(0, len(steps), max(1, len(steps) // 5))})
    return [steps[i] for i in keep if 0 <= i < len(steps)]


def _close(a: float | None, b: float | None, tol: float) -> bool:
    if a is None or b is None:
        return a is b
    if not (math.isfinite(a) and math.isfinite(b)):
        return (math.isnan(a) and math.isnan(b)) or a == b
    return abs(a - b) <= tol * max(1.0, abs(b))


def tolerance(model: str) -> float:
    """Relative (to max(1, |value|)) agreement asked of a model: its solver tolerance.

    Newton models stop at updates below 1e-6 (quadratic convergence leaves far less);
    the replay settles to its static tolerance after a damped transient.
    """
    return 1e-4 if model == "replay" else 1e-6


@pytest.mark.parametrize("case,model", pairs())
def test_same_answers_as_before(case: str, model: str) -> None:
    before = _FIXTURE.get(f"{case}|{model}")
    if before is None:
        pytest.fail(f"{case}|{model} missing from the regression fixture {FIXTURE}")
    now = record(case, model)
    assert now["status"] == before["status"]
    assert now["n_steps"] == before["n_steps"]
    tol = tolerance(model)
    if model.startswith("fem") and any(m.kind == "rigid" for m in cases.load(case).members):
        tol = max(tol, 1e-5)  # exact rigid links since issue 14 (module docstring)
    # PRB stress is now recovered from the PRB's own forces (not the elastica): not compared
    own_stress = model.startswith("prb")
    for s, b in zip(now["steps"], before["steps"]):
        assert _close(s["factor"], b["factor"], tol)
        # at a refined limit point the lowest eigenvalue is zero: its sign (the flag) is
        # round-off, so only away from limit points must the flag be the same
        if not s.get("limit_point"):
            assert s["stable"] == b["stable"], f"stability at factor {b['factor']}"
        assert _close(s["energy"], b["energy"], tol), "energy"
        if not own_stress:
            assert _close(s["max_stress"], b["max_stress"], tol), "max_stress"
        assert set(s["outputs"]) == set(b["outputs"])
        for k, v in b["outputs"].items():
            assert _close(s["outputs"][k], v, tol), f"{k} at factor {b['factor']}"


if __name__ == "__main__" and "--write" in sys.argv:
    # ``--write``: every pair; ``--write CASE|MODEL ...``: only those (an intended change)
    only = set(sys.argv[sys.argv.index("--write") + 1 :])
    data = dict(_FIXTURE)
    for c, m in pairs():
        if not only or f"{c}|{m}" in only:
            data[f"{c}|{m}"] = record(c, m)
    FIXTURE.write_text(json.dumps(data, separators=(",", ":"), sort_keys=True) + "\n")
    print(f"wrote {len(data)} pairs to {FIXTURE}")
