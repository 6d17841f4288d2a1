"""Where the FE lands after a snap, the same on every mesh and in every encoding.

Scenes from the outside review of issue 23 (``tests/hostile_review.py``), kept as fixtures:
a bistable switch of two flexible legs and a rigid shuttle ramped past its snap, made
asymmetric (one long leg 3 % thicker: an imperfect bifurcation, i.e. a limit point) and,
in a second scene, symmetric but loaded off the shuttle's middle.  Truth: the elastica of the
same scene (a limit point at 0.18011 and 0.15737, measured when these tests were written,
and the far branch beyond the unloaded second stable position); the scenes drawn rotated and
in mm give the same answer transformed back.  And a shallow arch traced by arc-length in
thousandths of its units, which must trace the path the catalog case traces.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import cases
import reports

FIXTURES = Path(__file__).parent / "fixtures"
ASYM = "bistable-asym-m-n-pa"
ENCODED = {  # file -> (length unit factor, force unit factor) against the drawn scene
    ASYM: (1.0, 1.0),
    ASYM + "--rot37": (1.0, 1.0),
    ASYM + "--units-mm-N-MPa_L1000_F1": (1000.0, 1.0),
}
ELASTICA_LIMIT = {ASYM: 0.18011022, "bistable-offload-m-n-pa": 0.15737276}


def _solve(name: str, model: str):
    return reports.solve(cases.load(str(FIXTURES / f"{name}.toml")), model)


def _snap(sol) -> dict:
    assert sol.status == "converged", sol.message
    kinds = [p["kind"] for p in sol.extras["critical_points"]]
    assert kinds == ["limit", "snap"], kinds  # a limit point, not a "bifurcation"
    return sol.extras["critical_points"][1]


@pytest.mark.parametrize("model", ["fem-8", "fem-auto"])
def test_an_imperfect_switch_snaps_at_its_limit_point_in_every_encoding(model):
    """fem-8 before: a 'subcritical bifurcation (not located)' at 0.18638 drawn as is and
    rotated, and load control stalled at 0.354 in mm; fem-auto: a limit point drawn as is, a
    bifurcation at 0.18491 rotated (600 x its own estimate away)."""
    snaps, travel = [], []
    for name, (lf, _) in ENCODED.items():
        sol = _solve(name, model)
        snap = _snap(sol)  # fem-auto: the Richardson-extrapolated factor where it has one
        snaps.append(snap.get("factor_extrapolated", snap["factor"]))
        travel.append([st.outputs["kn.rot"] for st in sol.steps])
        assert all(st.stable for st in sol.steps)
        assert sol.steps[-1].outputs["sh.ux"] / lf > 0.02  # beyond the second stable position
    assert max(snaps) - min(snaps) <= 1e-9 * snaps[0]
    for other in travel[1:]:
        assert other == pytest.approx(travel[0], abs=1e-8)
    fe_mesh_error = {"fem-8": 1e-2, "fem-auto": 1e-5}[model]  # measured: 6e-3, 2e-7
    assert snaps[0] == pytest.approx(ELASTICA_LIMIT[ASYM], rel=fe_mesh_error)


def test_every_fem_auto_mesh_lands_on_the_far_branch():
    """Off-middle load: before, fem-16 landed on the far branch and fem-32/64 on an
    intermediate one (7.3 mm), and fem-auto returned 1.35-2.5 mm at factors 0.2-0.3, flagged
    unstable, where the elastica is at 22-23 mm."""
    sol = _solve("bistable-offload-m-n-pa", "fem-auto")
    snap = _snap(sol)
    assert snap["factor"] == pytest.approx(ELASTICA_LIMIT["bistable-offload-m-n-pa"], rel=1e-4)
    assert not sol.extras.get("off_branch")
    for st in sol.steps:
        assert st.stable
        if st.factor >= 0.2:
            assert st.outputs["sh.ux"] > 0.0215  # the elastica: 0.0220 at 0.2, rising


@pytest.mark.parametrize("model", ["fem-16", "fem-64"])
def test_an_arch_in_other_units_is_traced_over_its_fold(model):
    """The arc-length step that passes the arch's fold ended on the unstable side, where the
    stability watch took it for a bifurcation (located by re-solving across the fold) and
    branched off backwards (fem-64 wandered to factor -238 and failed); traced on, it meets
    the catalog case's path (units: lengths x 0.01, forces x 1000)."""
    drawn = reports.solve("shallow-arch-snap", model)
    scaled = _solve("shallow-arch-snap--units-nondim_L0.01_F1000", model)
    assert drawn.status == scaled.status == "converged", scaled.message
    kinds = [[p["kind"] for p in sol.extras.get("critical_points", [])] for sol in (drawn, scaled)]
    assert kinds == [[], []] and scaled.message == drawn.message == ""  # no branch point
    assert [st.factor for st in scaled.steps] == pytest.approx(
        [st.factor for st in drawn.steps], rel=1e-8, abs=1e-10
    )


@pytest.mark.parametrize("model", ["fem-8", "replay"])
def test_a_perfect_column_past_euler_stays_straight_between_its_tied_branches(model):
    """A perfect column past Euler has two mirror-image buckled branches of equal energy;
    the mirrored scene is the same scene (translated), so a branch picked by any rule drawn
    from it would be the other branch once mirrored back.  The FE and the replay stay on the
    straight fundamental branch, flagged unstable past the bifurcation (at the Euler load
    pi^2 EI / (4 L^2): factor 1/6 of the 6x-Euler ramp, within the 8-element mesh's error),
    say why, and keep the two branch states; mirrored, the answer is the same.  An imperfect
    column has its own branch (no tie)."""
    perfect = _solve("col-6x-eps0-a10000", model)
    mirrored = _solve("col-6x-eps0-a10000--mirror+shift", model)
    (bif,) = perfect.extras["critical_points"]
    assert bif["kind"] == "bifurcation" and bif["tied"] and not bif["switched"]
    assert bif["factor"] == pytest.approx(1 / 6, rel=5e-3)  # fem-8: 0.35 % (h^2)
    assert "mirror-image branches" in perfect.message
    assert perfect.extras.get("reference_usable") is False
    for st, sm in zip(perfect.steps, mirrored.steps, strict=True):
        assert st.outputs["tip.x"] == pytest.approx(0.0, abs=1e-12)  # straight
        assert sm.outputs["tip.x"] - 3.7 == pytest.approx(0.0, abs=1e-12)
        assert st.outputs["tip.uy"] == pytest.approx(sm.outputs["tip.uy"], abs=1e-12)
        assert st.stable is (st.factor < bif["factor"])
    # rotated 37 deg (no exact symmetry left in the coordinates: a motion along the unstable
    # branch would leave it by round-off): the tip still moves along the column's own axis
    rotated = _solve("col-6x-eps0-a10000--rot37", model)
    sc = cases.load(str(FIXTURES / "col-6x-eps0-a10000--rot37.toml"))
    (a, b) = (sc.node(m) for m in ("A", "B"))
    for st in rotated.steps:
        ux, uy = st.outputs["tip.ux"], st.outputs["tip.uy"]
        assert abs(ux * (b.y - a.y) - uy * (b.x - a.x)) <= 1e-9, st.factor  # buckled: 0.5
    if model == "fem-8":  # the two branches it did not pick: mirror images, buckled
        a, b = bif["branches"]
        assert a["tip.ux"] == pytest.approx(-b["tip.ux"], rel=1e-9) and abs(a["tip.ux"]) > 0.3
    imperfect = _solve("col-6x-eps0-001-a10000", model)
    assert not any(p.get("tied") for p in imperfect.extras.get("critical_points", []))
    assert imperfect.steps[-1].outputs["tip.x"] > 0.3  # leans the way eps pushes it


def _as_path(name: str, stop: str = "tip.uy", value: float = -0.5):
    """The fixture as a path analysis (arc-length) to 6x Euler, stopped at ``stop`` =
    ``value`` (default: the tip's axial travel, which both mirror branches share)."""
    import dataclasses

    sc = cases.load(str(FIXTURES / f"{name}.toml"))
    a = dataclasses.replace(
        sc.analysis, kind="path", stop_output=stop, stop_value=value, max_steps=400
    )
    return dataclasses.replace(sc, analysis=a)


@pytest.mark.parametrize("model", ["fem-8", "fem-auto"])
def test_a_stop_output_the_mirror_flips_picks_the_branch_in_every_drawing(model):
    """Traced to a tip rotation of +1 rad (mirrored: -1 rad), the stop criterion itself picks
    one of the mirror branches -- a rule drawn from the scene, so the mirrored scene picks
    the mirrored branch and the answers agree once mirrored back."""
    drawn = reports.solve(_as_path("col-6x-eps0-a10000", "tip.rot", 1.0), model)
    mirrored = reports.solve(_as_path("col-6x-eps0-a10000--mirror+shift", "tip.rot", -1.0), model)
    for sol in (drawn, mirrored):
        assert sol.status == "converged", sol.message
        (bif,) = sol.extras["critical_points"]
        assert bif["kind"] == "bifurcation" and bif["switched"] and not bif.get("tied")
    assert drawn.steps[-1].outputs["tip.rot"] == pytest.approx(1.0)
    assert drawn.steps[-1].outputs["tip.x"] < -0.3  # a vertical column turned ccw leans to -x
    assert len(drawn.steps) == len(mirrored.steps)
    for a, b in zip(drawn.steps, mirrored.steps):
        assert b.factor == pytest.approx(a.factor, rel=1e-9)
        assert 3.7 - b.outputs["tip.x"] == pytest.approx(a.outputs["tip.x"], abs=1e-9)
        assert -b.outputs["tip.rot"] == pytest.approx(a.outputs["tip.rot"], abs=1e-9)


@pytest.mark.parametrize("model", ["fem-8", "fem-auto"])
def test_a_perfect_column_traced_by_arc_length_ties_its_branches_too(model):
    """A path analysis of the perfect column: before, the arc-length took the branch of the
    mode's + sign (left drawn as is, right mirrored) and then failed, stuck next to the
    bifurcation (400 steps).  Now it ties the mirror branches as a load analysis does: the
    traced path stays straight, unstable past the Euler load, in both drawings."""
    answers = []
    for name, x0 in (("col-6x-eps0-a10000", 0.0), ("col-6x-eps0-a10000--mirror+shift", 3.7)):
        sol = reports.solve(_as_path(name), model)
        assert sol.status == "converged", sol.message
        (bif,) = sol.extras["critical_points"]
        assert bif["kind"] == "bifurcation" and bif["tied"] and not bif["switched"]
        assert "mirror-image branches" in sol.message
        assert sol.steps[-1].factor == pytest.approx(1.0)  # factor_end: straight to the end
        for st in sol.steps:
            assert st.outputs["tip.x"] - x0 == pytest.approx(0.0, abs=1e-12)
            assert st.stable is (st.factor < bif["factor"])
        answers.append([st.outputs["tip.uy"] for st in sol.steps])
    assert answers[1] == pytest.approx(answers[0], abs=1e-12)


@pytest.mark.parametrize("model", ["linear-auto", "bcm"])
def test_a_perfect_column_drawn_along_an_axis_has_no_transverse_load(model):
    """A vertical column's beam frame is the drawn direction dx / L, dy / L (exactly 0 and 1),
    not cos / sin of atan2 (cos(pi/2) = 6e-17 put that much of the axial load across the
    column: past Euler, linear-auto's tip moved 1.3e-14 sideways, and the mirrored drawing
    moved it the other way -- the outside review's flag).  Straight, as drawn and mirrored."""
    for name, x0 in (("col-6x-eps0-a10000", 0.0), ("col-6x-eps0-a10000--mirror+shift", 3.7)):
        sol = _solve(name, model)
        assert sol.status == "converged", sol.message
        assert all(st.outputs["tip.x"] == x0 and st.outputs["tip.rot"] == 0.0 for st in sol.steps)


@pytest.mark.parametrize("model", ["elastica", "elastica-bvp"])
def test_the_elastica_declines_a_perfect_column_past_euler_in_every_drawing(model):
    """Past Euler a perfect column has two mirror branches and the straight one; the exact
    models have no static verdict to pick with, so both the closed form and the collocation
    decline at the first factor past Euler (1/6 of the 6x-Euler ramp), with the reason, in
    every drawing -- the load along the rotated column within 1e-12 rad of its axis is the
    drawing's round-off, not an imperfection (main: elastica-bvp stayed straight past Euler,
    converged, with no stability verdict)."""
    for name in ("col-6x-eps0-a10000", "col-6x-eps0-a10000--rot37"):
        sol = _solve(name, model)
        assert sol.status == "failed" and "perfect axial compression" in sol.message, sol.message
        if model == "elastica-bvp":  # the states below Euler are kept
            assert [st.factor for st in sol.steps] == pytest.approx([k / 24 for k in range(5)])


@pytest.mark.parametrize("model", ["fem-8"])
def test_a_path_is_sampled_the_same_when_the_drawing_is_turned(model):
    """The arc-length step sizing measures the tolerance's round-off floor from the nodes'
    centroid, as a distance: a floor taken from the bounding box (or from the origin) moved
    with a 37-degree turn of the drawing, and a perfect column traced to a tip rotation of
    1 rad (EA L^2/EI = 1e8: the floor sets the tolerance) was sampled elsewhere from its 17th
    step (5e-4 of the factor apart).  Scenes from an outside review, kept as fixtures."""
    drawn = _solve("col-path-rot1-a1e8", model)
    turned = _solve("col-path-rot1-a1e8--rot37", model)
    assert drawn.status == turned.status == "converged"
    assert len(drawn.steps) == len(turned.steps) > 12
    for a, b in zip(drawn.steps, turned.steps):
        assert b.factor == pytest.approx(a.factor, rel=1e-10, abs=1e-12)
        assert b.outputs["tip.rot"] == pytest.approx(a.outputs["tip.rot"], abs=1e-9)
