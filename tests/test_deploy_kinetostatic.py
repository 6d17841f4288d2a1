"""``kinetostatic`` deploy (booms in the mechanism assembler), verified against exact answers.

* Configuration 4's springs are all unloaded in the pose where the boom is 0.3 m long (bar I
  at 30 deg, II at 150 deg, the ternary link level): that pose is the exact Part 2
  equilibrium, J2 = (0.1 + 0.3 cos 30, 0.15), J4 = (0.05, 0.3), bar force 0.
* Every returned state: Lagrangian gradient < 1e-10 of the push, constraints < 1e-12 of the
  longest link.
* The boom's push and length terms: gradients and Hessians against central differences.
* A stall (springs unloaded in the drawn pose, weak push): located where the push balances
  the springs; the thesis's force method, an independent algorithm (relaxation to its fixed
  point), stalls at the same length.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import cases
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.deploy import BoomForceTerm, BoomLength, Deploy
from reduced_models.thesis.force_method import ThesisForceMethod
from reports import api


@pytest.fixture(scope="module")
def scene():
    return cases.load("thesis-sixbar-config4")


def test_config4_exact_equilibrium(scene):
    sol = api.solve(scene, "kinetostatic")
    assert sol.status == "converged", sol.message
    last = sol.steps[-1]
    assert last.factor == 2.0 and last.stable is True
    assert last.info["reduced_hessian_min"] > 0.0  # the mapped margin agrees with the verdict
    c30 = math.cos(math.radians(30.0))
    exact = {"J2": (0.1 + 0.3 * c30, 0.15), "J3": (0.1, 0.3), "J4": (0.05, 0.3), "J5": (0.0, 0.3)}
    exact["J6"] = (-0.3 * c30, 0.15)
    for k, (x, y) in exact.items():
        assert last.outputs[f"{k}.x"] == pytest.approx(x, abs=1e-12)
        assert last.outputs[f"{k}.y"] == pytest.approx(y, abs=1e-12)
    assert last.outputs["boom.length"] == pytest.approx(0.3, abs=1e-13)
    assert sol.extras["boom_bar_force"][0] == pytest.approx(0.0, abs=1e-9)


def test_states_satisfy_their_equations(scene):
    sysm = build(scene, lambda m: ("none",))
    r = Deploy(sysm)
    r.run_deploy()
    assert len(r.states) == scene.analysis.steps + 2
    for k, st in enumerate(r.states):
        if k == len(r.states) - 1:
            r.force.force[:] = 0.0  # Part 2: no push
        else:
            r.force.force[:] = scene.booms[0].force
            r.length.target[:] = r.lengths(st)["boom.length"]
        g, _ = sysm.grad_hess(st.q, st.lam)
        c, J = sysm.cons(st.q)
        f = sysm.free
        grad = g[f] + J[:, f].T @ st.mu
        assert np.max(np.abs(grad)) < 1e-10 * scene.booms[0].force
        assert np.max(np.abs(c)) < 1e-12 * 0.3


def _fd_check(term_grad, term_hess, q, dofs, h=1e-6):
    for j in dofs:
        e = np.zeros_like(q)
        e[j] = h
        fd = (term_grad(q + e) - term_grad(q - e)) / (2 * h)
        np.testing.assert_allclose(term_hess(q)[:, j], fd, atol=1e-6 * np.max(np.abs(fd)) + 1e-9)


def test_boom_terms_against_finite_differences():
    rng = np.random.default_rng(3)
    q = rng.normal(size=6)
    dofs = np.array([[0, 1, 4, 5]])
    n = len(q)

    def dense(idx, g, H):
        gg, HH = np.zeros(n), np.zeros((n, n))
        np.add.at(gg, idx[0], g[0])
        HH[np.ix_(idx[0], idx[0])] += H[0]
        return gg, HH

    force = BoomForceTerm(dofs, np.array([7.0]))
    grad = lambda x: dense(*force.local(x))[0]  # noqa: E731
    hess = lambda x: dense(*force.local(x))[1]  # noqa: E731
    energy_fd = np.array(
        [(force.energy(q + 1e-6 * e) - force.energy(q - 1e-6 * e)) / 2e-6 for e in np.eye(n)]
    )
    np.testing.assert_allclose(grad(q), energy_fd, atol=1e-8)
    _fd_check(grad, hess, q, dofs[0])
    con = BoomLength(dofs, np.array([0.5]))

    def cgrad(x):
        rows, cols, vals = con.jacobian(x)
        out = np.zeros(n)
        np.add.at(out, cols, vals)
        return out

    def chess(x):
        idx, H = con.curvature(x, np.array([1.0]))
        return dense(idx, np.zeros((1, 4)), H)[1]

    val_fd = np.array(
        [(con.values(q + 1e-6 * e)[0] - con.values(q - 1e-6 * e)[0]) / 2e-6 for e in np.eye(n)]
    )
    np.testing.assert_allclose(cgrad(q), val_fd, atol=1e-8)
    _fd_check(cgrad, chess, q, dofs[0])


def test_stall_agrees_with_the_force_method(scene):
    springs = tuple(
        dataclasses.replace(t, free_angle_deg=0.0, rest_angle_deg=None)
        for t in scene.torsion_springs
    )
    weak = dataclasses.replace(scene.booms[0], force=20.0)
    s2 = dataclasses.replace(scene, torsion_springs=springs, booms=(weak,))
    kin = api.solve(s2, "kinetostatic")
    thm = ThesisForceMethod().solve(s2)
    assert kin.status == thm.status == "converged"
    assert "stalled" in kin.message and "stalled" in thm.message
    a, b = kin.steps[-1].outputs, thm.steps[-1].outputs
    assert a["boom.length"] < 0.3 and kin.steps[-1].factor < 1.0
    for k in ("J2.x", "J2.y", "J4.y", "boom.length"):
        assert a[k] == pytest.approx(b[k], abs=1e-9)
