"""The continuation engine is one algorithm in three arithmetics (``paths.engine``).

A bare float (``floats.Scalar``), a list of floats (``floats.Floats``) and a numpy array
(``linalg.Arrays``) run the same Newton, step control, predictor and branch test, so the same
problem must give the same path in each -- the same Newton iterations at every reported
factor, states to round-off -- and that path must be the problem's closed-form one.

The problem: a unit link along x held at its root by a torsion spring k, loaded by a
transverse (y) dead force lam at its tip, V = k x^2 / 2 - lam sin x, so g = k x - lam cos x
and every equilibrium satisfies lam = k x / cos x exactly (x increases with lam here).
Three such pendulums in series (absolute angles, springs between neighbours) give the
tridiagonal Hessian of a PRB chain, whose closed form is checked the same way through the
equilibrium of each joint.
"""

from __future__ import annotations

import math

import numpy as np

from reduced_models.paths.engine import minimize_path

K = 2.0
FACTORS = np.linspace(0.0, 6.0, 13)


def _scalar(x: float, lam: float) -> tuple[float, float]:
    return K * x - lam * math.cos(x), K + lam * math.sin(x)


def _list(x: list, lam: float) -> tuple[list, tuple[list, list]]:
    g, h = _scalar(x[0], lam)
    return [g], ([h], [])


def _array(x: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    g, h = _scalar(float(x[0]), lam)
    return np.array([g]), np.array([[h]])


def test_one_unknown_same_path_in_every_arithmetic_and_on_the_closed_form() -> None:
    lg = {
        "scalar": lambda x, lam: -math.cos(x),
        "list": lambda x, lam: [-math.cos(x[0])],
        "array": lambda x, lam: np.array([-math.cos(x[0])]),
    }
    runs = {
        "scalar": minimize_path(_scalar, 0.0, FACTORS, load_gradient=lg["scalar"]),
        "list": minimize_path(_list, [0.0], FACTORS, load_gradient=lg["list"]),
        "array": minimize_path(
            _array, np.zeros(1), FACTORS, load_gradient=lg["array"], symmetric=True
        ),
    }
    ref = runs["scalar"]
    assert ref.ok and np.array_equal(ref.factors, FACTORS)
    x = ref.states[:, 0]
    # the closed form: lam = k x / cos x (the accepted state's own correction is <= 1e-10)
    assert np.allclose(K * x / np.cos(x), FACTORS, rtol=0.0, atol=1e-9)
    assert all(ref.stable)
    for name in ("list", "array"):
        run = runs[name]
        assert run.ok, name
        assert np.array_equal(run.iterations, ref.iterations), name
        assert np.allclose(run.states, ref.states, rtol=0.0, atol=1e-15), name
        assert list(run.stable) == list(ref.stable), name


def _chain3(x: list, lam: float) -> tuple[list, tuple[list, list]]:
    """Three unit links in absolute angles x, springs K between neighbours (and the root),
    transverse dead tip force lam: g_p = K (x_p - x_{p-1}) - K (x_{p+1} - x_p) - lam cos x_p."""
    g, d = [], []
    for p in range(3):
        left = x[p] - (x[p - 1] if p else 0.0)
        right = x[p + 1] - x[p] if p < 2 else 0.0
        g.append(K * left - K * right - lam * math.cos(x[p]))
        d.append(K * (2.0 if p < 2 else 1.0) + lam * math.sin(x[p]))
    return g, (d, [-K, -K])


def _chain3_array(x: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    g, (d, e) = _chain3(x.tolist(), lam)
    return np.array(g), np.diag(d) + np.diag(e, 1) + np.diag(e, -1)


def test_three_unknowns_float_path_equals_array_path_and_joint_equilibrium() -> None:
    fl = minimize_path(
        _chain3, [0.0] * 3, FACTORS, load_gradient=lambda x, lam: [-math.cos(v) for v in x]
    )
    ar = minimize_path(
        _chain3_array,
        np.zeros(3),
        FACTORS,
        load_gradient=lambda x, lam: -np.cos(x),
        symmetric=True,
    )
    assert fl.ok and ar.ok
    assert np.array_equal(fl.iterations, ar.iterations)
    assert np.allclose(fl.states, ar.states, rtol=0.0, atol=1e-14)
    assert list(fl.stable) == list(ar.stable) == [True] * len(FACTORS)
    # closed form at each joint: the spring moment there carries the force's moment about
    # it, K theta_p = lam * (tip's x beyond joint p) = lam sum_{q >= p} cos x_q
    x = fl.states
    theta = np.diff(x, axis=1, prepend=0.0)
    arm = np.cumsum(np.cos(x)[:, ::-1], axis=1)[:, ::-1]
    assert np.allclose(K * theta, FACTORS[:, None] * arm, rtol=0.0, atol=1e-8)
