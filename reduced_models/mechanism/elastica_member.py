"""Exact member law of a straight uniform flexible member: the (axially extensible) elastica.

In the frame of end a (origin at node a, x along the member's end-a tangent) the pose of end b
is (X, Y, Phi) = (xi, eta, r_b - r_a).  The member is the Kirchhoff rod with bending
stiffness EI and axial stiffness EA, loaded only at its ends.  With s in [0, 1] (units of L),
curvature m = M L / EI, end forces f = F L^2 / EI and axial compliance k = EI / (EA L^2):

    theta' = m,   m' = e (fx sin theta - fy cos theta),   x' = e cos theta,   y' = e sin theta,
    e = 1 + k n,  n = fx cos theta + fy sin theta (axial force),
    u' = m^2 / 2 + k n^2 / 2                                   (energy in EI / L),

from theta(0) = 0.  The boundary-value problem for a pose (X, Y, Phi) / (L, L, 1) is solved by
Chebyshev collocation: unknowns w = theta at N + 1 Chebyshev-Lobatto nodes and (fx, fy);
equations theta(0) = 0, theta(1) = Phi, theta'' = e t at the interior nodes, and the
Clenshaw-Curtis quadratures of x' and y' equal to X / L and Y / L; damped Newton with the
analytic Jacobian J (spectral accuracy: 1e-12 for curvatures of order 1 with N = 24; one
iteration is a (N + 3)^2 dense solve, ~0.1 ms).  Then (hyperelasticity, virtual work)

    gradient  dU/d(X, Y, Phi) = (Fx, Fy, M_b)       (M_b = EI theta'(1) / L, the end moment),
    Hessian   d(Fx, Fy, M_b)/d(X, Y, Phi) = from dw/dpose = J^-1 dR/dpose (implicit function),

mapped to the six end unknowns (X_a, Y_a, r_a, X_b, Y_b, r_b) with the Jacobian of
(xi, eta, Phi) and its curvature in r_a.  The energy is the quadrature of u'.

Why extensible: at the straight drawn state the inextensible problem is singular (the axial
force does not change the chord to first order), so the inextensible member has no stiffness
matrix there; the finite axial compliance of the real cross-section (the FE's) makes the law
regular.  Each new pose is reached by continuation along the straight line from the nearest of
the member's last ``HISTORY`` solved poses (the straight one always among them) in sub-steps of
at most ``STEP`` with the tangent predictor, so the member stays on the branch it is on and a
far-off Newton trial of the caller does not move it to another (eight times finer after a
failure).  A pose whose chord exceeds ``REFUSE_CHORD`` lengths (100 % strain) is refused: no
elastic member reaches it, and walking there (a synthesis trying EI x 1e-6) took minutes.
Below it a far Newton trial is still walked (refusing trials past the models' 20 % bound
made Lee's frame cut a step in one unit system and not in another); accepted states are held
to that bound by ``cases.limits.state_violation``.
"""

from __future__ import annotations

import math

import numpy as np

from cases.limits import STRAIN_MAX
from reduced_models.mechanism.newton import SolveError

N = 24  # Chebyshev-Lobatto intervals along the member (spectral: 1e-12 for |m| of order 1)
TOL = 1e-9  # last Newton step, relative (quadratic: the returned w is ~TOL^2 off)
MAX_IT = 40
STEP = 0.1  # largest pose change (X / L, Y / L, Phi in rad) per continuation sub-step
HISTORY = 32  # solved poses kept as warm starts
REFUSE_CHORD = 2.0  # chord / length of a pose refused outright (100 % strain)
MAX_WALK = 1000  # sub-steps beyond which a pose is refused (100 L or rad from any solved one)


def _cheb(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Differentiation matrix and nodes on s in [0, 1] (Trefethen, Spectral Methods, cheb)."""
    x = np.cos(np.pi * np.arange(n + 1) / n)
    c = np.r_[2.0, np.ones(n - 1), 2.0] * (-1.0) ** np.arange(n + 1)
    dx = x[:, None] - x[None, :]
    D = np.outer(c, 1.0 / c) / (dx + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    return -2.0 * D, 0.5 * (1.0 - x)  # s = (1 - x) / 2 runs from 0 to 1


def _clencurt(n: int) -> np.ndarray:
    """Clenshaw-Curtis weights on [0, 1] for the nodes of ``_cheb`` (n even)."""
    th = np.pi * np.arange(n + 1) / n
    w = np.zeros(n + 1)
    v = np.ones(n - 1)
    for k in range(1, n // 2):
        v -= 2.0 * np.cos(2 * k * th[1:-1]) / (4 * k * k - 1)
    v -= np.cos(n * th[1:-1]) / (n * n - 1)
    w[0] = w[n] = 1.0 / (n * n - 1)
    w[1:-1] = 2.0 * v / n
    return 0.5 * w


D1 = _cheb(N)[0]
D2 = D1 @ D1
WQ = _clencurt(N)
_IN = np.arange(1, N)
_A = D1.copy()  # indefinite integral from s = 0: D1 g = f on nodes 1..N, g(0) = 0
_A[0] = 0.0
_A[0, 0] = 1.0
QINT = np.linalg.inv(_A)
QINT[:, 0] = 0.0


def residual(w: np.ndarray, pose: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Collocation residual (N + 3,) and its Jacobian in w = (theta at the nodes, fx, fy)."""
    th, fx, fy = w[: N + 1], w[N + 1], w[N + 2]
    c, s = np.cos(th), np.sin(th)
    nn, t = fx * c + fy * s, fx * s - fy * c
    e = 1.0 + k * nn
    R = np.empty(N + 3)
    R[0] = th[0]
    R[N] = th[N] - pose[2]
    R[_IN] = (D2[_IN] @ th) - (e * t)[_IN]
    R[N + 1] = WQ @ (e * c) - pose[0]
    R[N + 2] = WQ @ (e * s) - pose[1]
    J = np.zeros((N + 3, N + 3))
    J[0, 0] = J[N, N] = 1.0
    J[1:N, : N + 1] = D2[1:N]
    J[_IN, _IN] -= (e * nn - k * t * t)[_IN]
    J[_IN, N + 1] = -(k * c * t + e * s)[_IN]
    J[_IN, N + 2] = -(k * s * t - e * c)[_IN]
    J[N + 1, : N + 1] = WQ * (-k * t * c - e * s)
    J[N + 2, : N + 1] = WQ * (-k * t * s + e * c)
    J[N + 1, N + 1] = WQ @ (k * c * c)
    J[N + 1, N + 2] = J[N + 2, N + 1] = WQ @ (k * s * c)
    J[N + 2, N + 2] = WQ @ (k * s * s)
    return R, J


def shoot(pose: np.ndarray, k: float, w0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodal angles and end forces w for a normalised pose (X / L, Y / L, Phi), damped Newton
    from ``w0``; returns (w, Jacobian at w).  Raises SolveError when it does not converge."""
    w = np.array(w0, float)
    for _ in range(MAX_IT):
        R, J = residual(w, pose, k)
        try:
            dw = np.linalg.solve(J, R)
        except np.linalg.LinAlgError as err:
            raise SolveError(f"elastica member: singular collocation matrix ({err})") from err
        # damping: at most 0.5 rad per nodal angle, 4 + |f| (units EI / L^2) per force
        big = max(
            float(np.abs(dw[: N + 1]).max()) / 0.5,
            float(np.abs(dw[N + 1 :]).max()) / (4.0 + float(np.abs(w[N + 1 :]).max())),
        )
        w = w - (dw / big if big > 1.0 else dw)
        if big <= 1.0 and float(np.abs(dw).max()) <= TOL * (1.0 + float(np.abs(w).max())):
            return w, residual(w, pose, k)[1]
    raise SolveError(f"elastica member: no convergence (residual {np.abs(R).max():.1e})")


def _walk(start: tuple, pose: np.ndarray, n: int, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Continuation from a solved ``start = (pose, w, J)`` to ``pose`` in ``n`` sub-steps."""
    p, w, J = start
    p0 = p
    for t in np.linspace(0.0, 1.0, n + 1)[1:]:
        nxt = p0 + t * (pose - p0)
        w0 = w if J is None else w + ElasticaTerm._dw(J) @ (nxt - p)
        w, J = shoot(nxt, k, w0)
        p = nxt
    return w, J


class ElasticaTerm:
    """One elastica member between two end poses (module doc).

    Parameters
    ----------
    dofs : (6,) global indices [X_a, Y_a, r_a, X_b, Y_b, r_b].
    L, EI, EA : length, flexural and axial rigidity of the member.
    alpha : drawn direction of the member (rad).
    sfac : E t / 2 (bending stress per curvature; NaN when the thickness is unknown).
    mid : the member's id (named when a pose is refused).
    """

    def __init__(
        self, dofs: list[int], L: float, EI: float, EA: float, alpha: float, sfac: float, mid: str
    ) -> None:
        self.mid = mid
        self.dofs = np.asarray(dofs, np.int64).reshape(1, 6)
        self.L, self.EI, self.alpha, self.sfac = float(L), float(EI), float(alpha), float(sfac)
        self.k = EI / (EA * L * L)
        straight = (np.array([1.0, 0.0, 0.0]), np.zeros(N + 3), None)
        self._hist: list[tuple] = [straight]  # (pose, w, J) of the last solves (warm starts)
        self._last: tuple | None = None

    def _local(self, q: np.ndarray) -> tuple:
        Xa, Ya, ra, Xb, Yb, rb = q[self.dofs[0]]
        psi = self.alpha + ra
        c, s = math.cos(psi), math.sin(psi)
        dX, dY = Xb - Xa, Yb - Ya
        return c * dX + s * dY, -s * dX + c * dY, rb - ra, c, s

    def _solve(self, q: np.ndarray) -> tuple:
        xi, eta, phi, c, s = self._local(q)
        pose = np.array([xi / self.L, eta / self.L, phi])
        geo = (xi, eta, c, s)
        chord = math.hypot(pose[0], pose[1])
        if not chord <= REFUSE_CHORD:  # (also NaN)
            raise SolveError(  # the words of cases.limits.state_violation
                f"member {self.mid!r} strained by at least {chord - 1.0:.2g} (bound "
                f"{STRAIN_MAX:g}): beyond the moderate-strain elastic models"
            )
        if self._last is not None and np.array_equal(pose, self._last[0]):  # same pose again
            return self._last[1], self._last[2], geo
        # continuation along the straight line from the nearest solved pose (a Newton trial of
        # the caller may have been far off: the accepted states stay in the history), tangent
        # predictor, sub-steps of at most STEP: the member stays on the branch it is on
        near = min(self._hist, key=lambda h: float(np.abs(h[0] - pose).max()))
        span = float(np.abs(pose - near[0]).max())
        if not span <= MAX_WALK * STEP:  # a Newton trial far off (or NaN): refuse, not walk
            raise SolveError(f"elastica member: pose {span:.3g} from any solved one")
        n = max(1, math.ceil(span / STEP))
        try:
            w, J = _walk(near, pose, n, self.k)
        except SolveError:  # eight times finer
            w, J = _walk(near, pose, 8 * n, self.k)
        self._last = (pose, w, J)
        self._hist.append(self._last)
        if len(self._hist) > HISTORY:
            del self._hist[1]  # the straight state (entry 0) stays
        return w, J, geo

    @staticmethod
    def _dw(J: np.ndarray) -> np.ndarray:
        """d w / d(X / L, Y / L, Phi): the pose enters rows N + 1, N + 2 and N with -1."""
        rhs = np.zeros((N + 3, 3))
        rhs[N + 1, 0] = rhs[N + 2, 1] = rhs[N, 2] = 1.0
        return np.linalg.solve(J, rhs)

    def energy(self, q: np.ndarray) -> float:
        """Strain energy (force * length): bending plus axial, Clenshaw-Curtis quadrature."""
        w, _, _ = self._solve(q)
        th = w[: N + 1]
        nn = w[N + 1] * np.cos(th) + w[N + 2] * np.sin(th)
        return float(WQ @ (0.5 * (D1 @ th) ** 2 + 0.5 * self.k * nn * nn)) * self.EI / self.L

    def local(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Gradient (1, 6) and Hessian (1, 6, 6) in the end unknowns."""
        w, J, (xi, eta, c, s) = self._solve(q)
        L, EI = self.L, self.EI
        dw = self._dw(J)
        mb = D1[N] @ w[: N + 1]
        # d(fx, fy, mb)/d(X/L, Y/L, Phi), nondimensional; symmetric up to the discretisation
        Hn = np.vstack([dw[N + 1], dw[N + 2], D1[N] @ dw[: N + 1]])
        Hn = 0.5 * (Hn + Hn.T)
        sc = np.array([EI / (L * L), EI / (L * L), EI / L])  # force, force, moment
        gl = sc * np.array([w[N + 1], w[N + 2], mb])
        Hl = Hn * (sc[:, None] / np.array([L, L, 1.0])[None, :])
        Jg = np.array(
            [
                [-c, -s, eta, c, s, 0.0],
                [s, -c, -xi, -s, c, 0.0],
                [0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
            ]
        )
        g = Jg.T @ gl
        H = Jg.T @ Hl @ Jg
        # curvature of xi and eta in r_a (the frame turns with end a)
        r = gl[0] * np.array([s, -c, 0.0, -s, c, 0.0]) + gl[1] * np.array([c, s, 0.0, -c, -s, 0.0])
        H[2, :] += r
        H[:, 2] += r
        H[2, 2] -= gl[0] * xi + gl[1] * eta
        return self.dofs, g[None, :], H[None, :, :]

    def max_stress(self, q: np.ndarray) -> float:
        """Largest bending stress E t |kappa| / 2 at the nodes (NaN when t or the shape is
        unknown)."""
        try:
            w, _, _ = self._solve(q)
        except SolveError:
            return np.nan
        return self.sfac * float(np.abs(D1 @ w[: N + 1]).max()) / self.L

    def shape(self, q: np.ndarray) -> np.ndarray:
        """(N + 1, 2) centre-line points (the collocation nodes) in global coordinates; the
        chord when the shape cannot be re-solved (drawing only, never a result)."""
        try:
            w, _, (_, _, c, s) = self._solve(q)
        except SolveError:
            i = self.dofs[0]
            return np.array([[q[i[0]], q[i[1]]], [q[i[3]], q[i[4]]]])
        th = w[: N + 1]
        e = 1.0 + self.k * (w[N + 1] * np.cos(th) + w[N + 2] * np.sin(th))
        x, y = QINT @ (e * np.cos(th)) * self.L, QINT @ (e * np.sin(th)) * self.L
        Xa, Ya = q[self.dofs[0, 0]], q[self.dofs[0, 1]]
        return np.column_stack([Xa + c * x - s * y, Ya + s * x + c * y])


def add(sysm, m, L: float, alpha: float, xa: int, xb: int, ra: int, rb: int) -> None:  # noqa: ANN001
    """Put member ``m`` (with its cross-section: ``m.A`` set, which the builder checks) into
    ``sysm`` as an ``ElasticaTerm`` (builder hook)."""
    sfac = m.E * m.thickness / 2.0 if m.thickness is not None else np.nan
    dofs = [xa, xa + 1, ra, xb, xb + 1, rb]
    term = ElasticaTerm(dofs, L, m.E * m.I, m.E * m.A, alpha, sfac, m.id)
    sysm.terms.append(term)
    sysm.shape_of[m.id] = term.shape


__all__ = ["ElasticaTerm", "add", "residual", "shoot"]
