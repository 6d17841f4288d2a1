"""Exact member law of a straight uniform flexible member: the (axially extensible) elastica.

In the frame of end a (origin at node a, x along the member's end-a tangent) the pose of end b
is (X, Y, Phi) = (xi, eta, r_b - r_a).  The member is the Kirchhoff rod with bending
stiffness EI and axial stiffness EA, loaded only at its ends.  With s in [0, 1] (units of L),
curvature m = M L / EI, end forces f = F L^2 / EI and axial compliance k = EI / (EA L^2):

    theta' = m,   m' = e (fx sin theta - fy cos theta),   x' = e cos theta,   y' = e sin theta,
    e = 1 + k n,  n = fx cos theta + fy sin theta (axial force),
    u' = m^2 / 2 + k n^2 / 2                                   (energy in EI / L),

from theta = x = y = 0, m = m0.  The unknowns z = (fx, fy, m0) are found by Newton on the
shooting map z -> (x, y, theta)(1) = (X, Y, Phi) / (L, L, 1), whose Jacobian B comes from the
variational equations integrated with the same explicit RK4 steps (the exact derivative of the
discrete flow, so Newton converges quadratically).  Then (hyperelasticity, virtual work)

    gradient  dU/d(X, Y, Phi) = (Fx, Fy, M_b)       (M_b = M(1), the end-b moment),
    Hessian   d(Fx, Fy, M_b)/d(X, Y, Phi) = A B^-1,  A = d(fx, fy, m(1))/dz,

mapped to the six end unknowns (X_a, Y_a, r_a, X_b, Y_b, r_b) with the Jacobian of
(xi, eta, Phi) and its curvature in r_a.  The energy is the RK4 quadrature of u'.

Why extensible: at the straight drawn state the inextensible shooting map is singular
(dX/dfx = 0: the axial load does not change the chord), so the inextensible member has no
stiffness matrix there; the finite axial compliance of the real cross-section (the FE's) makes
the law regular.  The discretisation is ``STEPS`` RK4 steps (error O(STEPS^-4) relative in the
pose; 1e-9 for curvatures m of order 1).  The shooting is warm-started from the member's last
solution (continuation along the mechanism's path picks the branch the path is on; from a
cold start the unbuckled branch nearest z = 0 is taken).
"""

from __future__ import annotations

import math

import numpy as np

from reduced_models.mechanism.newton import SolveError

STEPS = 64
TOL = 1e-13  # shooting residual (pose / L, rad)
MAX_IT = 40


def _rhs(S: tuple, fx: float, fy: float, k: float) -> tuple:
    """Derivatives of the state (th, m, x, y, u, then dth, dm, dx, dy per direction of z)."""
    th, m = S[0], S[1]
    c, s = math.cos(th), math.sin(th)
    nn = fx * c + fy * s
    t = fx * s - fy * c
    e = 1.0 + k * nn
    es, ec = e * s, e * c
    out = [m, e * t, ec, es, 0.5 * (m * m + k * nn * nn)]
    for j, (dfx, dfy) in enumerate(((1.0, 0.0), (0.0, 1.0), (0.0, 0.0))):
        dth = S[5 + 4 * j]
        de = k * (dfx * c + dfy * s - t * dth)
        out += (
            S[6 + 4 * j],
            de * t + e * (dfx * s - dfy * c + nn * dth),
            de * c - es * dth,
            de * s + ec * dth,
        )
    return out


def _rk4(z: tuple[float, float, float], k: float, n: int, points: bool = False):
    """RK4 flow of the rod equations and their variations in z (module doc).

    Returns (x, y, th, m, u) at s = 1, the 4 x 3 variations d(x, y, th, m)/dz, the largest |m|
    and, with ``points``, the (n + 1, 2) centre-line points.
    """
    fx, fy, m0 = z
    h, h2, h6 = 1.0 / n, 0.5 / n, 1.0 / (6.0 * n)
    S = [0.0, m0, 0.0, 0.0, 0.0] + [0.0] * 8 + [0.0, 1.0, 0.0, 0.0]
    pts = [(0.0, 0.0)] if points else None
    mmax = abs(m0)
    for _ in range(n):
        k1 = _rhs(S, fx, fy, k)
        k2 = _rhs([a + h2 * b for a, b in zip(S, k1)], fx, fy, k)
        k3 = _rhs([a + h2 * b for a, b in zip(S, k2)], fx, fy, k)
        k4 = _rhs([a + h * b for a, b in zip(S, k3)], fx, fy, k)
        S = [a + h6 * (b + 2.0 * (c + d) + e) for a, b, c, d, e in zip(S, k1, k2, k3, k4)]
        mmax = max(mmax, abs(S[1]))
        if points:
            pts.append((S[2], S[3]))
    th, m, x, y, u = S[:5]
    D = np.array(S[5:]).reshape(3, 4).T[[2, 3, 0, 1]]  # rows d(x, y, th, m), columns z
    return (x, y, th, m, u), D, mmax, (np.array(pts) if points else None)


def flow(z: tuple[float, float, float], k: float, n: int = STEPS, points: bool = False) -> tuple:
    """``_rk4`` with ``n`` and ``n / 2`` steps, Richardson-extrapolated (order 4 -> 5+): the
    pose, the energy and their variations are one linear combination of two discrete flows,
    so the variations stay the exact derivatives of the returned map."""
    fine = _rk4(z, k, n, points)
    coarse = _rk4(z, k, n // 2)
    end = tuple((16.0 * a - b) / 15.0 for a, b in zip(fine[0], coarse[0]))
    D = (16.0 * fine[1] - coarse[1]) / 15.0
    return end, D, fine[2], fine[3]


def shoot(
    pose: tuple[float, float, float], k: float, z0: np.ndarray
) -> tuple[np.ndarray, tuple, np.ndarray]:
    """Loads z = (fx, fy, m0) for a normalised pose (X / L, Y / L, Phi), damped Newton from
    ``z0``; returns (z, flow end state, variations).  Raises SolveError when it does not
    converge."""
    z = np.array(z0, float)
    target = np.asarray(pose, float)
    for _ in range(MAX_IT):
        end, D, _, _ = flow(tuple(z), k)
        r = np.array(end[:3]) - target
        if np.max(np.abs(r)) <= TOL:
            return z, end, D
        dz = np.linalg.lstsq(D[:3], -r, rcond=None)[0]  # least squares at a conjugate point
        # damping: a step at most 4 + |z| (units EI/L^2, EI/L): large loads move freely
        big = float(np.max(np.abs(dz))) / (4.0 + float(np.max(np.abs(z))))
        z = z + (dz / big if big > 1.0 else dz)
    raise SolveError(f"elastica member: shooting did not converge (residual {np.abs(r).max():.1e})")


class ElasticaTerm:
    """One elastica member between two end poses (module doc).

    Parameters
    ----------
    dofs : (6,) global indices [X_a, Y_a, r_a, X_b, Y_b, r_b].
    L, EI, EA : length, flexural and axial rigidity of the member.
    alpha : drawn direction of the member (rad).
    sfac : E t / 2 (bending stress per curvature; NaN when the thickness is unknown).
    """

    def __init__(
        self, dofs: list[int], L: float, EI: float, EA: float, alpha: float, sfac: float
    ) -> None:
        self.dofs = np.asarray(dofs, np.int64).reshape(1, 6)
        self.L, self.EI, self.alpha, self.sfac = float(L), float(EI), float(alpha), float(sfac)
        self.k = EI / (EA * L * L)
        self._z = np.zeros(3)  # last converged loads (warm start)
        self._pose: np.ndarray | None = None
        self._last: tuple | None = None  # (z, end, D) at _pose

    def _local(self, q: np.ndarray) -> tuple:
        Xa, Ya, ra, Xb, Yb, rb = q[self.dofs[0]]
        psi = self.alpha + ra
        c, s = math.cos(psi), math.sin(psi)
        dX, dY = Xb - Xa, Yb - Ya
        return c * dX + s * dY, -s * dX + c * dY, rb - ra, c, s

    def _solve(self, q: np.ndarray) -> tuple:
        xi, eta, phi, c, s = self._local(q)
        pose = np.array([xi / self.L, eta / self.L, phi])
        if self._last is not None and np.array_equal(pose, self._pose):  # same pose again
            return (*self._last, (xi, eta, c, s))
        z0 = self._z
        if self._last is not None:  # Newton step from the last solution (its Jacobian)
            try:
                z0 = z0 + np.linalg.solve(self._last[2][:3], pose - self._pose)
            except np.linalg.LinAlgError:
                pass
        try:
            z, end, D = shoot(pose, self.k, z0)
        except SolveError:  # continuation from the last solved pose (or the straight one)
            z, start = self._z, self._pose
            if start is None:
                start = np.array([1.0, 0.0, 0.0])
            for t in np.linspace(0.0, 1.0, 17)[1:]:
                z, end, D = shoot(start + t * (pose - start), self.k, z)
        self._z, self._pose, self._last = z, pose, (z, end, D)
        return z, end, D, (xi, eta, c, s)

    def energy(self, q: np.ndarray) -> float:
        """Strain energy (force * length)."""
        _, end, _, _ = self._solve(q)
        return end[4] * self.EI / self.L

    def local(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Gradient (1, 6) and Hessian (1, 6, 6) in the end unknowns."""
        z, end, D, (xi, eta, c, s) = self._solve(q)
        L, EI = self.L, self.EI
        A = np.eye(3)
        A[2] = D[3]
        Hn = A @ np.linalg.inv(D[:3])  # d(fx, fy, mb)/d(X/L, Y/L, Phi), nondimensional
        Hn = 0.5 * (Hn + Hn.T)  # symmetric up to round-off (hyperelastic)
        sc = np.array([EI / (L * L), EI / (L * L), EI / L])  # force, force, moment
        gl = sc * np.array([z[0], z[1], end[3]])
        Hl = Hn * (sc[:, None] / np.array([L, L, 1.0])[None, :])
        J = np.array(
            [
                [-c, -s, eta, c, s, 0.0],
                [s, -c, -xi, -s, c, 0.0],
                [0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
            ]
        )
        g = J.T @ gl
        H = J.T @ Hl @ J
        # curvature of xi and eta in r_a (the frame turns with end a)
        r = gl[0] * np.array([s, -c, 0.0, -s, c, 0.0]) + gl[1] * np.array([c, s, 0.0, -c, -s, 0.0])
        H[2, :] += r
        H[:, 2] += r
        H[2, 2] -= gl[0] * xi + gl[1] * eta
        return self.dofs, g[None, :], H[None, :, :]

    def max_stress(self, q: np.ndarray) -> float:
        """Largest bending stress E t |kappa| / 2 along the member (NaN when t is unknown)."""
        z, _, _, _ = self._solve(q)
        mmax = flow(tuple(z), self.k)[2]
        return self.sfac * mmax / self.L

    def shape(self, q: np.ndarray) -> np.ndarray:
        """(STEPS + 1, 2) centre-line points in global coordinates."""
        z, _, _, (xi, eta, c, s) = self._solve(q)
        pts = flow(tuple(z), self.k, points=True)[3] * self.L
        Xa, Ya = q[self.dofs[0, 0]], q[self.dofs[0, 1]]
        return np.column_stack(
            [Xa + c * pts[:, 0] - s * pts[:, 1], Ya + s * pts[:, 0] + c * pts[:, 1]]
        )


def add(sysm, m, L: float, alpha: float, xa: int, xb: int, ra: int, rb: int) -> None:  # noqa: ANN001
    """Put member ``m`` into ``sysm`` as an ``ElasticaTerm`` (builder hook)."""
    from reduced_models.mechanism.system import SceneError

    if m.A is None:
        raise SceneError(
            f"elastica member {m.id!r} needs its cross-section (width, thickness) for the axial "
            "compliance that makes the member law regular"
        )
    sfac = m.E * m.thickness / 2.0 if m.thickness is not None else np.nan
    term = ElasticaTerm([xa, xa + 1, ra, xb, xb + 1, rb], L, m.E * m.I, m.E * m.A, alpha, sfac)
    sysm.terms.append(term)
    sysm.shape_of[m.id] = term.shape


__all__ = ["ElasticaTerm", "add", "flow", "shoot"]
