"""``bcm`` and ``cbcm-N``: Awtar's beam constraint model, single and chained.

Segment-normalised tip quantities in the segment's undeformed frame (PARAMETERS.md; Awtar,
Slocum & Sevincer 2007; Awtar & Sen 2010): y = Y/h, ux = X/h - 1, a = tip rotation,
f = F_y h^2/EI, p = F_x h^2/EI (tension +), m = M h/EI, k = t^2/12 = EI/(EA h^2):

    [f, m]^T = (G + p P + p^2 Q) [y, a]^T
    ux = k p - 1/2 [y a] P [y a]^T - p [y a] Q [y a]^T
    v = 1/2 [y a] G [y a]^T + 1/2 p^2 (k - [y a] Q [y a]^T)        (strain energy, EI/h)

The axial force p is kept as an unknown (a multiplier of the x-relation, see
``reduced_models.beam.chain`` for why); ``bcm`` is one such segment, ``cbcm-N`` chains N of them
with each segment in the frame of the previous segment's tip (Ma & Chen 2016), so the
Hessian is block-tridiagonal and the cost grows linearly in N.

Deformed shape: the exact beam-column deflection of the segment under its axial force p,
through the tip (y, a) (shape functions k_ij of seed 000, "BCM - Energy Equations", written
with entire functions of p so that p -> 0 and p < 0 need no special branches; a Taylor
series is used for |p x^2| <= 1 as the seed advises).  Axial position along the segment:
k p s - 1/2 int theta^2, corrected linearly to end at the BCM tip.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution
from reduced_models.beam import single_beam
from reduced_models.beam.bcm_single import pd_interval, solve_direct, with_shapes
from reduced_models.beam.chain import SegmentLaw
from reduced_models.beam.chain_model import ChainModel
from reduced_models.beam.linear import hermite_shape

# Awtar, Slocum & Sevincer (2007), Eq. (7)-(8); Awtar & Sen (2010) -- also PARAMETERS.md
G_BCM = np.array([[12.0, -6.0], [-6.0, 4.0]])
P_BCM = np.array([[6.0 / 5.0, -1.0 / 10.0], [-1.0 / 10.0, 2.0 / 15.0]])
Q_BCM = np.array([[-1.0 / 700.0, 1.0 / 1400.0], [1.0 / 1400.0, -11.0 / 6300.0]])
BCM_LAW = SegmentLaw(G=G_BCM, P=P_BCM, Q=Q_BCM)

# intermediate-deflection range claimed for one BCM segment (Awtar et al. 2007)
Y_LIMIT = 0.1

_SERIES_TERMS = 11  # |z| <= 1: the first omitted term is below 1/22! ~ 1e-21
_INV_FACT = 1.0 / np.array([math.factorial(j) for j in range(2 * _SERIES_TERMS + 4)])


def _series(z: np.ndarray, offset: int) -> np.ndarray:
    """sum_j z^j / (2 j + offset)!  (Horner)."""
    out = np.full_like(z, _INV_FACT[2 * (_SERIES_TERMS - 1) + offset])
    for j in range(_SERIES_TERMS - 2, -1, -1):  # loop over series terms, not elements
        out *= z
        out += _INV_FACT[2 * j + offset]
    return out


def _cosh_sqrt(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Entire functions of z = p x^2 used by the beam-column shape functions.

    Returns C = cosh(sqrt z), S = sinh(sqrt z)/sqrt z, c1 = (C - 1)/z, s1 = (S - 1)/z, each
    continued analytically to z < 0 (cos, sin); Taylor series for |z| <= 1 (where the
    closed forms lose digits to cancellation).
    """
    z = np.asarray(z, dtype=float)
    if not z.any():  # no axial force (transverse loads only): the series' constant terms
        one = np.ones_like(z)
        return one, one, np.full_like(z, _INV_FACT[2]), np.full_like(z, _INV_FACT[3])
    small = np.abs(z) <= 1.0
    if np.all(small):
        c1, s1 = _series(z, 2), _series(z, 3)
        return 1.0 + z * c1, 1.0 + z * s1, c1, s1
    zs = np.where(small, z, 0.0)
    c1, s1 = _series(zs, 2), _series(zs, 3)
    zb = np.where(small, 4.0, z)  # placeholder keeps the closed forms finite
    r = np.sqrt(np.abs(zb))
    pos = zb > 0
    rc = np.minimum(r, 700.0)
    Cb = np.where(pos, np.cosh(rc), np.cos(r))
    Sb = np.where(pos, np.sinh(rc), np.sin(r)) / r
    c1 = np.where(small, c1, (Cb - 1.0) / zb)
    s1 = np.where(small, s1, (Sb - 1.0) / zb)
    return 1.0 + z * c1, 1.0 + z * s1, c1, s1


def shape_functions(p: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, ...]:
    """Beam-column shape functions of a clamped segment with tip loads (f, p, m).

    u_y(s) = k11 f + k12 m, theta(s) = k21 f + k22 m (seed 000; p > 0 tension, p < 0
    compression up to the segment's buckling load p = -pi^2/4).

    Parameters
    ----------
    p : (N,) segment-normalised axial force.
    sigma : (s,) positions in [0, 1].

    Returns
    -------
    k11, k12, k21, k22 : each (N, s).
    """
    p = np.asarray(p, dtype=float)[:, None]
    s = np.asarray(sigma, dtype=float)[None, :]
    C1, S1, _, _ = _cosh_sqrt(p)  # cosh r, sinh r / r at the segment end
    _, Sx, c1x, s1x = _cosh_sqrt(p * s**2)
    T = S1 / C1  # tanh(r)/r
    k11 = T * s**2 * c1x - s**3 * s1x
    k12 = s**2 * c1x / C1
    k21 = -(s**2) * c1x + T * s * Sx
    k22 = s * Sx / C1
    return k11, k12, k21, k22


def bcm_shape(
    ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float, sigma: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local segment shapes through the BCM tip state.

    Returns xl, yl (segment units) and curvature kappa (1/h), each (N, s).  The transverse
    loads (f, m) are those of the exact beam-column with axial force p that reach (y, a);
    segments at or beyond their own buckling load fall back to the Hermite cubic.
    """
    k11, k12, k21, k22 = shape_functions(p, sigma)
    # tip compliance [[k11, k12], [k21, k22]](s = 1), inverted in closed form (2x2)
    c11, c12, c21, c22 = k11[:, -1], k12[:, -1], k21[:, -1], k22[:, -1]
    det = c11 * c22 - c12 * c21
    ok = np.isfinite(det) & (np.abs(det) > 1e-12) & (p > -(math.pi**2) / 4 * 0.999)
    safe = np.where(ok, det, 1.0)
    f = np.where(ok, (c22 * y - c12 * a) / safe, 0.0)[:, None]
    m = np.where(ok, (-c21 * y + c11 * a) / safe, 0.0)[:, None]
    yl = k11 * f + k12 * m
    th = k21 * f + k22 * m
    s = np.asarray(sigma)[None, :]
    kappa = m + f * (1.0 - s) - p[:, None] * (y[:, None] - yl)
    if not np.all(ok):
        vh, kh = hermite_shape(y, a, np.asarray(sigma))
        yl = np.where(ok[:, None], yl, vh)
        kappa = np.where(ok[:, None], kappa, kh)
        th = np.where(ok[:, None], th, np.gradient(vh, np.asarray(sigma), axis=1))
    # cumulative trapezoid of theta^2 along sigma (numpy: scipy.integrate is a 0.5 s import)
    t2 = th * th
    steps = 0.5 * (t2[:, 1:] + t2[:, :-1]) * np.diff(np.asarray(sigma, dtype=float))
    shortening = np.concatenate([np.zeros_like(t2[:, :1]), np.cumsum(steps, axis=1)], axis=1)
    xl = s * (1.0 + k * p[:, None]) - 0.5 * shortening
    xl = xl + s * ((1.0 + ux)[:, None] - xl[:, -1:])
    return xl, yl, kappa


def stiffness_positive_definite(p: np.ndarray) -> np.ndarray:
    """Bool array shaped like p: is G + p P + p^2 Q positive definite (k11 > 0, det > 0)?"""
    p = np.asarray(p, dtype=float)
    K = BCM_LAW.stiffness(p.ravel())
    det = K[:, 0, 0] * K[:, 1, 1] - K[:, 0, 1] * K[:, 1, 0]
    return ((K[:, 0, 0] > 0) & (det > 0)).reshape(p.shape)


def segment_energy(ux: np.ndarray, y: np.ndarray, a: np.ndarray, k: float) -> np.ndarray:
    """BCM strain energy with p eliminated (Awtar & Sen 2010), segment-normalised (EI/h).

    v = 1/2 w.G.w + (ux + 1/2 w.P.w)^2 / (2 (k - w.Q.w)), w = (y, a); needs k > 0 or w != 0.
    """
    w = np.stack([np.atleast_1d(y), np.atleast_1d(a)], axis=1)
    wGw = np.einsum("ni,ij,nj->n", w, G_BCM, w)
    wPw = np.einsum("ni,ij,nj->n", w, P_BCM, w)
    wQw = np.einsum("ni,ij,nj->n", w, Q_BCM, w)
    return 0.5 * wGw + (np.atleast_1d(ux) + 0.5 * wPw) ** 2 / (2.0 * (k - wQw))


def segment_loads(
    ux: np.ndarray, y: np.ndarray, a: np.ndarray, k: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(p, f, m) from the BCM force-deflection and x relations (Awtar et al. 2007)."""
    w = np.stack([np.atleast_1d(y), np.atleast_1d(a)], axis=1)
    wPw = np.einsum("ni,ij,nj->n", w, P_BCM, w)
    wQw = np.einsum("ni,ij,nj->n", w, Q_BCM, w)
    p = (np.atleast_1d(ux) + 0.5 * wPw) / (k - wQw)
    fm = np.einsum("nij,nj->ni", BCM_LAW.stiffness(p), w)
    return p, fm[:, 0], fm[:, 1]


_REFS = (
    "Awtar, Slocum & Sevincer, J. Mech. Des. 129:625-639 (2007), doi 10.1115/1.2717231",
    "Awtar & Sen, J. Mech. Des. 132:081008 (2010), doi 10.1115/1.4002005 (strain energy)",
    "Ma & Chen, J. Mechanisms Robotics 8:021018 (2016), doi 10.1115/1.4031028 (chained BCM)",
    "DAS-2D seed 000_265bc60728766176.txt, 'BCM - Energy Equations' (shape functions)",
)
_ASSUMPTIONS = (
    "Euler-Bernoulli segment, loads resolved in the segment's undeformed (root) frame",
    "force-deflection exact to second order in p (Taylor of the beam-column stiffness)",
    "x-relation: elastic stretch k p, kinematic shortening 1/2 w.P.w, load term p w.Q.w",
    "axial strain included when EA is given (k = EI/(EA h^2)); inextensible otherwise",
    "dead tip loads (follower force: residual Newton with unsymmetric tangent)",
)


class ChainedBCM(ChainModel):
    """``cbcm-N``: N chained BCM segments (Ma & Chen 2016).

    Parameters
    ----------
    n : number of segments.
    shape_points : shape samples per segment.

    ``Solution.extras["validity_warning"]`` is set (with ``validity_message``) when a segment
    leaves the intermediate-deflection range (|y| > 0.1 of the segment length) or its
    stiffness G + pP + p^2Q is not positive definite; the solution is still returned.
    """

    law = BCM_LAW
    family = "cbcm"
    extensible = True
    _card = ModelCard(
        name="cbcm-N",
        family="bcm",
        summary="{N} chained beam-constraint-model segments, each in its predecessor's tip frame",
        assumptions=_ASSUMPTIONS + ("large overall rotation from chaining segment frames",),
        validity=(
            "each segment within the BCM range: |y| <= ~0.1 h and G + pP + p^2Q positive "
            "definite (Ma, Chen & Hao, Mech. Sci. 9:71-79, 2018); tip error vs the elastica "
            "falls as N^-3 for a dead or follower tip force (measured, "
            "tests/test_verify_linear_bcm.py)"
        ),
        references=_REFS,
    )

    def shape(
        self,
        ux: np.ndarray,
        y: np.ndarray,
        a: np.ndarray,
        p: np.ndarray,
        k: float,
        sigma: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local segment shapes (xl, yl, kappa), each (N, s), segment units."""
        return bcm_shape(ux, y, a, p, k, sigma)

    def warning_flags(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> list[tuple[str, np.ndarray]]:
        """Validity-range violations per reported step ((m, N) segment arrays)."""
        return [
            (
                f"segment transverse deflection |y| > {Y_LIMIT} h (BCM range)",
                np.any(np.abs(y) > Y_LIMIT, axis=-1),
            ),
            (
                "BCM stiffness G + pP + p^2Q not positive definite",
                ~np.all(stiffness_positive_definite(p), axis=-1),
            ),
        ]


class BCM(ChainedBCM):
    """``bcm``: one beam-constraint-model segment for the whole beam (Awtar et al. 2007)."""

    _card = ModelCard(
        name="bcm",
        family="bcm",
        summary="Awtar's beam constraint model, one segment, axial strain included",
        assumptions=_ASSUMPTIONS,
        validity=(
            "intermediate deflections: |y| <= ~0.1 L, |p| below the first buckling load "
            "(stiffness positive definite); flagged in Solution.extras otherwise"
        ),
        references=_REFS,
    )

    def __init__(self, shape_points: int | None = None) -> None:
        super().__init__(1, shape_points=shape_points)
        self.name = "bcm"
        self.card = ModelCard(
            name="bcm",
            family=self._card.family,
            summary=self._card.summary,
            assumptions=self._card.assumptions,
            validity=self._card.validity,
            references=self._card.references,
        )

    @staticmethod
    @functools.cache
    def pd_range(guided: bool) -> tuple[float, float]:
        """Where the BCM stiffness K(p) is positive definite (``bcm_single.pd_interval``)."""
        return pd_interval(BCM_LAW, guided)

    def solve(self, scene: Scene) -> Solution:
        """As ``ChainModel.solve``; under dead loads with K(p) positive definite on the whole
        ramp each step is one 2x2 solve (``bcm_single``), not a continuation."""
        beam = single_beam.cantilever_of(scene)
        if isinstance(beam, str) or beam.follower or self.applies_to(scene):
            return super().solve(scene)
        return solve_direct(self, scene, beam) or super().solve(scene)

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """``ChainModel.postprocess`` for one segment, all steps at once."""
        return with_shapes(self, scene, sol)
