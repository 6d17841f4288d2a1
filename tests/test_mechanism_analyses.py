"""Mechanism analyses against FE and exact kinematics: MA, synthesis, distance, stability
verdicts, per-member models and honest declines."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import cases
import reports
from cases.schema import Driver, MechanicalAdvantage, Synthesis
from reduced_models.mechanism.synthesis import synthesised_scene
from tests import mech_scenes as M


def _with(scene, **analysis):
    return dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, **analysis))


def test_kinematic_ma_is_the_velocity_ratio():
    """Rigid slider-crank (Ex. 5 as a linkage): ma = ds_in/ds_out along the motion."""
    scene = cases.load("das2d-ex5-constant-force")
    scene = _with(
        scene, kind="kinematics", steps=200, ma=MechanicalAdvantage("crank_tip", "y", "driver")
    )
    sol = reports.solve(scene, "kinetostatic")
    assert sol.status == "converged", sol.message
    x, y, ma = sol.path("factor"), sol.path("crank_tip.y"), sol.path("ma")
    fd = (x[2:] - x[:-2]) / (y[2:] - y[:-2])  # central differences of the exact positions
    np.testing.assert_allclose(ma[1:-1], fd, rtol=1e-3)


def test_energy_ma_without_output_load_is_zero():
    """No load at the output: all input work is stored, F_out = 0 (power balance)."""
    scene = cases.load("das2d-ex5-constant-force")
    sol = reports.solve(_with(scene, ma=MechanicalAdvantage("crank_tip", "y")), "kinetostatic")
    assert np.max(np.abs(sol.path("ma"))) < 1e-9


def test_stiffness_synthesis_checked_by_fem():
    scene = cases.load("das2d-ex2-parallelogram")
    syn = Synthesis("stiffness", ("lower", "upper"), 10.0, "coupler_low.uy")
    scene = _with(scene, kind="synthesis", synthesis=syn)
    sol = reports.solve(scene, "cbcm-8")
    assert sol.status == "converged", sol.message
    info = sol.extras["synthesis"]
    assert info["achieved"] == pytest.approx(10.0, rel=1e-8)
    check = reports.solve(synthesised_scene(scene, info["scale"]), "fem-auto")
    assert check.steps[-1].outputs["coupler_low.uy"] == pytest.approx(10.0, rel=2e-3)


def test_critical_load_synthesis_checked_by_fem():
    scene = M.fourbar(M.ENERGY.replace("steps = 120", "steps = 40"))
    scene = _with(scene, kind="synthesis", synthesis=Synthesis("critical-load", ("rocker",), 5.0))
    sol = reports.solve(scene, "cbcm-4")
    assert sol.status == "converged", sol.message
    scale = sol.extras["synthesis"]["scale"]
    fe = reports.solve(synthesised_scene(scene, scale), "fem-16")
    assert fe.status == "converged", fe.message
    assert np.max(np.abs(fe.path("driver.torque"))) == pytest.approx(5.0, rel=0.02)


def test_distance_analysis_matches_fem():
    scene = cases.load("das2d-ex2-parallelogram")
    drv = Driver("displacement", 0.0, 20.0, node="C1", direction="y")
    scene = _with(scene, kind="distance", steps=8, driver=drv)
    red, fe = reports.solve(scene, "cbcm-8"), reports.solve(scene, "fem-32")
    assert red.status == fe.status == "converged", (red.message, fe.message)
    np.testing.assert_allclose(red.path("factor"), fe.path("factor"), rtol=5e-3, atol=1e-6)
    np.testing.assert_allclose(red.path("coupler_low.uy"), np.linspace(0, 20, 9), atol=1e-9)


def test_bistable_toggle_verdicts_agree_with_fe_tangent():
    """Apex driven down through both limit points (distance analysis: the load factor is the
    unknown, stability judged under load control)."""
    scene = cases.load("bistable-toggle")
    drv = Driver("displacement", 0.0, -0.24, node="C", direction="y")
    scene = _with(scene, kind="distance", steps=24, driver=drv)
    red, fe = reports.solve(scene, "cbcm-4"), reports.solve(scene, "fem-16")
    assert red.status == fe.status == "converged", (red.message, fe.message)
    v_red = [s.stable for s in red.steps]
    v_fe = [s.stable for s in fe.steps]
    assert True in v_fe and False in v_fe, "the path crosses both limit points"
    assert v_red == v_fe
    np.testing.assert_allclose(red.path("factor"), fe.path("factor"), atol=0.02)


def test_mixed_models_per_member():
    scene = cases.load("das2d-ex2-parallelogram")
    lower, upper, coupler = scene.members
    same = dataclasses.replace(
        scene,
        members=(
            dataclasses.replace(lower, model="cbcm-2"),
            dataclasses.replace(upper, model="cbcm-2"),
            coupler,
        ),
    )
    a, b = reports.solve(same, "mixed"), reports.solve(scene, "cbcm-2")
    np.testing.assert_allclose(a.path("coupler_low.uy"), b.path("coupler_low.uy"), rtol=1e-12)
    mix = dataclasses.replace(
        same, members=(dataclasses.replace(lower, model="prb-3r"), *same.members[1:])
    )
    sol = reports.solve(mix, "mixed")
    assert sol.status == "converged", sol.message
    assert reports.solve(scene, "mixed").status == "not-applicable"


def test_honest_declines():
    ex5, ex2 = cases.load("das2d-ex5-constant-force"), cases.load("das2d-ex2-parallelogram")
    assert "no flexible member" in reports.solve(ex5, "cbcm-2").message
    assert "flexible" in reports.solve(ex2, "kinetostatic").message
    fol = dataclasses.replace(
        ex2, loads=tuple(dataclasses.replace(ld, follower=True) for ld in ex2.loads)
    )
    sol = reports.solve(fol, "cbcm-2")
    assert sol.status == "not-applicable" and "follower" in sol.message
    assert "two joints" in reports.solve(ex2, "prb-1r").message


def test_replay_moves_the_driver_and_matches_fem():
    """Energy analysis replayed as a prescribed, slowly ramped driver motion."""
    scene = M.fourbar(M.ENERGY.replace("steps = 120", "steps = 4"))
    rep, fe = reports.solve(scene, "replay"), reports.solve(scene, "fem-32")  # same mesh
    assert rep.status == fe.status == "converged", (rep.message, fe.message)
    T_rep, T_fe = rep.path("driver.torque"), fe.path("driver.torque")
    np.testing.assert_allclose(T_rep, T_fe, rtol=0, atol=1e-5 * np.max(np.abs(T_fe)))
    assert [p["stable"] for p in rep.extras["probes"]] == [s.stable for s in fe.steps]


@pytest.mark.parametrize("model", ["kinetostatic", "fem-16"])
def test_toggle_ma_closed_form(model):
    """ma = F_out / F_in = -1 / (2 tan alpha), sin alpha = y_B / L (virtual work)."""
    sol = reports.solve(M.toggle(), model)
    assert sol.status == "converged", sol.message
    alpha = np.arcsin(sol.path("knee.y") / 0.1)
    exact = -1.0 / (2.0 * np.tan(alpha))
    tol = 1e-9 if model == "kinetostatic" else 2e-3  # FE: finite differences along 40 steps
    np.testing.assert_allclose(sol.path("ma"), exact, rtol=tol)
    np.testing.assert_allclose(sol.path("driver.force"), -20.0 * np.tan(alpha), rtol=1e-6)


def test_bistable_equilibria_and_barrier_match_fem():
    """Crank driven -120 deg: stable - unstable - stable; reduced-Hessian verdicts at the
    refined zero-force points agree with the FE force slope, positions and barrier with FE."""
    scene = M.fourbar(M.ENERGY.replace("stop = 120.0", "stop = -120.0").replace("= 120", "= 60"))
    red, fe = reports.solve(scene, "cbcm-4"), reports.solve(scene, "fem-16")
    eq_r, eq_f = red.extras["equilibria"], fe.extras["equilibria"]
    assert (
        [e["kind"] for e in eq_r]
        == [e["kind"] for e in eq_f]
        == [
            "stable",
            "unstable",
            "stable",
        ]
    )
    for a, b in zip(eq_r, eq_f):
        assert a["coordinate"] == pytest.approx(b["coordinate"], abs=0.1)
    assert red.extras["barrier"] == pytest.approx(fe.extras["barrier"], rel=5e-3)


@pytest.mark.parametrize("case", ["lee-frame", "shallow-arch-snap"])
def test_path_limit_loads_match_fem(case):
    """Arc-length through the limit points; the refined extrema against fem-auto's."""
    scene = cases.load(case)
    red, fe = reports.solve(scene, "cbcm-8"), reports.solve(scene, "fem-auto")
    assert red.status == "converged", red.message
    lr = [(p["kind"], p["factor"]) for p in red.extras["limit_points"]]
    lf = [(p["kind"], p["factor"]) for p in fe.extras["limit_points"]]
    assert [k for k, _ in lr] == [k for k, _ in lf]
    for (_, a), (_, b) in zip(lr, lf):
        assert a == pytest.approx(b, rel=5e-3)
    marked = [s.factor for s in red.steps if "limit_point" in s.info]
    assert marked == [f for _, f in lr], "refined extrema are inserted as steps"
