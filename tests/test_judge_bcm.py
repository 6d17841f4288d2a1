"""BCM coefficients against the exact beam-column, and BCM's own limit point (issue 11).

The beam constraint model's load-stiffening matrices are the Taylor coefficients, in the axial
load p, of the exact linearised beam-column stiffness (Awtar, Slocum & Sevincer, ASME J. Mech.
Des. 129:625, 2007, Eq. 7-8; /work/shared/PARAMETERS.md): ``[f, m] = (G + p P + p^2 Q) [y, th]``
with G = [[12, -6], [-6, 4]], P = [[6/5, -1/10], [-1/10, 2/15]], Q = [[-1/700, 1/1400],
[1/1400, -11/6300]].  The exact stiffness comes from w'''' - p w'' = 0 on [0, 1] with
w(0) = w'(0) = 0, w(1) = y, w'(1) = th, f = -w'''(1) + p w'(1), m = w''(1) (closed-form
hyperbolic / trigonometric basis); its coefficients are fitted over |p| in [0.5, 4].
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import reports
from reduced_models.beam.bcm import BCM_LAW


def beam_column_stiffness(p: float) -> np.ndarray:
    """Exact 2x2 tip stiffness of a clamped beam-column under axial load p (tension +)."""
    k = math.sqrt(abs(p))

    def basis(x: float) -> np.ndarray:
        if p > 0:
            ch, sh = math.cosh(k * x), math.sinh(k * x)
            rows = [[1, x, ch, sh], [0, 1, k * sh, k * ch], [0, 0, k * k * ch, k * k * sh]]
            return np.array(rows + [[0, 0, k**3 * sh, k**3 * ch]])
        c, s = math.cos(k * x), math.sin(k * x)
        rows = [[1, x, c, s], [0, 1, -k * s, k * c], [0, 0, -k * k * c, -k * k * s]]
        return np.array(rows + [[0, 0, k**3 * s, -(k**3) * c]])

    b0, b1 = basis(0.0), basis(1.0)
    M = np.vstack([b0[0], b0[1], b1[0], b1[1]])
    out = np.zeros((2, 2))
    for j, rhs in enumerate(([0, 0, 1, 0], [0, 0, 0, 1])):
        c = np.linalg.solve(M, rhs)
        out[:, j] = [-(b1[3] @ c) + p * (b1[1] @ c), b1[2] @ c]
    return out


@pytest.fixture(scope="module")
def series() -> np.ndarray:
    ps = np.concatenate([np.linspace(-4.0, -0.5, 30), np.linspace(0.5, 4.0, 30)])
    ks = np.array([beam_column_stiffness(p) for p in ps])
    coef = np.polynomial.polynomial.polyfit(ps, ks.reshape(len(ps), 4), 10)  # (11, 4)
    return coef[:3].reshape(3, 2, 2)


def test_bcm_matrices_are_the_beam_column_series(series):
    np.testing.assert_allclose(series[0], BCM_LAW.G, atol=1e-8)
    np.testing.assert_allclose(series[1], BCM_LAW.P, atol=1e-8)
    np.testing.assert_allclose(series[2], BCM_LAW.Q, atol=1e-8)
    # the off-diagonal terms on their own (Awtar 2007: -1/10 and 1/1400)
    assert series[1][0, 1] == pytest.approx(-0.1, abs=1e-9)
    assert series[2][0, 1] == pytest.approx(1.0 / 1400.0, abs=1e-9)


def test_bcm_stops_at_its_own_limit_point_and_says_so():
    """Compressed past its buckling load, the single BCM's path folds near P = Pcr: it fails
    at the fold and names it (not a bare 'Newton did not converge')."""
    sol = reports.solve("column-postbuckling", "bcm")
    assert sol.status == "failed" and "own limit point" in sol.message
    last = sol.steps[-1].factor
    assert 0.45 < last <= 0.51  # P/Pcr ~ 1: the fold sits at the model's buckling load
