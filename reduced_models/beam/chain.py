"""Chained-segment kinematics and mixed Lagrangian of the linear-N, bcm and cbcm-N models.

A beam of length L is split into N equal segments of length h = L/N.  Following DAS-2D
(seed 000, "Multiple Segment Models", "Analytical Hessian") and Ma & Chen (2016), each
segment is described in the frame of the previous segment's tip, so a segment's energy
depends only on its two end nodes and the Hessian is block-tridiagonal.

Unknowns (normalised: lengths by L, forces by EI/L^2, energies by EI/L), per node
i = 0..N: ``[X_i, Y_i, phi_i, p_i]`` -- the node position and cross-section angle in the beam
frame, and the axial force p_i of segment i (segment-normalised, p h^2/EI, tension +; p_0 is a
dummy).  Segment i sees, in the frame rotated by phi_{i-1} and scaled by h,

    xi  = ( cos(phi_{i-1}) dX + sin(phi_{i-1}) dY) / h,   ux = xi - 1
    eta = (-sin(phi_{i-1}) dX + cos(phi_{i-1}) dY) / h,   y  = eta
    a   = phi_i - phi_{i-1}

and stores the segment-normalised mixed Lagrangian (Awtar & Sen 2010 energy with the
x-displacement relation enforced by the axial force p as a multiplier):

    l(ux, w, p) = 1/2 w.G.w + p (ux + 1/2 w.P.w) - 1/2 p^2 (k - w.Q.w),   w = (y, a)

with k = EI/(EA h^2) (= t^2/12).  Stationarity in p gives the BCM x-relation
ux = p (k - w.Q.w) - 1/2 w.P.w; stationarity in w gives [f, m] = (G + p P + p^2 Q) w; the
value at stationarity is the BCM strain energy 1/2 w.G.w + 1/2 p^2 (k - w.Q.w).  With
P = Q = 0 and k = 0 the same expression is the linear Euler-Bernoulli segment of the seed
(V = 2EI/h^3 (3 dy^2 + h^2 a^2 - 3 h dy a)) with the axial constraint ux = 0 enforced by p.

Why the multiplier form rather than eliminating p (p = (ux + 1/2 w.P.w)/(k - w.Q.w)):
the Lagrangian is a polynomial, so its gradient and Hessian are short and exact; it is
well defined for an inextensible beam (k = 0, EA not given), where the eliminated energy is
0/0 at the straight state; and it covers the linear chain (whose axial constraint has no
energy) with the same code.  The price is an indefinite Hessian: it is solved by banded LU
(half-bandwidth 7), and stability is judged by its inertia (stable iff exactly N negative
eigenvalues, one per multiplier -- Haynsworth inertia additivity), decided in O(N) by
condensing each p_i inside its segment and a banded Cholesky factorisation.

Total potential: Pi = N sum_i l_i - lam * (fX X_N + fY Y_N + m phi_N) for dead loads; a
follower force turns with phi_N (residual Newton with the unsymmetric Jacobian, stability
not assessed).  Newton updates go through ``ChainProblem.update``, which rebuilds node
positions from the updated segment deformations (forward kinematics): without it the
iteration count grows with N and Newton diverges for N >~ 64.

The shared Model-protocol layer (``ChainModel``: ``applies_to``/``solve``) lives in
``reduced_models.beam.chain_model`` and stays importable from here.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from reduced_models.paths.linalg import Banded


NB = 4  # unknowns per node: X, Y, phi, p
HALF_BAND = 2 * NB - 1  # block-tridiagonal with 4x4 blocks -> 7 off-diagonals


# Constant patterns of the kinematic Jacobian J = d(ux, y, a, p)/d(X0, Y0, phi0, p0, X1, Y1,
# phi1, p1) of a segment and of the phi0-row of the second derivatives of (ux, y): both are
# linear in the per-segment coefficients (c/h, s/h, eta, xi, 1), so one matrix product per
# Newton iteration builds them for all segments.
_J_PATTERN = np.zeros((5, 4, 2 * NB))
_J_PATTERN[0, 0, [0, 4]] = _J_PATTERN[0, 1, [1, 5]] = (-1.0, 1.0)  # c/h
_J_PATTERN[1, 0, [1, 5]] = _J_PATTERN[1, 1, [4, 0]] = (-1.0, 1.0)  # s/h
_J_PATTERN[2, 0, 2] = 1.0  # eta: d ux / d phi0
_J_PATTERN[3, 1, 2] = -1.0  # xi: d y / d phi0
_J_PATTERN[4, 2, [2, 6]] = (-1.0, 1.0)  # a = phi1 - phi0
_J_PATTERN[4, 3, 7] = 1.0  # p = p1
_J_PATTERN = _J_PATTERN.reshape(5, -1)
_V_PATTERN = np.zeros((5, 2, 2 * NB))  # d2(ux, y) / d phi0 d(local)
_V_PATTERN[0, 0, [1, 5]] = _V_PATTERN[0, 1, [4, 0]] = (-1.0, 1.0)
_V_PATTERN[1, 0, [4, 0]] = _V_PATTERN[1, 1, [5, 1]] = (-1.0, 1.0)
_V_PATTERN[2, 1, 2] = -1.0
_V_PATTERN[3, 0, 2] = -1.0
_V_PATTERN = _V_PATTERN.reshape(5, -1)


@dataclass(frozen=True)
class SegmentLaw:
    """Coefficient matrices (2x2) of the segment-normalised mixed Lagrangian (module doc)."""

    G: np.ndarray
    P: np.ndarray
    Q: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "_coef_cache", {})

    def coefficients(self, k: float) -> np.ndarray:
        """(18, 20) matrix C: ``[d2l | dl]`` (4 x 5 per segment, flat) = monomials @ C + ux e.

        Every entry of the gradient and Hessian of l is a polynomial in (p, y, a) (plus ux in
        dl/dp): p^i times one of (1, y, a, y^2, y a, a^2), i = 0, 1, 2 -- 18 monomials.  The
        coefficients are written out here once per k, so a Newton iteration evaluates all
        20 derivatives of all segments with one matrix product (see ``block``):

        dl = [p, K w, ux + w.P.w/2 - p D],  d2l = [[0, 0, 1], [0, K, c], [1, c, -D]],
        K = G + p P + p^2 Q, c = P w + 2 p Q w, D = k - w.Q.w, w = (y, a).
        """
        C = self._coef_cache.get(k)
        if C is not None:
            return C
        G, P, Q = self.G, self.P, self.Q
        C = np.zeros((3, 6, 4, 5))  # [p power, monomial of w, row of [d2l | dl], column]
        ONE, Y, A, YY, YA, AA = range(6)
        C[1, ONE, 0, 4] = 1.0  # dl/dux = p
        for i, M in enumerate((G, P, Q)):
            for r in (0, 1):  # rows y, a of K w and of K
                C[i, Y, 1 + r, 4], C[i, A, 1 + r, 4] = M[r, 0], M[r, 1]
                C[i, ONE, 1 + r, 1], C[i, ONE, 1 + r, 2] = M[r, 0], M[r, 1]
        for r in (0, 1):  # c = P w + 2 p Q w in column and row p
            for i, M, f in ((0, P, 1.0), (1, Q, 2.0)):
                C[i, Y, 1 + r, 3] = C[i, Y, 3, 1 + r] = f * M[r, 0]
                C[i, A, 1 + r, 3] = C[i, A, 3, 1 + r] = f * M[r, 1]
        # dl/dp = ux + w.P.w/2 - p k + p w.Q.w;  d2l/dp2 = -k + w.Q.w
        C[0, [YY, YA, AA], 3, 4] = 0.5 * P[0, 0], P[0, 1], 0.5 * P[1, 1]
        C[1, [ONE, YY, YA, AA], 3, 4] = -k, Q[0, 0], 2.0 * Q[0, 1], Q[1, 1]
        C[0, [ONE, YY, YA, AA], 3, 3] = -k, Q[0, 0], 2.0 * Q[0, 1], Q[1, 1]
        C[0, ONE, 0, 3] = C[0, ONE, 3, 0] = 1.0  # d2l/dux dp
        C = C.reshape(18, 20)
        self._coef_cache[k] = C
        return C

    def block(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> np.ndarray:
        """``[d2l | dl]``, shape (N, 4, 5): Hessian and gradient of l in (ux, y, a, p)."""
        n = ux.shape[0]
        mono = np.empty((n, 3, 6))  # p^i times (1, y, a, y^2, y a, a^2), i = 0, 1, 2
        m2 = mono[:, 0]
        m2[:, 0], m2[:, 1], m2[:, 2] = 1.0, y, a
        m2[:, 3:5] = y[:, None] * m2[:, 1:3]
        m2[:, 5] = a * a
        np.multiply(p[:, None], m2, out=mono[:, 1])  # products, not float powers (cheaper)
        np.multiply(p[:, None], mono[:, 1], out=mono[:, 2])
        out = mono.reshape(n, 18) @ self.coefficients(k)
        out[:, 19] += ux
        return out.reshape(n, 4, 5)

    def lagrangian(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value (N,), gradient (N, 4) and Hessian (N, 4, 4) in (ux, y, a, p)."""
        w = np.stack([y, a], axis=1)
        wGw = np.einsum("ni,ij,nj->n", w, self.G, w)
        wPw = np.einsum("ni,ij,nj->n", w, self.P, w)
        wQw = np.einsum("ni,ij,nj->n", w, self.Q, w)
        val = 0.5 * wGw + p * (ux + 0.5 * wPw) - 0.5 * p * p * (k - wQw)
        B = self.block(ux, y, a, p, k)
        return val, B[:, :, 4], B[:, :, :4]

    def energy(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> np.ndarray:
        """Segment strain energy (N,) at the stationary axial force p (normalised EI/h)."""
        (g00, g01), (g10, g11) = self.G.tolist()
        (q00, q01), (q10, q11) = self.Q.tolist()
        yy, ya, aa = y * y, y * a, a * a  # the quadratic forms written out (no einsum parsing)
        wGw = g00 * yy + (g01 + g10) * ya + g11 * aa
        wQw = q00 * yy + (q01 + q10) * ya + q11 * aa
        return 0.5 * wGw + 0.5 * p**2 * (k - wQw)

    def stiffness(self, p: np.ndarray) -> np.ndarray:
        """Transverse stiffness G + p P + p^2 Q, shape (N, 2, 2)."""
        p = np.asarray(p, dtype=float)[:, None, None]
        return self.G + p * self.P + p**2 * self.Q


def local_coords(nodes: np.ndarray, h: float) -> tuple[np.ndarray, ...]:
    """Segment-frame tip coordinates from node states.

    Parameters
    ----------
    nodes : (..., N + 1, 3) normalised node states (X, Y, phi), optionally stacked.
    h : normalised segment length 1/N.

    Returns
    -------
    xi, eta, a, c, s : each (..., N): normalised local tip position, segment rotation, and
    cos/sin of the previous node's angle.
    """
    X, Y, phi = nodes[..., 0], nodes[..., 1], nodes[..., 2]
    c, s = np.cos(phi[..., :-1]), np.sin(phi[..., :-1])
    dX, dY = X[..., 1:] - X[..., :-1], Y[..., 1:] - Y[..., :-1]
    xi = (c * dX + s * dY) / h
    eta = (-s * dX + c * dY) / h
    return xi, eta, phi[..., 1:] - phi[..., :-1], c, s


def _band_index(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Scatter maps: local (N, 8) gradient -> global, local (N, 8, 8) -> flat band storage."""
    n = NB * (N + 1)
    gdof = NB * np.arange(N)[:, None] + np.arange(2 * NB)[None, :]  # (N, 8)
    rows = gdof[:, :, None]
    cols = gdof[:, None, :]
    band_row = HALF_BAND + rows - cols  # ab[u + i - j, j]
    return gdof.ravel(), (band_row * n + cols).ravel()


class ChainProblem:
    """Residual and banded tangent of a clamped chain of N segments under tip loads.

    Parameters
    ----------
    law : SegmentLaw.
    N : number of segments.
    k : segment axial compliance EI/(EA h^2) (0: inextensible).
    loads : (fX, fY, m) normalised tip loads at factor 1 in the beam frame.
    follower : tip force turns with the tip section.
    guided : tip rotation held at 0.
    """

    def __init__(
        self,
        law: SegmentLaw,
        N: int,
        k: float,
        loads: tuple[float, float, float],
        follower: bool = False,
        guided: bool = False,
    ) -> None:
        self.law, self.N, self.k = law, N, float(k)
        self.h = 1.0 / N
        self.loads = np.asarray(loads, dtype=float)
        self.follower, self.guided = follower, guided
        self.n = NB * (N + 1)
        tip = NB * N
        self.tip = tip
        self.fixed = np.array([0, 1, 2, 3] + ([tip + 2] if guided else []))
        self.x0 = np.zeros(self.n)
        self.x0[0::NB] = np.arange(N + 1) * self.h
        self.scale = np.ones(self.n)
        self.scale[3::NB] = self.h**2  # p is segment-normalised: p_seg = p_glob h^2
        # damping: at most 0.5 (L or rad) per Newton update in geometry, none in p
        self.max_step = np.full(self.n, 0.5)
        self.max_step[3::NB] = np.inf
        self._dead = np.zeros(self.n)  # d(residual)/d(load factor) for dead loads
        self._dead[tip : tip + 3] = -self.loads
        self._coef = np.ones((N, 5))
        self._cache: tuple | None = None
        self._coords_cache: tuple | None = None

    # scatter maps, built on first use (a one-segment chain on floats never needs them)
    @functools.cached_property
    def _scatter(self) -> tuple[np.ndarray, np.ndarray]:
        """``(gdof, bidx)``: ``_band_index(N)``."""
        return _band_index(self.N)

    @functools.cached_property
    def _condensed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ridx, rfixed, keep)``: scatter map of the condensed (X, Y, phi) segment
        Hessians (N, 6, 6) to upper band storage ab[5 + i - j, j] for i <= j (lower-triangle
        entries go to a dump slot), the held rows, the kept local unknowns."""
        N = self.N
        rdof = 3 * np.arange(N)[:, None] + np.arange(6)[None, :]
        r, cc = rdof[:, :, None], rdof[:, None, :]
        ridx = np.where(r <= cc, (5 + r - cc) * 3 * (N + 1) + cc, 6 * 3 * (N + 1)).ravel()
        rfixed = np.array([0, 1, 2] + ([3 * N + 2] if self.guided else []))
        return ridx, rfixed, np.array([0, 1, 2, 4, 5, 6])

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node states (..., N + 1, 3) and segment axial forces (..., N) from unknowns (..., n)."""
        q = x.reshape(x.shape[:-1] + (self.N + 1, NB))
        return q[..., :3], q[..., 1:, 3]

    def _coords(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local tip coordinates z = xi + i eta (N,) and N e^{-i phi_{i-1}} (N,).

        Node rows [X, Y, phi, p] are read as complex pairs (X + i Y, phi + i p).  Coordinates
        of a state made by ``update`` are known already (forward kinematics from them).
        """
        c = self._coords_cache
        if c is not None and c[0] is x and np.array_equal(c[1], x):
            return c[2], c[3]
        qc = np.ascontiguousarray(x).reshape(self.N + 1, NB).view(np.complex128)
        Ne = self.N * np.exp(-1j * qc[:-1, 1].real)
        return Ne * (qc[1:, 0] - qc[:-1, 0]), Ne

    def local(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment gradients (N, 8) and Hessians (N, 8, 8) of N * l_i in the local unknowns
        (X0, Y0, phi0, p0, X1, Y1, phi1, p1) of each segment (no load terms)."""
        c = self._cache
        if c is not None and c[0] is x and np.array_equal(c[1], x):
            return c[2]  # update/stability/tangent ask again at the state just evaluated
        N = self.N
        q = x.reshape(N + 1, NB)
        z, Ne = self._coords(x)
        xi, eta = z.real, z.imag
        B = N * self.law.block(xi - 1.0, eta, q[1:, 2] - q[:-1, 2], q[1:, 3], self.k)
        coef = self._coef  # (c/h, s/h, eta, xi, 1) per segment
        coef[:, 0], coef[:, 1], coef[:, 2], coef[:, 3] = Ne.real, -Ne.imag, eta, xi
        J = (coef @ _J_PATTERN).reshape(N, 4, 2 * NB)
        JB = J.transpose(0, 2, 1) @ B  # (N, 8, 5): [J^T d2l | J^T dl]
        gloc = JB[:, :, 4]
        Hloc = JB[:, :, :4] @ J
        # curvature of xi and eta in phi_{i-1} (row/column 2 of their second derivatives)
        G2 = (B[:, None, :2, 4] @ (coef @ _V_PATTERN).reshape(N, 2, 2 * NB))[:, 0]
        G2[:, 2] *= 0.5  # the (phi0, phi0) entry is reached by both the row and the column
        Hloc[:, 2, :] += G2
        Hloc[:, :, 2] += G2
        self._cache = (x, x.copy(), (gloc, Hloc))
        self._coords_cache = (x, self._cache[1], z, Ne)
        return gloc, Hloc

    def update(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """Retraction used by the continuation instead of ``x + dx``.

        The update is mapped to segment deformations (ux, y, a) through the kinematic
        Jacobian (exact to first order), and the node positions are rebuilt from the new
        deformations by forward kinematics (cumulative sums; angles and axial forces are
        linear and simply add).  Without it a Newton step that rotates a long chain leaves
        O(phi^2) errors in every segment's local coordinates, which are large against the
        small per-segment deformations of a long chain and make Newton diverge for N >~ 64.
        """
        z, Ne = self._coords(x)
        d = np.ascontiguousarray(dx).reshape(self.N + 1, NB)
        dc = d.view(np.complex128)
        # first-order change of z = N e^{-i phi_{i-1}} (dX + i dY), then forward kinematics
        z2 = z + Ne * (dc[1:, 0] - dc[:-1, 0]) - 1j * z * d[:-1, 2]
        out = x.reshape(self.N + 1, NB) + d
        oc = out.view(np.complex128)
        rot = np.exp(1j * out[:-1, 2])
        oc[1:, 0] = oc[0, 0] + self.h * np.cumsum(rot * z2)
        x2 = out.ravel()
        self._coords_cache = (x2, x2.copy(), z2, self.N * rot.conj())
        return x2

    def grad_hess(self, x: np.ndarray, lam: float) -> tuple[np.ndarray, Banded]:
        """Residual (n,) and tangent (band storage, 7 + 7 diagonals) at load factor lam."""
        from reduced_models.paths.linalg import Banded  # lazy: a chain law's import needs no scipy

        gloc, Hloc = self.local(x)
        gdof, bidx = self._scatter
        g = np.bincount(gdof, gloc.ravel(), minlength=self.n)
        nb = 2 * HALF_BAND + 1
        ab = np.bincount(bidx, Hloc.ravel(), minlength=nb * self.n).reshape(nb, self.n)
        t = self.tip
        if self.follower:
            fX, fY, m = lam * self.loads
            phi = x[t + 2]
            cp, sp = math.cos(phi), math.sin(phi)
            g[t] -= cp * fX - sp * fY
            g[t + 1] -= sp * fX + cp * fY
            g[t + 2] -= m
            # d(-F)/dphi in rows X_N, Y_N, column phi_N: ab[u + i - j, j]
            ab[HALF_BAND - 2, t + 2] += sp * fX + cp * fY
            ab[HALF_BAND - 1, t + 2] += -(cp * fX - sp * fY)
        else:
            g[t : t + 3] += lam * self._dead[t : t + 3]
        return g, Banded(ab, HALF_BAND, HALF_BAND, symmetric=not self.follower)

    def load_gradient(self, x: np.ndarray, lam: float) -> np.ndarray:
        """d(residual)/d(load factor) (n,): minus the tip loads (turned with a follower)."""
        if not self.follower:
            return self._dead
        fX, fY, m = self.loads
        t = self.tip
        cp, sp = math.cos(x[t + 2]), math.sin(x[t + 2])
        out = np.zeros(self.n)
        out[t : t + 3] = -(cp * fX - sp * fY), -(sp * fX + cp * fY), -m
        return out

    def stability(self, x: np.ndarray, lam: float, H: Banded) -> bool | None:
        """Is the equilibrium a strict minimum of the strain energy minus the load work?

        The axial forces are condensed out segment by segment (each p_i lives in one
        segment only), which leaves the Hessian of the energy in (X, Y, phi) with 3x3-block
        tridiagonal structure; a banded Cholesky factorisation then decides positive
        definiteness in O(N).  Where a segment has no axial compliance (linear segments,
        BCM with EA not given) the condensation caps its axial pivot at -1e-9 N^3: a
        penalty equal to an axial stiffness EA = 1e9 EI/L^2 whatever N, which moves a
        critical load P by a relative ~P / EA (2.5e-9 at a cantilever's Euler load).  Why
        not stiffer: the penalty (1e9 N) must stay within a modest factor of the largest
        bending stiffness (12 N^3) for Cholesky to decide; a pivot of -1e-9 N gave a
        condition ~1e19 at N = 512 and verdicts that round-off decided.
        Follower loads are not conservative: None.
        """
        if self.follower:
            return None
        from scipy.linalg import lapack  # lazy: a chain law's import needs no scipy

        from reduced_models.paths.linalg import Banded

        _, Hloc = self.local(x)
        Hpp = np.minimum(Hloc[:, 7, 7], -1e-9 * self.N**3)
        ridx, rfixed, keep = self._condensed
        Hc = Hloc[:, keep, 7]
        Hr = Hloc[:, keep[:, None], keep] - Hc[:, :, None] * (Hc / Hpp[:, None])[:, None, :]
        nr = 3 * (self.N + 1)
        ab = np.bincount(ridx, Hr.ravel(), minlength=6 * nr + 1)[: 6 * nr]
        R = Banded(ab.reshape(6, nr), 0, 5)
        R.fix(rfixed)
        return lapack.dpbtrf(R.ab)[1] == 0

    def tip_loads_of(
        self,
        xi: np.ndarray,
        eta: np.ndarray,
        a: np.ndarray,
        c: np.ndarray,
        s: np.ndarray,
        p: np.ndarray,
    ) -> np.ndarray:
        """Loads (fX, fY, m), (m, 3), the last segment carries at the tip, from its
        constitutive law, given its ``local_coords`` (each (m,)) and axial force p (m,).
        Normalised, beam frame; at equilibrium they equal the applied tip loads (and the
        guided-tip reaction moment)."""
        B = self.law.block(xi - 1.0, eta, a, p, self.k)
        pl, fl, ml = B[:, 0, 4], B[:, 1, 4], B[:, 2, 4]
        N2 = self.N**2
        return np.column_stack([N2 * (c * pl - s * fl), N2 * (s * pl + c * fl), self.N * ml])


def chain_shape(nodes: np.ndarray, xl: np.ndarray, yl: np.ndarray, h: float) -> np.ndarray:
    """Global points of a chain from per-segment local shapes.

    Parameters
    ----------
    nodes : (..., N + 1, 3) normalised node states (optionally stacked over steps).
    xl, yl : (..., N, s) segment-normalised local coordinates, xl[..., 0] = 0 at the root.
    h : normalised segment length.

    Returns
    -------
    (..., N (s - 1) + 1, 2) normalised beam-frame points from root to tip.
    """
    c, s = np.cos(nodes[..., :-1, 2])[..., None], np.sin(nodes[..., :-1, 2])[..., None]
    X = nodes[..., :-1, 0:1] + h * (c * xl - s * yl)
    Y = nodes[..., :-1, 1:2] + h * (s * xl + c * yl)
    lead = nodes.shape[:-2]
    npts = xl.shape[-2] * (xl.shape[-1] - 1)
    pts = np.stack([X[..., :-1], Y[..., :-1]], axis=-1).reshape(lead + (npts, 2))
    return np.concatenate([pts, nodes[..., -1:, :2]], axis=-2)
