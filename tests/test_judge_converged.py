"""Converged means right (issue 23): scenes written outside the project where a ``converged``
answer was wrong or a snap went unreported, each checked against an exact answer."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import cases
import reports

FIXTURES = Path(__file__).parent / "fixtures"
R2, R3, X_C = 40.2, 107.1, 140.0111793630614  # DAS-2D Ex. 5: crank, coupler, drawn slider x
B0 = np.array([34.814221232134436, 20.1])  # drawn crank tip


def _link_lengths(step: object) -> tuple[float, float]:
    """Crank |OB| and coupler |BC| of a DAS-2D Ex. 5 state (O fixed, C on the x axis)."""
    o = step.outputs
    b = B0 + (o["crank_tip.ux"], o["crank_tip.uy"])
    c = np.array([X_C + o["slider.ux"], o["slider.uy"]])
    return float(np.hypot(*b)), float(np.hypot(*(c - b)))


@pytest.mark.parametrize(
    ("model", "reason"),
    [("replay", "rigid link"), ("fem-8", "rigid link"), ("kinetostatic", "near t = -73.1")],
)
def test_slider_driven_past_reach_keeps_rigid_links_or_fails_with_the_reason(model, reason):
    """The slider cannot come closer than r3 - r2 = 66.9 mm to the crank pivot, i.e. past
    -73.11 mm: every returned state keeps both links at their lengths and the run fails there."""
    sol = reports.solve(cases.load(str(FIXTURES / "das2d-ex5-past-reach.toml")), model)
    assert sol.status == "failed"
    assert reason in sol.message
    for st in sol.steps:
        crank, coupler = _link_lengths(st)
        assert crank == pytest.approx(R2, rel=1e-4)
        assert coupler == pytest.approx(R3, rel=1e-4)
    reach = (R3 - R2) - X_C
    assert reach <= min(st.factor for st in sol.steps) <= reach + 2.5  # fails at the reach
    assert math.isfinite(sol.steps[-1].outputs["driver.force"])


def column(multiple: float, imperfection: float, steps: int = 40) -> object:
    """The catalog's cantilever column (EI = L = 1) loaded to ``multiple`` x Euler, with a
    transverse tip force ``imperfection`` x P."""
    base = cases.load("column-postbuckling")
    P = multiple * math.pi**2 / 4.0
    load = dataclasses.replace(base.loads[0], fx=-P, fy=imperfection * P)
    a = dataclasses.replace(base.analysis, steps=steps)
    return dataclasses.replace(base, loads=(load,), analysis=a, references=())


def test_elastica_on_a_column_with_a_tiny_imperfection_has_no_nan_step():
    """Below Euler the exact answer of the imperfect column is linear in the imperfection Q:
    v(L) = Q (tan kL - kL) / (P k), v'(L) = Q (sec kL - 1) / P, k = sqrt(P/EI) (Timoshenko &
    Gere 1961, Sec. 1.11); at 2 x Euler the post-buckled elastica, tip angle 2 asin k."""
    sol = reports.solve(column(2.0, 1e-9), "elastica")
    assert sol.status == "converged"
    assert all(math.isfinite(v) for st in sol.steps for v in st.outputs.values())
    for st in sol.steps:
        P = st.factor * 2.0 * math.pi**2 / 4.0
        if 0.0 < P < 0.9 * math.pi**2 / 4.0:
            k, Q = math.sqrt(P), 1e-9 * P
            assert st.outputs["tip.uy"] == pytest.approx(Q * (math.tan(k) - k) / (P * k), 1e-6)
            assert st.outputs["tip.rot"] == pytest.approx(Q * (1 / math.cos(k) - 1) / P, 1e-6)
    assert sol.steps[-1].outputs["tip.rot"] == pytest.approx(2.1738542409403347, rel=1e-6)


class _NaNModel:
    """A model that reports ``converged`` with a NaN output at its second step."""

    name = "nan-model"

    def applies_to(self, scene):  # noqa: ANN001, ANN201
        return None

    def solve(self, scene):  # noqa: ANN001, ANN201
        from reduced_models.base import Solution, Step

        steps = tuple(Step(f, {"tip.ux": v}) for f, v in ((0.0, 0.0), (0.5, math.nan)))
        return Solution(scene.name, self.name, "converged", "", steps)


def test_a_converged_solution_with_a_nan_output_is_failed_with_the_reason():
    sol = reports.solve("cantilever-tip-load", _NaNModel())
    assert sol.status == "failed"
    assert "tip.ux" in sol.message and "0.5" in sol.message
    assert [st.factor for st in sol.steps] == [0.0]  # the states up to the bad one


@pytest.mark.parametrize("model", ["elastica", "replay", "cbcm-4", "linear-8", "bcm", "fem-8"])
def test_tip_driven_to_six_lengths_is_declined_by_every_model_with_the_reason(model):
    """A cantilever of length 1 whose tip is driven 5 along its axis: the chord root-tip is 6,
    so the member is stretched by at least 500 %, far beyond the 20 % of any elastic model
    here (``cases.limits.STRAIN_MAX``).  States up to 20 % may be returned, none beyond."""
    from cases.schema import Driver
    from tests.test_verify_linear_bcm import beam_scene

    scene = beam_scene(1.0, 0.0, A=1.0, steps=4)
    drive = Driver("displacement", 0.0, 5.0, node="B", direction="x")
    a = dataclasses.replace(scene.analysis, kind="distance", driver=drive)
    sol = reports.solve(dataclasses.replace(scene, analysis=a), model)
    assert sol.status == "failed"
    assert "strained by" in sol.message and "bound 0.2" in sol.message
    assert all(st.outputs["tip.ux"] <= 0.2 for st in sol.steps)


def pinned_root_beam() -> object:
    """A beam pinned (end 'pin') to its clamped root, a tip force straight down: it hangs."""
    base = cases.load("cantilever-tip-load")
    beam = dataclasses.replace(base.members[0], end_a="pin")  # L = E = I = 1, A = 1e4
    load = dataclasses.replace(base.loads[0], fx=0.0, fy=-1.0)
    a = dataclasses.replace(base.analysis, kind="load", steps=10)
    return dataclasses.replace(
        base, members=(beam,), loads=(load,), analysis=a, references=(), models=()
    )


@pytest.mark.parametrize("model", ["fem-2", "fem-16"])
def test_a_pinned_root_beam_hangs_at_minus_a_quarter_turn_not_24_turns_more(model):
    """The pinned beam swings from horizontal to hanging straight down under any tip force:
    tip rotation -pi/2 exactly (the force is then axial: no bending), continuous from the
    initial 0 -- not -pi/2 + 2 pi k of an arc-length that went round the circle of
    equilibria at factor ~0 before landing (the branch switch past the bifurcation at 0)."""
    sol = reports.solve(pinned_root_beam(), model)
    assert sol.status == "converged"
    for st in sol.steps[1:]:
        assert st.outputs["tip.rot"] == pytest.approx(-math.pi / 2, abs=1e-6)


@pytest.mark.parametrize(
    ("multiple", "imperfection", "area"),
    [(6.0, 1e-3, 1e4), (3.0, 1e-4, 1e4), (2.0, 1e-2, 1e4), (6.0, 1e-3, 1e5), (4.0, 1e-5, 1e3)],
)
@pytest.mark.parametrize("model", ["fem-16", "fem-auto"])
def test_an_imperfect_column_stays_on_its_natural_path(model, multiple, imperfection, area):
    """The natural path of an imperfect column has no limit point: it bends smoothly through
    the Euler load onto the post-buckled elastica.  A load step across the Euler load that
    lands on the complementary (unstable, nearly straight) branch is a step too large, not a
    limit point.  The FE ends where the exact elastica of the same imperfect scene ends
    (6 x Euler, 1e-3: tip uy 0.518, rot 2.97), within its axial stretch P/EA and mesh error."""
    base = column(multiple, imperfection)
    scene = dataclasses.replace(base, members=(dataclasses.replace(base.members[0], A=area),))
    exact = reports.solve(scene, "elastica").steps[-1].outputs
    sol = reports.solve(scene, model)
    assert sol.status == "converged", sol.message
    assert sol.extras.get("reference_usable", True) is True, sol.message
    assert all(st.stable for st in sol.steps)
    last = sol.steps[-1].outputs
    mesh = {"fem-16": 5e-3, "fem-auto": 1e-4}[model]  # fem-16: 2.5e-3 measured at 1e5
    tol = 2 * multiple * math.pi**2 / 4 / area + mesh  # + the stretch P/EA the elastica lacks
    assert last["tip.uy"] == pytest.approx(exact["tip.uy"], rel=tol)
    assert last["tip.rot"] == pytest.approx(exact["tip.rot"], rel=tol)


def test_a_load_ramp_past_the_limit_of_a_von_mises_arch_reports_the_snap():
    """Shallow arch (von Mises truss, EA 1000, half-span 1, rise 0.1) loaded past its limit
    load: the snap is reported at the exact limit load P(w1) = max P, from the apex
    deflection w1 to the far branch's w at the same load (closed form P(w))."""
    from scipy.optimize import brentq

    from fem_reference.models import FEM
    from tests.test_verify_fem_hard import arch_P

    base = cases.load("shallow-arch-snap")
    a = dataclasses.replace(base.analysis, kind="load", steps=5, factor_end=0.5)
    sol = FEM(8).solve(dataclasses.replace(base, analysis=a))
    assert sol.ok
    (snap,) = [p for p in sol.extras["critical_points"] if p["kind"] == "snap"]
    dP = lambda w: (arch_P(w + 1e-7) - arch_P(w - 1e-7)) / 2e-7  # noqa: E731
    w1 = brentq(dP, 1e-3, 0.099)
    w_far = brentq(lambda w: arch_P(w) - arch_P(w1), 0.2, 0.3)
    assert snap["factor"] == pytest.approx(arch_P(w1), rel=1e-8)
    assert -snap["from"]["apex.uy"] == pytest.approx(w1, rel=1e-5)
    assert -snap["to"]["apex.uy"] == pytest.approx(w_far, rel=1e-6)
    assert "snap at factor" in sol.message


# critical factor against the elastica's: fem-8's own mesh error (measured 6.3e-3), and
# fem-auto's Richardson-extrapolated factor (its estimate 1.2e-7)
EX3_FACTOR_RTOL = {"fem-8": 1e-2, "fem-auto": 1e-6}


@pytest.mark.parametrize("model", ["fem-8", "fem-auto"])
def test_das2d_ex3_ramped_to_15_n_says_where_it_snaps(model):
    """DAS-2D Ex. 3 as the seed runs it (Fx ramped to 15 N, shuttle unguided).  Its symmetric
    path meets a subcritical bifurcation first (the elastica: 0.43203, where it snaps): no
    stable state lies next to it, so the model must switch there by energy descent and report
    the snap at that factor, from the symmetric state (1.595 mm of travel in the elastica) to
    the far branch beyond the second stable position (15.25 mm; the elastica lands at 18.11 mm
    one step later)."""
    ramp = cases.load(str(FIXTURES / "das2d-ex3-load-ramp.toml"))
    sol = reports.solve(ramp, model)
    assert sol.status == "converged"
    points = sol.extras["critical_points"]
    (bif,) = [p for p in points if p["kind"] == "bifurcation"]
    (snap,) = [p for p in points if p["kind"] == "snap"]
    elastica = reports.solve(ramp, "elastica")
    (exact,) = [p for p in elastica.extras["critical_points"] if p["kind"] == "snap"]
    assert bif["switched"]
    assert snap["factor"] == pytest.approx(bif["factor"], rel=1e-12)
    factor = bif.get("factor_extrapolated", bif["factor"])
    assert factor == pytest.approx(exact["factor"], rel=EX3_FACTOR_RTOL[model])
    ux = {end: exact[end]["outputs"]["shuttle_top.ux"] for end in ("from", "to")}
    assert snap["from"]["shuttle_top.ux"] == pytest.approx(ux["from"], rel=0.02)
    to = snap["to"]["shuttle_top.ux"]  # at the critical factor; the elastica's one step on
    assert to > 15.25 and to == pytest.approx(ux["to"], rel=0.01)
    assert "snap at factor" in sol.message and "subcritical bifurcation passed" in sol.message


@pytest.mark.parametrize("model", ["linear-4", "linear-8"])
def test_a_path_put_on_a_branch_by_round_off_at_a_singular_start_is_declined(model):
    """DAS-2D Ex. 3 driven by its shuttle with every member a linear chain: straight
    inextensible segments cannot shorten at first order, the drawn state's tangent is
    singular (no stability verdict), and the first step landed on an unstable equilibrium
    whose driving force (8.5, 2.1 or 1.6 N) depended on the CPU's BLAS and on how the scene
    was drawn -- the elastica's path starts stable at 0.15 N.  Declined with the reason."""
    scene = cases.load("das2d-ex3-bistable-switch")
    exact = reports.solve(scene, "elastica")
    assert exact.ok and exact.steps[1].stable and exact.steps[1].factor < 0.2
    sol = reports.solve(scene, model)
    assert sol.status == "failed"
    assert "singular" in sol.message and "picked by round-off" in sol.message


def test_a_state_exactly_at_the_strain_bound_is_within_it_in_every_unit_system():
    """A pinned-slider column whose mid node the replay's servo drives to exactly 20 %
    shortening of its lower half (``cases.limits.STRAIN_MAX``): in one unit system round-off
    put the strain at 0.2 + 1e-16 and the replay failed there, in mm it converged.  A bound
    is passed only by more than round-off (``cases.limits.beyond``): both converge, and the
    last state is the bound itself."""
    for name in ("col-pinned-shortened-to-20pc", "col-pinned-shortened-to-20pc--mm"):
        sol = reports.solve(cases.load(str(FIXTURES / f"{name}.toml")), "replay")
        assert sol.status == "converged", (name, sol.message)
        scale = 1000.0 if name.endswith("--mm") else 1.0
        assert sol.steps[-1].outputs["m.uy"] / scale == pytest.approx(-0.1, rel=1e-9)
