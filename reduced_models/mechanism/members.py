"""Member energy laws and potential terms of the mechanism assembler.

Every term is vectorised over all its items in the scene and returns, for a state ``q``
(absolute unknowns, see ``topology``), its energy and local gradient/Hessian blocks with the
global indices they scatter to::

    term.energy(q) -> float
    term.local(q) -> (idx (E, k) int, g (E, k), H (E, k, k))

Terms (open list: a boom is one more term plus one more constraint):

* ``ChainTerm`` -- linear-N, bcm and cbcm-N members: N chained segments, each in the frame of
  the previous segment's tip (``reduced_models.beam.chain``), with the mixed Lagrangian of the
  segment law (``SegmentLaw``: value = strain energy at the stationary axial force p).  The
  chain's first/last node are the member's end poses (node position + end rotation unknown).
* ``JointTerm`` -- PRB joint springs 1/2 K (psi_p - psi_{p-1})^2 and PRB axial springs
  1/2 K_e u^2 (the PRB chain's kinematics is a ``Closure`` constraint).
* ``TorsionTerm`` -- torsion springs 1/2 k (r_a - r_b - free_angle)^2 between two rotation
  unknowns (ground = the held unknown ``layout.ground``).
* ``SpringTerm`` -- linear springs 1/2 k (|x_b - x_a| - l0)^2.
* ``LoadTerm`` -- minus the work of the dead loads at factor 1: node forces and moments,
  forces at a fraction of a rigid link (nonlinear in the link angle).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from reduced_models.beam.chain import SegmentLaw

#: (global indices (E, k), gradients (E, k), Hessians (E, k, k)) of a term
Local = tuple[np.ndarray, np.ndarray, np.ndarray]


class ChainTerm:
    """Chained-segment members of one segment law (module doc).

    Parameters
    ----------
    law : SegmentLaw (linear or BCM).
    dofs : (S, 7) global indices [X0, Y0, phi0, X1, Y1, phi1, p] per segment.
    h, EI, k, alpha : (S,) segment length, flexural rigidity, axial compliance EI/(EA h^2)
        (0: inextensible), direction of the member from its root end (rad, ``orient``).
    sfac : (S,) E t / 2 of the segment's member (bending stress per curvature; NaN when the
        thickness is unknown).
    """

    def __init__(
        self,
        law: SegmentLaw,
        dofs: ArrayLike,
        h: ArrayLike,
        EI: ArrayLike,
        k: ArrayLike,
        alpha: ArrayLike,
        sfac: ArrayLike,
    ) -> None:
        self.law = law
        self.dofs = np.asarray(dofs, dtype=np.int64).reshape(-1, 7)
        self.h, self.EI, self.k = (np.asarray(v, float) for v in (h, EI, k))
        self.alpha = np.asarray(alpha, float)
        self.sfac = np.asarray(sfac, float)  # E t / 2 per segment (NaN: thickness unknown)
        self.w = self.EI / self.h  # energy scale EI/h per segment
        self.ih = 1.0 / self.h
        # one axial compliance for all segments (the usual case): one law block per call
        self._k1 = float(self.k[0]) if self.k.size and np.all(self.k == self.k[0]) else None
        self._last: tuple | None = None  # (q, coords) of the last evaluation
        self._gpq = np.hstack([law.G.T, law.P.T, law.Q.T])

    def coords(self, q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Segment-normalised ux, y, a, p and cos/sin of the root angle, each (S,); cached
        for the state last seen (``local`` and ``strain`` at the accepted state)."""
        hit = self._last
        if hit is not None and hit[0] is q:
            return hit[1]
        z = q[self.dofs]
        psi = self.alpha + z[:, 2]
        c, s = np.cos(psi), np.sin(psi)
        dX, dY = z[:, 3] - z[:, 0], z[:, 4] - z[:, 1]
        ux = (c * dX + s * dY) * self.ih - 1.0
        y = (-s * dX + c * dY) * self.ih
        out = ux, y, z[:, 5] - z[:, 2], z[:, 6], c, s
        self._last = (q, out)
        return out

    def _forms(self, y: np.ndarray, a: np.ndarray, p: np.ndarray) -> tuple:
        w = np.column_stack([y, a])
        M = w @ self._gpq  # [G w | P w | Q w] in one product
        return w, M[:, 0:2], M[:, 2:4], M[:, 4:6]

    def max_stress(self, q: np.ndarray) -> float:
        """Largest |sigma| = E t |kappa| / 2 at the segment ends (cubic Hermite curvature
        (6 y - 2 a) / h at the root, (4 a - 6 y) / h at the tip); NaN if unknown."""
        _, y, a, _, _, _ = self.coords(q)
        k = np.maximum(np.abs(6 * y - 2 * a), np.abs(4 * a - 6 * y)) / self.h
        return float(np.max(self.sfac * k, initial=-np.inf)) if self.sfac.size else np.nan

    def strain(self, q: np.ndarray) -> np.ndarray:
        """Strain energy per segment (S,) at the current axial forces."""
        ux, y, a, p, _, _ = self.coords(q)
        G, Q = self.law.G, self.law.Q
        wGw = G[0, 0] * y * y + (G[0, 1] + G[1, 0]) * y * a + G[1, 1] * a * a
        wQw = Q[0, 0] * y * y + (Q[0, 1] + Q[1, 0]) * y * a + Q[1, 1] * a * a
        return self.w * (0.5 * wGw + 0.5 * p * p * (self.k - wQw))

    def energy(self, q: np.ndarray) -> float:
        """Value of the mixed Lagrangian (= strain energy at stationary p)."""
        ux, y, a, p, _, _ = self.coords(q)
        w, Gw, Pw, Qw = self._forms(y, a, p)
        wGw, wPw, wQw = (np.einsum("ni,ni->n", w, v) for v in (Gw, Pw, Qw))
        return float(
            np.sum(self.w * (0.5 * wGw + p * (ux + 0.5 * wPw) - 0.5 * p * p * (self.k - wQw)))
        )

    def local(self, q: np.ndarray) -> Local:
        """Gradient (S, 7) and Hessian (S, 7, 7) of the segment Lagrangians.

        The kinematic Jacobian J = d(ux, y, a, p)/d(local unknowns) and the curvature of ux
        and y in phi0 are linear in (cos/h, sin/h, y, ux + 1, 1): one product with constant
        patterns builds them for all segments; the law's derivatives come from
        ``SegmentLaw.block`` (one product) when every segment has the same axial compliance.
        """
        ux, y, a, p, c, s = self.coords(q)
        n = ux.size
        B = self._block(ux, y, a, p)  # (n, 4, 5): [d2l | dl]
        B *= self.w[:, None, None]  # energy scale EI/h once, before the products
        Hl, gl = B[:, :, :4], B[:, :, 4]
        coef = np.empty((n, 5))
        np.multiply(c, self.ih, out=coef[:, 0])
        np.multiply(s, self.ih, out=coef[:, 1])
        coef[:, 2], coef[:, 3], coef[:, 4] = y, ux + 1.0, 1.0
        J = (coef @ _J7).reshape(n, 4, 7)
        JT = J.transpose(0, 2, 1)
        g = (JT @ gl[:, :, None])[:, :, 0]
        H = JT @ (Hl @ J)
        # row/column phi0 of the curvature terms gx d2ux + gy d2y: bilinear in (gx, gy) and
        # the coefficients, one product with a constant pattern
        r = (gl[:, :2, None] * coef[:, None, :]).reshape(n, 10) @ _R10
        H[:, 2, :] += r
        H[:, :, 2] += r
        return self.dofs, g, H

    def _block(self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray) -> np.ndarray:
        if self._k1 is not None:
            return self.law.block(ux, y, a, p, self._k1)
        out = np.empty((ux.size, 4, 5))
        for kk in np.unique(self.k):
            i = np.flatnonzero(self.k == kk)
            out[i] = self.law.block(ux[i], y[i], a[i], p[i], float(kk))
        return out


# constant patterns: J (4 x 7, flat) and the phi0 curvature row (7) from their coefficients
_J7 = np.zeros((5, 4, 7))
_J7[0, 0, [0, 3]] = _J7[0, 1, [1, 4]] = (-1.0, 1.0)  # cos/h
_J7[1, 0, [1, 4]] = (-1.0, 1.0)  # sin/h
_J7[1, 1, [0, 3]] = (1.0, -1.0)
_J7[2, 0, 2] = 1.0  # y: d ux / d phi0
_J7[3, 1, 2] = -1.0  # ux + 1: d y / d phi0
_J7[4, 2, [2, 5]] = (-1.0, 1.0)  # a = phi1 - phi0
_J7[4, 3, 6] = 1.0  # p
_J7 = _J7.reshape(5, 28)
# r = gx * (si, -ci, ., -si, ci) + gy * (ci, si, ., -ci, -si) - (gx xi + gy y) e_phi0 / 2:
# the diagonal term is added twice (row and column), hence the halves.  Rows: (g index,
# coefficient index) flattened as 5 g + a, g in (gx, gy), a in (c/h, s/h, y, ux + 1, 1)
_R10 = np.zeros((2, 5, 7))
_R10[0, 1, [0, 3]] = (1.0, -1.0)  # gx si
_R10[1, 0, [0, 3]] = (1.0, -1.0)  # gy ci
_R10[0, 0, [1, 4]] = (-1.0, 1.0)  # gx ci
_R10[1, 1, [1, 4]] = (1.0, -1.0)  # gy si
_R10[0, 3, 2] = -0.5  # gx (ux + 1)
_R10[1, 2, 2] = -0.5  # gy y
_R10 = _R10.reshape(10, 7)


class JointTerm:
    """Quadratic springs on differences of unknowns: 1/2 K (q[i] - q[j])^2 (j may be the
    held ground unknown); PRB joints (psi_p - psi_{p-1}) and PRB axial springs (u - 0)."""

    def __init__(
        self, i: ArrayLike, j: ArrayLike, K: ArrayLike, sfac: ArrayLike | None = None
    ) -> None:
        self.dofs = np.column_stack([np.asarray(i, np.int64), np.asarray(j, np.int64)])
        self.K = np.asarray(K, float)
        self.offset = np.zeros(len(self.K))
        # bending stress per joint moment, t / (2 I) (NaN: not a PRB joint or t unknown)
        self.sfac = np.full(len(self.K), np.nan) if sfac is None else np.asarray(sfac, float)

    def max_stress(self, q: np.ndarray) -> float:
        """Largest |M| t / (2 I) over the joints (PRB joint moments); NaN if unknown."""
        d = q[self.dofs[:, 0]] - q[self.dofs[:, 1]] - self.offset
        return float(np.nanmax(np.abs(self.K * d) * self.sfac, initial=-np.inf))

    def energy(self, q: np.ndarray) -> float:
        d = q[self.dofs[:, 0]] - q[self.dofs[:, 1]] - self.offset
        return float(0.5 * np.sum(self.K * d * d))

    def local(self, q: np.ndarray) -> Local:
        d = q[self.dofs[:, 0]] - q[self.dofs[:, 1]] - self.offset
        f = self.K * d
        g = np.column_stack([f, -f])
        H = self.K[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        return self.dofs, g, H


class TorsionTerm(JointTerm):
    """Torsion springs 1/2 k (r_a - r_b - free_angle)^2 (r_b: ground unknown for ground)."""

    def __init__(self, a: ArrayLike, b: ArrayLike, k: ArrayLike, free_angle: ArrayLike) -> None:
        super().__init__(a, b, k)
        self.offset = np.asarray(free_angle, float)


class SpringTerm:
    """Linear springs between node positions: 1/2 k (|x_b - x_a| - l0)^2."""

    def __init__(self, xa: ArrayLike, xb: ArrayLike, k: ArrayLike, l0: ArrayLike) -> None:
        xa, xb = np.asarray(xa, np.int64), np.asarray(xb, np.int64)
        self.dofs = np.column_stack([xa, xa + 1, xb, xb + 1])
        self.k, self.l0 = np.asarray(k, float), np.asarray(l0, float)

    def _d(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z = q[self.dofs]
        d = z[:, 2:] - z[:, :2]
        ell = np.hypot(d[:, 0], d[:, 1])
        return d, ell

    def energy(self, q: np.ndarray) -> float:
        _, ell = self._d(q)
        return float(0.5 * np.sum(self.k * (ell - self.l0) ** 2))

    def local(self, q: np.ndarray) -> Local:
        d, ell = self._d(q)
        e = d / ell[:, None]
        f = self.k * (ell - self.l0)
        ge = f[:, None] * e
        g = np.concatenate([-ge, ge], axis=1)
        # d2/dd2 = k e e^T + f/ell (I - e e^T)
        ee = e[:, :, None] * e[:, None, :]
        Kd = self.k[:, None, None] * ee + (f / ell)[:, None, None] * (np.eye(2) - ee)
        H = np.zeros((len(f), 4, 4))
        H[:, :2, :2] = H[:, 2:, 2:] = Kd
        H[:, :2, 2:] = H[:, 2:, :2] = -Kd
        return self.dofs, g, H


class LoadTerm:
    """Minus the work of the dead loads at factor 1.

    Parameters
    ----------
    linear : (n,) constant part: -F at translation unknowns, -M at rotation unknowns.
    rigid : rows (x index of the link's node a, angle unknown, lever f L, drawn angle alpha,
        fx, fy) for forces at a fraction of a rigid link.
    """

    def __init__(self, linear: np.ndarray, rigid: list[tuple]) -> None:
        self.lin = np.asarray(linear, float)
        r = np.array(rigid, float).reshape(-1, 6)
        self.xa, self.th = r[:, 0].astype(np.int64), r[:, 1].astype(np.int64)
        self.lever, self.alpha, self.f = r[:, 2], r[:, 3], r[:, 4:6]
        self.dofs = self.th[:, None]

    def energy(self, q: np.ndarray) -> float:
        psi = self.alpha + q[self.th]
        lin = float(self.lin @ q)  # includes -F . x_a for the rigid-link loads
        return lin - float(
            np.sum(self.lever * (self.f[:, 0] * np.cos(psi) + self.f[:, 1] * np.sin(psi)))
        )

    def local(self, q: np.ndarray) -> Local:
        psi = self.alpha + q[self.th]
        c, s = np.cos(psi), np.sin(psi)
        fx, fy = self.f[:, 0], self.f[:, 1]
        g = (-self.lever * (-fx * s + fy * c))[:, None]
        H = (self.lever * (fx * c + fy * s))[:, None, None]
        return self.dofs, g, H
