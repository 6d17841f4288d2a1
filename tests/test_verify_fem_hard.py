"""Hard cases for the FE reference: limit points, snap-back, snap-through, a 1000-element
stiff flexure and a one-step roll-up.  Expected values are published numbers or closed forms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import cases
from cases.schema import Analysis
from fem_reference.assembly import build
from fem_reference.auto import FEMAuto
from fem_reference.models import FEM
from fem_reference.statics.newton import lu_of
from reduced_models.base import load_factors
from reduced_models.beam.elastica import tip_dead_force

# Lee's frame, first limit load P L^2/EI as commonly quoted for the 120 x 120 frame
# (E = 720, A = 6, I = 2): 18.5 (e.g. Schweizerhof & Wriggers, CMAME 59:261, 1986; the 3-digit
# value quoted across the corotational literature).  The issue asks for 0.5 %.
LEE_FIRST_LIMIT = 18.5


@pytest.fixture(scope="module")
def lee():
    sc = cases.load("lee-frame")
    return FEMAuto(sequence=(10, 20, 40)).solve(sc)


def test_lee_frame_limit_loads_and_snap_back(lee):
    assert lee.ok, lee.message
    lps = lee.extras["limit_points"]
    kinds = [lp["kind"] for lp in lps]
    assert kinds == ["max", "min"], kinds
    first, second = lps
    assert first["factor_extrapolated"] == pytest.approx(LEE_FIRST_LIMIT, rel=5e-3)
    # the mesh error of the limit loads converges at the element's order
    assert abs(first["order"] - 2.0) < 0.3 and abs(second["order"] - 2.0) < 0.3
    assert first["error"] < 1e-3 * first["factor_extrapolated"]
    # the second limit point lies at a negative load (the frame pulls back after snapping)
    assert second["factor_extrapolated"] < -5.0
    lam = lee.path("factor")
    uy = lee.path("corner.uy")
    # unstable branch between the limit points, stable before and after
    stable = np.array([s.stable for s in lee.steps])
    assert stable[0] and stable[-1] and not stable.all()
    i1 = int(np.argmax(lam))
    assert not stable[i1 + 2]
    # snap-back: the corner's downward deflection reverses along the path before it ends
    duy = np.diff(uy)
    assert (duy < 0).any() and (duy > 0).any()
    # the path ends exactly on the stop criterion
    assert uy[-1] == pytest.approx(-100.0, abs=1e-9)


def arch_P(w, EA=1000.0, b=1.0, h=0.1):
    """Exact von Mises truss load for apex deflection w (downward)."""
    L0, L = math.hypot(b, h), math.hypot(b, h - w)
    return -2.0 * EA * (L - L0) / L0 * (h - w) / L


def test_shallow_arch_snap_through_exact_limit_points():
    sol = FEM(16).solve(cases.load("shallow-arch-snap"))
    assert sol.ok
    dP = lambda w: (arch_P(w + 1e-7) - arch_P(w - 1e-7)) / 2e-7  # noqa: E731
    w1, w2 = brentq(dP, 1e-3, 0.099), brentq(dP, 0.101, 0.199)
    lps = sol.extras["limit_points"]
    assert [lp["kind"] for lp in lps] == ["max", "min"]
    assert lps[0]["factor"] == pytest.approx(arch_P(w1), rel=1e-8)
    assert lps[1]["factor"] == pytest.approx(arch_P(w2), rel=1e-8)
    assert -lps[0]["outputs"]["apex.uy"] == pytest.approx(w1, rel=1e-5)
    for st in sol.steps:  # every path point is on the exact curve
        assert st.factor == pytest.approx(arch_P(-st.outputs["apex.uy"]), abs=1e-9)
    assert sol.steps[-1].factor == pytest.approx(arch_P(0.25), rel=1e-10)


def test_shallow_arch_load_control_snaps_and_lands_on_requested_factors():
    """A load analysis beyond P_max: the solver passes the limit point by arc-length and lands
    exactly on each requested factor on the far (inverted) branch."""
    base = cases.load("shallow-arch-snap")
    sc = type(base)(**{**base.__dict__, "analysis": Analysis(kind="load", steps=5, factor_end=0.5)})
    sol = FEM(8).solve(sc)
    assert sol.ok
    assert [s.factor for s in sol.steps] == load_factors(sc).tolist()
    snapped = [s for s in sol.steps if s.info.get("snap")]
    assert len(snapped) == 1 and snapped[0].factor == pytest.approx(0.4)
    for st in sol.steps:
        w = -st.outputs["apex.uy"]
        assert arch_P(w) == pytest.approx(st.factor, abs=1e-9)
        assert st.stable
    assert -sol.steps[4].outputs["apex.uy"] > 0.2  # on the inverted branch


def plain_newton_diverges(system, steps=10, max_iter=60):
    """Textbook Newton: 10 equal load steps, tangent predictor, no cutting or damping."""
    u = np.zeros(system.ndof)
    for k in range(1, steps + 1):
        lam = k / steps
        for _ in range(max_iter):
            r, K = system.residual_and_tangent(u, lam)
            if not np.all(np.isfinite(r)):
                return True
            if np.linalg.norm(r) < 1e-6 * np.linalg.norm(system.external(u)):
                break
            u = u + lu_of(system, K).solve(-r)
        else:
            return True
    return False


def test_steel_flexure_1000_elements_solves_where_plain_newton_diverges():
    sc = cases.load("steel-flexure-1000")
    mem = sc.members[0]
    EI = mem.E * mem.I
    P = -sc.loads[0].fy
    assert P * 100.0**2 / EI == pytest.approx(10.0)
    assert mem.E * mem.A * 100.0**2 / EI == pytest.approx(1.2e5)
    system = build(sc, 1000)
    assert plain_newton_diverges(system)
    sol = FEM(1000).solve(sc)
    assert sol.ok, sol.message
    assert [s.factor for s in sol.steps] == load_factors(sc).tolist()
    for st in sol.steps[1:]:
        x, y, th = tip_dead_force(100.0, EI, 0.0, -st.factor * P)
        o = st.outputs
        # inextensible elastica vs EA L^2/EI = 1.2e5: the axial strain is below 1e-4
        assert o["tip.x"] == pytest.approx(x, abs=1e-2)
        assert o["tip.y"] == pytest.approx(y, abs=1e-2)
        assert o["tip.rot"] == pytest.approx(th, abs=1e-4)
        assert st.stable


def test_rollup_to_two_pi_in_one_reported_step():
    sc = cases.load("pure-moment-rollup")
    one = type(sc)(**{**sc.__dict__, "analysis": Analysis(kind="load", steps=1)})
    sol = FEM(64, stability=False).solve(one)
    assert sol.ok
    tip = sol.steps[-1].outputs
    assert tip["tip.rot"] == pytest.approx(2 * math.pi, abs=1e-12)
    assert abs(tip["tip.x"]) < 1e-10 and abs(tip["tip.y"]) < 1e-10
    assert sol.steps[-1].iterations < 200


def test_fine_mesh_converges_at_its_round_off_floor():
    """1024 elements, EA L^2/EI = 1e4: the bending entries 12 EI / L0^3 ~ 1e10 set the
    residual's round-off floor; with an axial-only floor Newton stalled just above it and the
    FE failed (regression of the no-slack convergence test).  The converged tip agrees with
    the 256-element mesh to its O(h^2) discretisation error."""
    import reports

    scene = cases.load("cantilever-tip-load")
    fine = reports.solve(scene, "fem-1024")
    assert fine.status == "converged", fine.message
    coarse = reports.solve(scene, "fem-256")
    d = abs(fine.steps[-1].outputs["tip.uy"] - coarse.steps[-1].outputs["tip.uy"])
    assert d < 1e-5
