"""Closed-form pendulum flow of the elastica (``elastica_shooting`` shoots on it).

The inextensible Euler-Bernoulli beam clamped at s = 0 (tangent along +x) and loaded at its tip
by a force of magnitude P in direction phi (and a tip moment) obeys, with the tangent angle
theta(s),  EI theta'' = P sin(theta - phi).  With u = theta - phi + pi and lam = sqrt(P/EI) this
is the pendulum  u'' = -lam^2 sin u, and u' = theta' = kappa is the curvature.  Its solution
from any state (u0, p0 = u'(0)) is written in Jacobi elliptic functions: libration
(k^2 = p0^2/(4 lam^2) + sin^2(u0/2) < 1) sin(u/2) = k sn(w|k^2), w = w0 + lam s; rotation
(k > 1) u = 2 am(w | 1/k^2), w = w0 + sign(p0) lam k s.  The position integrals int cos u ds,
int sin u ds and the bending integral int u'^2 ds follow in closed form from the addition
theorems of sn, cn and of Jacobi's epsilon function, written with Carlson's R_F and R_D
(``scipy.special.elliprf/elliprd``) so that small loads lose no digits to cancellation.  Every
function takes the complementary parameter m1 = 1 - m computed without cancellation, and near
the separatrix (m1 < 1e-3: beam nearly aligned with a large tensile force, boundary layer at
the tip) the Jacobi functions come from the AGM started at sqrt(m1) (A&S 16.4) instead of
``scipy.special.ellipj``, whose m-argument would round 1 - m.

One evaluation of the flow costs a few special-function calls (~20-40 us) and is exact to
round-off for any load size; ``tip_flow`` also gives its derivative with respect to the root
curvature analytically, from d am(w|m)/dm (DLMF 19.4.2 with E = F - m D).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ellipj, elliprd, elliprf

TWO_PI = 2.0 * math.pi
M1_AGM = 1e-3  # below this complementary parameter use the m1-accurate AGM


# -- elliptic primitives in (m, m1 = 1 - m) -------------------------------------------------
def jacobi(u: float | np.ndarray, m: float, m1: float) -> tuple:
    """sn, cn, dn, am of u (scalar or array) for parameter m with m1 = 1 - m given exactly."""
    if isinstance(u, float):
        return _jacobi_float(u, m, m1)
    return _jacobi(u, m, m1)


@functools.lru_cache(maxsize=16)
def _jacobi_float(u: float, m: float, m1: float) -> tuple:
    """``jacobi`` of a float, cached: a reported state's tip flow and tip state both ask for
    the Jacobi functions at the tip."""
    return _jacobi(u, m, m1)


def _jacobi(u: float | np.ndarray, m: float, m1: float) -> tuple:
    """``jacobi`` uncached: scipy's ``ellipj``, the AGM from sqrt(m1) near the separatrix."""
    if m1 >= M1_AGM:
        return ellipj(u, m)
    if m1 <= 0.0:  # separatrix: sn = tanh, cn = dn = sech
        t, c = np.tanh(u), 1.0 / np.cosh(u)
        return t, c, c, np.arctan2(t, c)
    a, b, c = 1.0, math.sqrt(m1), math.sqrt(m)
    ratios = []
    while abs(c) > 1e-17 * a and len(ratios) < 60:
        a, b, c = 0.5 * (a + b), math.sqrt(a * b), 0.5 * (a - b)
        ratios.append(c / a)
    phi = (2.0 ** len(ratios)) * a * u
    for r in reversed(ratios):
        phi = 0.5 * (phi + np.arcsin(r * np.sin(phi)))
    cn = np.cos(phi)
    # dn from dn^2 = m1 + m cn^2 (the AGM quotient cn / cos(phi1 - phi0) is 0/0 at w = K)
    return np.sin(phi), cn, np.sqrt(m1 + m * cn * cn), phi


def ellK(m1: float) -> float:
    """Complete K(m) = R_F(0, m1, 1)."""
    return float(elliprf(0.0, m1, 1.0))


def ellF(phi: float, m: float, m1: float) -> float:
    """Incomplete F(phi|m), any real phi (Carlson form on the reduced angle)."""
    n = round(phi / math.pi)
    r = phi - n * math.pi
    s, c = math.sin(r), math.cos(r)
    val = s * float(elliprf(c * c, c * c + m1 * s * s, 1.0))
    return val + 2.0 * n * ellK(m1) if n else val


def incD(phi: float | np.ndarray, m: float, m1: float) -> float | np.ndarray:
    """D(phi|m) = int_0^phi sin^2 t / sqrt(1 - m sin^2 t) dt = (F - E)/m, any real phi.

    sin^3 r R_D(cos^2 r, cos^2 r + m1 sin^2 r, 1)/3 on the reduced angle r in [-pi/2, pi/2]
    plus whole half-periods: no cancellation for small m, small phi or small m1.
    """
    if isinstance(phi, float):  # scalar fast path (np.float64 is a float)
        n = round(phi / math.pi)
        r = phi - n * math.pi
        s, c = math.sin(r), math.cos(r)
        val = s**3 / 3.0 * float(elliprd(c * c, c * c + m1 * s * s, 1.0))
        return val + 2.0 * n * float(elliprd(0.0, m1, 1.0)) / 3.0 if n else val
    n = np.round(phi / math.pi)
    r = phi - n * math.pi
    s, c = np.sin(r), np.cos(r)
    val = s**3 / 3.0 * elliprd(c * c, c * c + m1 * s * s, 1.0)
    if np.any(n != 0.0):
        val = val + 2.0 * n * elliprd(0.0, m1, 1.0) / 3.0
    return val


def _one_minus_cn(cnh, snh):  # noqa: ANN001, ANN202
    """1 - cn(h) without cancellation for small h."""
    if np.ndim(cnh) == 0:
        return snh * snh / (1.0 + cnh) if cnh > 0.0 else 1.0 - cnh
    return np.where(cnh > 0.0, snh * snh / (1.0 + np.abs(cnh)), 1.0 - cnh)


@dataclass(frozen=True)
class Orbit:
    """Elliptic parameters of the pendulum orbit through (u0, p0).

    kind : "rest" (equilibrium), "lib" (libration) or "rot" (rotation).
    m, m1 : parameter and 1 - m.  w0 : elliptic argument at s = 0.  rate : dw/ds.
    amp : 2 lam k (lib) or 2 sig omega (rot): p = amp cn(w) or amp dn(w).
    k : modulus (lib) or omega = lam k (rot).  a0 : am(w0).  shift : 2 pi multiple removed.
    """

    kind: str
    m: float
    m1: float
    w0: float
    rate: float
    amp: float
    k: float
    a0: float
    shift: float
    uw: float


@functools.lru_cache(maxsize=16)
def orbit(u0: float, p0: float, lam: float, m1: float | None = None) -> Orbit:
    """Parameters of the orbit (``m1`` overrides 1 - m when the caller knows it exactly).

    Cached for the last few states: a reported state asks for its orbit three times (tip
    flow, tip state, largest curvature)."""
    j = math.floor((u0 + math.pi) / TWO_PI)
    uw = u0 - j * TWO_PI
    if uw <= -math.pi:
        uw, j = uw + TWO_PI, j - 1
    half, q = 0.5 * uw, 0.5 * p0
    sh, ch = math.sin(half), math.cos(half)
    if p0 == 0.0 and (lam == 0.0 or math.sin(uw) == 0.0):
        return Orbit("rest", 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, half, j * TWO_PI, uw)
    r = abs(q) / lam if lam > 0.0 else math.inf
    if r < ch:  # libration, m = k^2 = r^2 + sh^2
        m1 = (ch - r) * (ch + r) if m1 is None else m1
        m = 1.0 - m1
        psi0 = math.atan2(sh, q / lam)
        k = math.sqrt(r * r + sh * sh)
        return Orbit("lib", m, m1, ellF(psi0, m, m1), lam, 2.0 * lam * k, k, psi0, j * TWO_PI, uw)
    sig = 1.0 if q > 0.0 else -1.0
    omega = math.sqrt(q * q + (lam * sh) ** 2)
    if m1 is None:
        m1 = (abs(q) - lam * ch) * (abs(q) + lam * ch) / (omega * omega)
    m = 1.0 - m1
    return Orbit("rot", m, m1, ellF(half, m, m1), sig * omega, 2.0 * sig * omega, omega, half,
                 j * TWO_PI, uw)  # fmt: skip


def pendulum(
    u0: float, p0: float, lam: float, s: float | np.ndarray, m1: float | None = None
) -> tuple:
    """Exact pendulum flow u'' = -lam^2 sin u from (u0, p0) over arc lengths s.

    Parameters
    ----------
    u0, p0 : initial angle (rad) and slope u'(0) (1/length).
    lam : sqrt(P/EI) (1/length), >= 0.
    s : arc lengths, shape (n,), or a float (scalar fast path).
    m1 : exact 1 - m of the orbit if known (else computed from u0, p0, lam).

    Returns
    -------
    u, p, A, B, U2 : of the shape of ``s``: u(s), u'(s), A = int_0^s cos u, B = int_0^s sin u
        (length), U2 = int_0^s u'^2 (1/length).
    """
    if not isinstance(s, float):
        s = np.asarray(s, dtype=float)
    o = orbit(u0, p0, lam, m1)
    if o.kind == "rest":  # equilibrium: straight beam
        z = np.zeros_like(s)
        return z + u0, z, s * math.cos(o.uw), s * math.sin(o.uw), z
    m, m1 = o.m, o.m1
    h = o.rate * s
    snh, cnh, dnh, phh = jacobi(h, m, m1)
    sn, cn, dn, ph = jacobi(o.w0 + h, m, m1)
    sn0, cn0 = math.sin(o.a0), math.cos(o.a0)
    dn0 = math.sqrt(cn0 * cn0 + m1 * sn0 * sn0)
    S = incD(phh, m, m1) + sn0 * snh * sn  # int_{w0}^{w} sn^2 dw
    den = cn0 * cn0 + sn0 * sn0 * (cnh * cnh + m1 * snh * snh)  # 1 - m sn0^2 snh^2
    if o.kind == "lib":  # sin(u/2) = k sn, cos(u/2) = dn, p = 2 lam k cn
        u = 2.0 * np.arctan2(o.k * sn, dn) + o.shift
        dcn = (
            cn0 * _one_minus_cn(cnh, snh) - m * cn0 * sn0**2 * snh**2 + sn0 * dn0 * snh * dnh
        ) / den
        A = s - 2.0 * m * S / lam
        B = 2.0 * o.k / lam * dcn  # (2k/lam)(cn0 - cn)
        return u, o.amp * cn, A, B, 4.0 * lam * m * (h - S)
    # rotation: u = 2 am(w), p = 2 sig omega dn
    sig, omega = math.copysign(1.0, o.rate), o.k
    B = 2.0 * sig / omega * _sn2_diff(sn0, cn0, dn0, snh, cnh, dnh, sn, cn, m, m1) / (dn0 + dn)
    A = s - 2.0 * sig * S / omega
    return 2.0 * ph + o.shift, o.amp * dn, A, B, 4.0 * omega * (np.abs(h) - sig * m * S)


def _sn2_diff(sn0, cn0, dn0, snh, cnh, dnh, sn, cn, m, m1):  # noqa: ANN001, ANN202
    """sn(w0 + h)^2 - sn0^2 without cancellation (also for m -> 1, where cn ~ dn).

    For cn(h) dn(h) >= 0 the addition theorem gives sn(w0 + h) - sn0 =
    (sn0 snh^2 X + snh cn0 dn0) / (1 - m sn0^2 snh^2) with X = cnh dnh - 1 + m sn0^2 snh^2
    rewritten as X = -m1 Q / (1 + cnh dnh) - m cn0^2, Q = 1 - m cnh snh^2 / (dnh + cnh) >= 1/2;
    elsewhere the direct cn0^2 - cn^2 is well conditioned.
    """
    cd = cnh * dnh
    q = 1.0 - m * cnh * snh * snh / (dnh + np.abs(cnh))
    X = -m1 * q / (1.0 + np.abs(cd)) - m * cn0 * cn0
    den = cn0 * cn0 + sn0 * sn0 * (cnh * cnh + m1 * snh * snh)  # 1 - m sn0^2 snh^2
    near = (sn0 * snh * snh * X + snh * cn0 * dn0) / den * (sn + sn0)
    return np.where(cd >= 0.0, near, (cn0 - cn) * (cn0 + cn))


def _times_inverse(a: tuple, b: tuple) -> np.ndarray:
    """A B^-1 of two 2x2 matrices given row-major as 4-tuples of floats (plain floats: a
    numpy 2x2 product and inverse cost ~10x more than the arithmetic)."""
    a00, a01, a10, a11 = a
    b00, b01, b10, b11 = b
    det = b00 * b11 - b01 * b10
    return np.array(
        [
            [(a00 * b11 - a01 * b10) / det, (a01 * b00 - a00 * b01) / det],
            [(a10 * b11 - a11 * b10) / det, (a11 * b00 - a10 * b01) / det],
        ]
    )


def _am_m(w: float, sn: float, cn: float, dn: float, ph: float, m: float, m1: float) -> float:
    """d am(w|m)/dm at fixed w (from dF/dm, DLMF 19.4.2, with E = F - m D)."""
    return -(dn * (w - incD(ph, m, m1)) - sn * cn) / (2.0 * m1)


def tip_flow(
    u0: float, p0: float, lam: float, L: float, m1: float | None = None
) -> tuple[float, float, np.ndarray]:
    """Tip state u(L), u'(L) and the (2, 2) Jacobian d(uL, pL)/d(u0, p0) of the exact flow
    (``m1``: the orbit's exact 1 - m when the caller knows it)."""
    o = orbit(u0, p0, lam, m1)
    if o.kind == "rest":  # linearised flow about the equilibrium
        if lam == 0.0:
            return u0, 0.0, np.array([[1.0, L], [0.0, 1.0]])
        x = lam * L
        if math.cos(o.uw) > 0.0:
            c, s = math.cos(x), math.sin(x)
            return u0, 0.0, np.array([[c, s / lam], [-lam * s, c]])
        c, s = math.cosh(x), math.sinh(x)
        return u0, 0.0, np.array([[c, s / lam], [lam * s, c]])
    m, m1 = o.m, o.m1
    wL = o.w0 + o.rate * L
    snL, cnL, dnL, phL = (float(v) for v in jacobi(wL, m, m1))
    sn0, cn0 = math.sin(o.a0), math.cos(o.a0)
    dn0 = math.sqrt(cn0 * cn0 + m1 * sn0 * sn0)
    if o.kind == "lib":

        def jac(w: float, sn: float, cn: float, dn: float, ph: float) -> tuple:
            a = _am_m(w, sn, cn, dn, ph, m, m1)
            # columns d/dk at fixed w and (d/dw)/k (scaled so that k -> 0 stays regular)
            return (
                2.0 * (sn + 2.0 * m * cn * a) / dn,
                2.0 * cn,
                2.0 * lam * (cn - 2.0 * m * sn * a),
                -2.0 * lam * sn * dn,
            )

        J = _times_inverse(jac(wL, snL, cnL, dnL, phL), jac(o.w0, sn0, cn0, dn0, o.a0))
        return 2.0 * math.atan2(o.k * snL, dnL) + o.shift, o.amp * cnL, J
    sig, omega = math.copysign(1.0, o.rate), o.k

    def jac_r(w: float, sn: float, cn: float, dn: float, ph: float) -> tuple:
        a = _am_m(w, sn, cn, dn, ph, m, m1)
        dn_m = -(sn * sn + 2.0 * m * sn * cn * a) / (2.0 * dn)
        # coordinates (omega, w); m = lam^2/omega^2, dm/domega = -2 m/omega
        return (
            -4.0 * m * a / omega,
            2.0 * dn,
            2.0 * sig * (dn - 2.0 * m * dn_m),
            -2.0 * sig * omega * m * sn * cn,
        )

    a, b, c, d = jac_r(wL, snL, cnL, dnL, phL)
    # times T = [[1, 0], [sig L, 1]] (w_L = w0 + sig omega L)
    J = _times_inverse((a + b * sig * L, b, c + d * sig * L, d), jac_r(o.w0, sn0, cn0, dn0, o.a0))
    return 2.0 * phL + o.shift, o.amp * dnL, J


def tip_states(
    u0: np.ndarray, p0: np.ndarray, lam: np.ndarray, L: float, m1: np.ndarray
) -> tuple[np.ndarray, ...]:
    """The flow to the tip of many states at once (arrays of one shape; ``m1`` NaN where not
    known): u(L), u'(L), A(L), B(L), U2(L) of ``pendulum`` and the shooting derivative
    d u'(L) / d u'(0) of ``tip_flow`` (the Jacobi test) of each state of a path.

    Libration orbits with m1 >= ``M1_AGM`` are evaluated on the arrays (the formulas of
    ``orbit``, ``pendulum`` and ``tip_flow``); any other state one by one.
    """
    out = tuple(np.empty(np.shape(u0)) for _ in range(6))
    j = np.floor((u0 + math.pi) / TWO_PI)
    uw = u0 - j * TWO_PI
    j = np.where(uw <= -math.pi, j - 1.0, j)
    uw = np.where(uw <= -math.pi, uw + TWO_PI, uw)
    half, q = 0.5 * uw, 0.5 * p0
    sh, ch = np.sin(half), np.cos(half)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.abs(q) / lam
        vec = (p0 != 0.0) & (lam > 0.0) & (r < ch) & (m1 >= M1_AGM)
    for i in np.flatnonzero(~vec):
        mi = None if np.isnan(m1[i]) else float(m1[i])
        state = (float(u0[i]), float(p0[i]), float(lam[i]))
        flow = pendulum(*state, float(L), mi)
        for k in range(5):
            out[k][i] = flow[k]
        out[5][i] = tip_flow(*state, L, mi)[2][1, 1]
    if not vec.any():
        return out
    sh, q, lm, m1v, r = sh[vec], q[vec], lam[vec], m1[vec], r[vec]
    m = 1.0 - m1v
    k = np.sqrt(r * r + sh * sh)
    psi0 = np.arctan2(sh, q / lm)
    # w0 = F(psi0 | m) on the reduced angle (as ``ellF``)
    n = np.round(psi0 / math.pi)
    rr = psi0 - n * math.pi
    sr, cr = np.sin(rr), np.cos(rr)
    w0 = sr * elliprf(cr * cr, cr * cr + m1v * sr * sr, 1.0) + 2.0 * n * elliprf(0.0, m1v, 1.0)
    h = lm * L
    snh, cnh, dnh, phh = ellipj(h, m)
    sn, cn, dn, ph = ellipj(w0 + h, m)
    sn0, cn0 = np.sin(psi0), np.cos(psi0)
    dn0 = np.sqrt(cn0 * cn0 + m1v * sn0 * sn0)
    S = incD(phh, m, m1v) + sn0 * snh * sn
    den = cn0 * cn0 + sn0 * sn0 * (cnh * cnh + m1v * snh * snh)
    dcn = (cn0 * _one_minus_cn(cnh, snh) - m * cn0 * sn0**2 * snh**2 + sn0 * dn0 * snh * dnh) / den
    out[0][vec] = 2.0 * np.arctan2(k * sn, dn) + j[vec] * TWO_PI
    out[1][vec] = 2.0 * lm * k * cn
    out[2][vec] = L - 2.0 * m * S / lm
    out[3][vec] = 2.0 * k / lm * dcn
    out[4][vec] = 4.0 * lm * m * (h - S)

    def jac(w, sn, cn, dn, ph):  # noqa: ANN001, ANN202 - tip_flow's libration Jacobian
        a = _am_m(w, sn, cn, dn, ph, m, m1v)
        return (
            2.0 * (sn + 2.0 * m * cn * a) / dn,
            2.0 * cn,
            2.0 * lm * (cn - 2.0 * m * sn * a),
            -2.0 * lm * sn * dn,
        )

    _, _, a10, a11 = jac(w0 + h, sn, cn, dn, ph)
    b00, b01, b10, b11 = jac(w0, sn0, cn0, dn0, psi0)
    out[5][vec] = (a11 * b00 - a10 * b01) / (b00 * b11 - b01 * b10)
    return out


def max_abs_p(u0: float, p0: float, lam: float, L: float, pL: float, m1: float | None = None):  # noqa: ANN201
    """Exact max |u'| over [0, L]: |cn| or dn peaks at w = 2 j K inside the span, else an end."""
    o = orbit(u0, p0, lam, m1)
    ends = max(abs(p0), abs(pL))
    if o.kind == "rest" or (o.kind == "lib" and o.m == 0.0):
        return ends
    if o.m == 0.0:
        return abs(o.amp)
    K2 = 2.0 * ellK(o.m1)
    w1 = o.w0 + o.rate * L
    lo, hi = min(o.w0, w1), max(o.w0, w1)
    return abs(o.amp) if math.floor(hi / K2) >= math.ceil(lo / K2) else ends
