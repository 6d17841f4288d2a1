"""Cited constants of the pseudo-rigid-body (PRB) models, as PRB matrices.

A PRB matrix (Venkiteswaran & Su, Precis. Eng. 40:46-54, 2015,
doi 10.1016/j.precisioneng.2014.10.002; seed 000_265bc60728766176.txt, slide "PRB Matrix") has
one row per rigid segment, ``[k_theta, k_ex, gamma]``:

* ``gamma`` -- segment length as a fraction of the beam length L;
* ``k_theta`` -- torsion spring at the *proximal* end of the segment, K = k_theta EI/L
  (``inf``: no joint there, the segment is welded to the previous one or to the clamp);
* ``k_ex`` -- axial (prismatic) spring of the segment, K = k_ex EA/L (``inf``: rigid segment).

Every constant below is copied from the cited source (checked against public transcriptions,
see the notes) or, where no published value could be found, *derived here* and marked so.
Load notation (Howell): tip force P(-n, 1) in the beam frame, i.e. transverse component P and
axial component n P, **n > 0 compressive**; alpha = P L^2/EI.
"""

from __future__ import annotations

import math

import numpy as np

INF = math.inf

# --------------------------------------------------------------------------------------------
# PRB-1R (Howell & Midha, J. Mech. Des. 117:156-165, 1995, doi 10.1115/1.2826101;
# Howell, Midha & Norton, J. Mech. Des. 118:126-131, 1996, doi 10.1115/1.2826843;
# Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.6, Eqs. (5.8)-(5.10), Table 5.1).
# The curve fits were checked against two independent public MATLAB/Python transcriptions that
# cite Howell (identical coefficients; one of them has the typo 1.967657 for 1.967647).
# --------------------------------------------------------------------------------------------

#: Table 5.1 (Howell 2001): load ratio n -> characteristic radius factor gamma.
HOWELL_TABLE_N = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.5, 10.0])
HOWELL_TABLE_GAMMA = np.array(
    [0.8517, 0.8430, 0.8360, 0.8311, 0.8276, 0.8232, 0.8207, 0.8192, 0.8168, 0.8156]
)

#: Parametric angle coefficient c_theta (tip slope = c_theta * Theta), Howell 2001 Table 5.1
#: (n >= 0) and the negative-n values of the same source; sorted by n for interpolation.
HOWELL_CTHETA_N = np.array(
    [-5.0, -4.0, -3.0, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.5, 10.0]
)
HOWELL_CTHETA = np.array(
    [1.1788, 1.1971, 1.2119, 1.2293, 1.2322, 1.2323, 1.2348, 1.2385, 1.2430, 1.2467, 1.2492,
     1.2511, 1.2534, 1.2548, 1.2557, 1.2570, 1.2578]
)  # fmt: skip

#: n = 0 (transverse force) values quoted by Howell: gamma, K_Theta, c_theta and the largest PRB
#: angle for which the characteristic-radius tip locus stays within 0.5 % of the deflection.
HOWELL_N0 = {"gamma": 0.8517, "K_Theta": 2.67617, "c_theta": 1.2385, "Theta_max_deg": 64.3}

#: Averages often quoted (Howell 2001, Sec. 5.6): gamma 0.85, K_Theta 2.65, c_theta 1.24.
HOWELL_AVERAGE = {"gamma": 0.85, "K_Theta": 2.65, "c_theta": 1.24}

#: Pure end moment (Howell 2001, Sec. 5.5): gamma, c_theta, K_Theta; tip slope valid to ~124.4 deg.
HOWELL_MOMENT = {"gamma": 0.7346, "K_Theta": 2.0643, "c_theta": 1.5164, "Theta_max_deg": 124.4}

#: Load-ratio range covered by the curve fits.
HOWELL_N_RANGE = (-5.0, 10.0)


def howell_gamma(n: float) -> float:
    """Characteristic radius factor gamma(n), Howell 2001 Eq. (5.8) curve fit (-5 < n <= 10)."""
    if 0.5 < n <= 10.0:
        return 0.841655 - 0.0067807 * n + 0.000438 * n * n
    if -1.8316 < n <= 0.5:
        return 0.852144 - 0.0182867 * n
    if -5.0 < n <= -1.8316:
        return 0.912364 + 0.0145928 * n
    raise ValueError(f"load ratio n = {n:g} outside Howell's fit range (-5, 10]")


def howell_k_theta(n: float) -> float:
    """Stiffness coefficient K_Theta(n), Howell, Midha & Norton 1996 curve fit (-5 < n <= 10)."""
    if -5.0 < n <= -2.5:
        return 3.024112 + 0.121290 * n + 0.003169 * n * n
    if -2.5 < n <= -1.0:
        return (
            1.967647
            - 2.616021 * n
            - 3.738166 * n**2
            - 2.649437 * n**3
            - 0.891906 * n**4
            - 0.113063 * n**5
        )
    if -1.0 < n <= 10.0:
        return 2.654855 - 0.0509896 * n + 0.0126749 * n**2 - 0.00142039 * n**3 + 0.0000584525 * n**4
    raise ValueError(f"load ratio n = {n:g} outside Howell's fit range (-5, 10]")


def howell_c_theta(n: float) -> float:
    """Parametric angle coefficient c_theta(n), linear interpolation of Howell's table."""
    if not HOWELL_N_RANGE[0] <= n <= HOWELL_N_RANGE[1]:
        raise ValueError(f"load ratio n = {n:g} outside Howell's table range [-5, 10]")
    return float(np.interp(n, HOWELL_CTHETA_N, HOWELL_CTHETA))


def prb1r_matrix(gamma: float, K_Theta: float) -> np.ndarray:
    """PRB matrix of Howell's 1R model: rigid root (1 - gamma) L, pivot, rigid link gamma L.

    The pivot spring is K = gamma K_Theta EI/L, so ``k_theta = gamma * K_Theta``.
    """
    return np.array([[INF, INF, 1.0 - gamma], [gamma * K_Theta, INF, gamma]])


# --------------------------------------------------------------------------------------------
# Small-length flexural pivot (Howell & Midha, J. Mech. Des. 116:280-290, 1994,
# doi 10.1115/1.2919359; Howell 2001 Sec. 5.4): pivot at the centre of the flexible segment,
# K = EI/l.  Applied to a whole beam of length L: gamma = 1/2 | 1/2, k_theta = 1.
# --------------------------------------------------------------------------------------------
PRB_SHORT = np.array([[INF, INF, 0.5], [1.0, INF, 0.5]])

# --------------------------------------------------------------------------------------------
# PRB-3R (Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148, Sec. 4).
# gamma0..gamma3 = 0.10, 0.35, 0.40, 0.15 (Eq. 24); three stiffness sets.  Checked against a
# public MATLAB transcription of Su's Sec. 4 (same gammas, Eq. 25/27 and Table 1 values).
# --------------------------------------------------------------------------------------------
SU_GAMMA = (0.10, 0.35, 0.40, 0.15)
SU_K = {
    "average": (3.51, 2.99, 2.58),  # Table 1: load-independent averages
    "force": (3.71591, 2.87128, 2.26417),  # Eq. (27): optimised for a pure tip force
    "moment": (3.51933, 2.78518, 2.79756),  # Eq. (25): optimised for a pure end moment
}
SU_SOURCE = {
    "average": "Su 2009, Table 1 (load-independent averages)",
    "force": "Su 2009, Eq. (27) (optimised for a pure tip force)",
    "moment": "Su 2009, Eq. (25) (optimised for a pure end moment)",
}


def prb3r_matrix(kset: str = "average") -> np.ndarray:
    """Su's PRB-3R matrix with stiffness set ``average`` | ``force`` | ``moment``."""
    k = SU_K[kset]
    g = SU_GAMMA
    return np.array([[INF, INF, g[0]], [k[0], INF, g[1]], [k[1], INF, g[2]], [k[2], INF, g[3]]])


# --------------------------------------------------------------------------------------------
# PRB-2R: no published parameter set could be located and checked for this project, so the
# matrix below is DERIVED HERE with reduced_models.beam.prb_fit.fit_prb(2, ...) against the exact
# elastica (settings in PRB_2R_FIT); tests/test_verify_prb.py re-measures its error.
# --------------------------------------------------------------------------------------------
# fit_prb(2, load_range=(0, 10), n=0, moment_range=(0, 2), n_points=12, angle_weight=1):
# transverse tip force PL^2/EI <= 10 and pure end moment ML/EI <= 2 jointly.  Measured at the
# fit: max tip position error 3.76 % of L (moment end), 2.06 % for the force alone; max tip
# angle error 0.0243 rad.
PRB_2R_FIT = {
    "n_segments": 2,
    "load_range": (0.0, 10.0),
    "n": 0.0,
    "moment_range": (0.0, 2.0),
    "n_points": 12,
    "angle_weight": 1.0,
}
PRB_2R = np.array(
    [
        [INF, INF, 0.1483592252],
        [2.4145066965, INF, 0.5948194416],
        [1.7095009583, INF, 1.0 - 0.1483592252 - 0.5948194416],
    ]
)

# --------------------------------------------------------------------------------------------
# PRB-2(RP)R (name from DAS-2D; PRB-matrix framework of Venkiteswaran & Su 2015).  No
# published matrix could be located, so it is DERIVED HERE: revolute joints and gammas from
# Su's PRB-3R (Table 1 averages), prismatic springs in the two middle segments chosen so
# that the series axial compliance equals the beam's, L/EA (sum 1/k_ex = 1), split in
# proportion to the segment lengths: k_ex_i = (gamma1 + gamma2)/gamma_i.
# --------------------------------------------------------------------------------------------


def prb2rpr_matrix() -> np.ndarray:
    """Derived PRB-2(RP)R matrix: Su's 3R with prismatic springs in segments 1 and 2."""
    m = prb3r_matrix("average")
    g12 = m[1, 2] + m[2, 2]
    m[1, 1] = g12 / m[1, 2]
    m[2, 1] = g12 / m[2, 2]
    return m


# --------------------------------------------------------------------------------------------
# Finite segment model: N elements of length L/N, each replaced by a small-length flexural
# pivot at its centre with K = EI/(L/N) = N EI/L (Howell & Midha 1994 applied per element;
# the midpoint placement makes the model a midpoint-rule discretisation of the curvature,
# second order in 1/N).  ``placement="end"`` gives N identical rows [N, inf, 1/N] (spring at
# the proximal end of each element, first order in 1/N).
# --------------------------------------------------------------------------------------------


def fsm_matrix(n: int, placement: str = "mid") -> np.ndarray:
    """PRB matrix of the N-element finite segment model (``mid`` or ``end`` placement)."""
    if n < 1:
        raise ValueError("finite segment model needs N >= 1")
    if placement == "end":
        return np.tile([float(n), INF, 1.0 / n], (n, 1))
    if placement != "mid":
        raise ValueError(f"placement must be 'mid' or 'end', got {placement!r}")
    rows = [[INF, INF, 0.5 / n]] + [[float(n), INF, 1.0 / n]] * (n - 1) + [[float(n), INF, 0.5 / n]]
    return np.array(rows)
