"""PRB chain numerics: kinematics, energy, analytic gradient/Hessian and the equilibrium path
(end-load recovery, shape and stress of the solved states: ``prb_post``).  The registered
models built on it are in ``reduced_models.beam.prb`` (their shared layer ``prb_model``).

A PRB chain is described by a PRB matrix ``[[k_theta, k_ex, gamma], ...]`` (see
``prb_tables``): segment i has length gamma_i L (plus an axial stretch u_i when k_ex_i is
finite), a torsion spring k_theta_i EI/L at its proximal end (absent when infinite) and an
axial spring k_ex_i EA/L (rigid when infinite).

Equilibrium is the stationary point of the total potential energy
``V = sum 1/2 K_theta theta^2 + sum 1/2 K_ex u^2 - (fx X + fy Y + m Phi)``
(dead tip loads; X, Y tip position, Phi tip-link angle), found by Newton's method with the
analytic gradient and Hessian (vectorised over segments; tridiagonal in absolute link angles)
along the load ramp with step cutting, through the shared ``reduced_models.paths.engine``.

Shape and stress (``prb_post``; seed 000_265bc60728766176.txt, "Computing Beam Shape and Stress"):
the end loads are recovered from the spring torques through the Moore-Penrose pseudo-inverse of the
Jacobian transpose; the shape drawn is the PRB's own chain of rigid links and the stress is
that of the bending moment these loads give at the root, the pivots and the tip.  The seed
also solves the elastica under the recovered loads (its shape, and the PRB-vs-Euler tip gap as
an accuracy indicator): the PRB models' option ``das2d`` (``prb_das2d``), off by default since
it costs an elastica solve per state.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from reduced_models.paths.engine import minimize_path
from reduced_models.paths.floats import MAX_N
from reduced_models.paths.path_result import PathResult

if TYPE_CHECKING:
    from reduced_models.paths.linalg import Banded

__all__ = [
    "RESIDUAL_TOL",
    "PRBChain",
    "check_matrix",
    "equilibrium_path",
]

#: largest accepted max |grad V| at a reported state, in units of EI/L
RESIDUAL_TOL = 1e-8


def check_matrix(matrix: object) -> np.ndarray:
    """Validate a PRB matrix: rows ``[k_theta, k_ex, gamma]``, gamma > 0 summing to 1.

    Strings ``"inf"`` are accepted for infinite entries.  Raises ValueError with the reason.
    """
    try:
        m = np.array(
            [[float(v) if not isinstance(v, str) else float(v.strip()) for v in r] for r in matrix],
            dtype=float,
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"PRB matrix must be rows of 3 numbers: {exc}") from None
    if m.ndim != 2 or m.shape[1] != 3 or m.shape[0] < 1:
        raise ValueError("PRB matrix must be rows [k_theta, k_ex, gamma]")
    if np.any(np.isnan(m)) or np.any(m <= 0) or not np.all(np.isfinite(m[:, 2])):
        raise ValueError("PRB matrix entries must be positive (inf allowed for k_theta, k_ex)")
    if abs(m[:, 2].sum() - 1.0) > 1e-6:
        raise ValueError(f"segment lengths gamma must sum to 1 (got {m[:, 2].sum():.6g})")
    if not np.any(np.isfinite(m[:, 0])):
        raise ValueError("PRB matrix has no torsion spring (all k_theta infinite)")
    return m


class PRBChain:
    """Kinematics and energy of one PRB chain in the beam frame (root at the origin).

    Unknowns x = [psi (nj,), u (ne,)]: psi_p is the absolute angle of the links that follow
    joint p (the seed's "each segment in the frame of the previous one" choice: a spring
    couples only neighbouring angles, theta_p = psi_p - psi_{p-1}), u_e the stretch of
    extensible segment e.  Without stretch the Hessian is tridiagonal; long chains hand it to
    the continuation engine as a ``Banded`` matrix (linear cost in N).

    Parameters
    ----------
    matrix : (S, 3) PRB matrix.
    L, EI, EA : beam length, flexural rigidity, axial rigidity (EA = inf: inextensible).
    """

    def __init__(self, matrix: np.ndarray, L: float, EI: float, EA: float = math.inf) -> None:
        m = np.asarray(matrix, dtype=float)
        self.matrix, self.L, self.EI, self.EA = m, float(L), float(EI), float(EA)
        S = len(m)
        self.gL = m[:, 2] * L
        self.jidx = np.flatnonzero(np.isfinite(m[:, 0]))
        self.eidx = np.flatnonzero(np.isfinite(m[:, 1]) & math.isfinite(EA))
        self.nj, self.ne = len(self.jidx), len(self.eidx)
        self.n = self.nj + self.ne
        self.Kt = m[self.jidx, 0] * EI / L
        self.Ke = m[self.eidx, 1] * EA / L
        self.Kspring = np.concatenate([self.Kt, self.Ke])
        # owner[i]: joint whose angle segment i has (-1: welded to the clamp)
        owner = np.searchsorted(self.jidx, np.arange(S), side="right") - 1
        self.owner, self.eown = owner, owner[self.eidx]
        self.root = owner < 0  # rigid root links (angle 0)
        own = ~self.root
        # all links of joint p turn with psi_p: their unstretched sum is Lp e^{i psi_p}
        self.Lp = np.bincount(owner[own], weights=self.gL[own], minlength=self.nj)
        self.scale = np.concatenate([np.ones(self.nj), np.full(self.ne, L)])
        # spring stiffness in psi: sum K_p (psi_p - psi_{p-1})^2 / 2 -> tridiagonal K_psi
        Kn = np.append(self.Kt[1:], 0.0)
        self._kd, self._ko = self.Kt + Kn, -self.Kt[1:]
        self.banded = self.ne == 0 and self.nj > 12

    @functools.cached_property
    def _Kpsi(self) -> np.ndarray:
        """K_psi dense (nj, nj) (built on first use: the float path never needs it)."""
        return np.diag(self._kd) + np.diag(self._ko, 1) + np.diag(self._ko, -1)

    @functools.cached_property
    def _ab(self) -> np.ndarray:
        """K_psi in band storage (3, nj)."""
        ab = np.zeros((3, self.nj))
        ab[0, 1:] = self._ko
        ab[1] = self._kd
        ab[2, :-1] = self._ko
        return ab

    # -- kinematics (x may be one state (n,) or a stack (m, n)) ------------------------------
    def _links(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Link vectors z_i = l_i e^{i phi_i} (..., S) and directions e^{i psi_p} (..., nj)."""
        Ep = np.exp(1j * x[..., : self.nj])
        E = np.where(self.root, 1.0 + 0j, Ep[..., np.maximum(self.owner, 0)])
        if self.ne:
            ln = np.broadcast_to(self.gL, E.shape).copy()
            ln[..., self.eidx] += x[..., self.nj :]
            return ln * E, Ep
        return self.gL * E, Ep

    def theta(self, x: np.ndarray) -> np.ndarray:
        """Relative joint rotations theta_p = psi_p - psi_{p-1} (rad), shape (..., nj)."""
        th = x[..., : self.nj].copy()
        th[..., 1:] -= x[..., : self.nj - 1]
        return th

    def springs(self, x: np.ndarray) -> np.ndarray:
        """Spring coordinates [theta (nj,), u (ne,)], shape (..., n)."""
        return np.concatenate([self.theta(x), x[..., self.nj :]], axis=-1)

    def _displacements(self, x: np.ndarray) -> np.ndarray:
        # z_i - l0_i as l0 (e^{i phi} - 1) + u e^{i phi}, with e^{i phi} - 1 = 2i sin(phi/2)
        # e^{i phi/2}: exact zero without load and full precision for tiny rotations
        psi = x[..., : self.nj]
        half = np.where(self.root, 0.0, 0.5 * psi[..., np.maximum(self.owner, 0)])
        d = self.gL * (2j * np.sin(half) * np.exp(1j * half))
        if self.ne:
            d[..., self.eidx] += x[..., self.nj :] * np.exp(2j * half[..., self.eidx])
        return d

    def tip(self, x: np.ndarray) -> tuple[float, float, float]:
        """Tip x, y (beam frame, length) and tip-link angle (rad)."""
        t = self._displacements(x).sum()
        return float(self.L + t.real), float(t.imag), float(x[self.nj - 1])

    def tips(self, X: np.ndarray) -> np.ndarray:
        """Tip (x, y, angle) of a stack of states (m, n), shape (m, 3)."""
        t = self._displacements(X).sum(axis=-1)
        return np.column_stack([self.L + t.real, t.imag, X[:, self.nj - 1]])

    def points(self, x: np.ndarray) -> np.ndarray:
        """Joint and end points of the chain, shape (..., S + 1, 2), beam frame (x: one
        state (n,) or a stack (..., n))."""
        d = self._displacements(x)
        p = np.zeros(d.shape[:-1] + (d.shape[-1] + 1,), dtype=complex)
        np.cumsum(d, axis=-1, out=p[..., 1:])
        s = np.concatenate([[0.0], np.cumsum(self.gL)])
        return np.stack([s + p.real, p.imag], axis=-1)

    def jacobian_T(self, x: np.ndarray) -> np.ndarray:
        """J^T: one row per spring coordinate (theta_p, then u_e), columns d(X, Y, Phi),
        shape (..., nj + ne, 3) (seed slide "Computing Beam Shape and Stress")."""
        z, Ep = self._links(x)
        T = np.cumsum(z[..., ::-1], axis=-1)[..., ::-1][..., self.jidx]  # tip minus joint p
        out = np.zeros(z.shape[:-1] + (self.n, 3))
        out[..., : self.nj, 0] = -T.imag
        out[..., : self.nj, 1] = T.real
        out[..., : self.nj, 2] = 1.0
        if self.ne:
            e = np.where(self.eown < 0, 1.0 + 0j, Ep[..., np.maximum(self.eown, 0)])
            out[..., self.nj :, 0] = e.real
            out[..., self.nj :, 1] = e.imag
        return out

    def spring_forces(self, x: np.ndarray) -> np.ndarray:
        """Spring torques and axial forces tau = K [theta, u], shape (..., nj + ne)."""
        return self.Kspring * self.springs(x)

    def strain_energy(self, x: np.ndarray) -> float | np.ndarray:
        """Elastic energy stored in the springs (force * length); (m,) for a stack."""
        q = self.springs(x)
        e = 0.5 * np.sum(self.Kspring * q * q, axis=-1)
        return float(e) if np.ndim(e) == 0 else e

    # -- energy, analytic gradient and Hessian --------------------------------------------------
    def grad_hess(
        self, x: np.ndarray, f: np.ndarray, dense: bool = False
    ) -> tuple[np.ndarray, np.ndarray | Banded]:
        """Gradient (n,) and Hessian of V = U - (fx X + fy Y + m Phi) for dead tip loads f.

        With F = fx - i fy and Z_p = sum of the link vectors of joint p:
        dW/dpsi_p = -Im(F Z_p) (+ m for the tip link), d2W/dpsi_p^2 = -Re(F Z_p) (no
        cross terms); dW/du_e = Re(F e^{i psi}), d2W/du_e dpsi = -Im(F e^{i psi}).
        The Hessian is a ``Banded`` tridiagonal for long inextensible chains unless ``dense``.
        """
        z, Ep = self._links(x)
        F = complex(f[0], -f[1])
        FZ = F * np.add.reduceat(z, self.jidx, axis=-1)  # the links of a joint are contiguous
        Kth = self.Kt * self.theta(x)
        gpsi = FZ.imag + Kth
        gpsi[:-1] -= Kth[1:]
        gpsi[-1] -= f[2]
        if self.banded and not dense:
            from reduced_models.paths.linalg import Banded  # long chains only: scipy's LAPACK

            ab = self._ab.copy()
            ab[1] += FZ.real
            return gpsi, Banded(ab, 1, 1)
        H = self._Kpsi.copy()
        H.flat[:: self.nj + 1] += FZ.real
        if not self.ne:
            return gpsi, H
        u = x[self.nj :]
        e = np.where(self.eown < 0, 1.0 + 0j, Ep[np.maximum(self.eown, 0)])
        Fe = F * e
        g = np.concatenate([gpsi, self.Ke * u - Fe.real])
        Hf = np.zeros((self.n, self.n))
        Hf[: self.nj, : self.nj] = H
        k = self.nj + np.arange(self.ne)
        Hf[k, k] = self.Ke
        own = self.eown >= 0
        Hf[self.eown[own], k[own]] = Hf[k[own], self.eown[own]] = Fe.imag[own]
        return g, Hf

    def load_gradient(self, x: np.ndarray, f: np.ndarray) -> np.ndarray:
        """-grad W (n,) for tip loads f: the derivative of the residual in the load scale.

        The residual is affine in the loads, so it is the difference of two evaluations.
        """
        zero = np.zeros(3)
        return self.grad_hess(x, f, dense=True)[0] - self.grad_hess(x, zero, dense=True)[0]

    def path_functions(self, f1: np.ndarray) -> tuple:
        """``(grad_hess(x, lam), load_gradient(x, lam))`` for loads ``lam * f1``.

        Inextensible chains take a short route: the links of joint p sum to Lp e^{i psi_p},
        so the residual is K_psi psi + lam (Im(F1 Lp e^{i psi}) - m1 e_tip) and the Hessian
        K_psi + lam diag(Re(F1 Lp e^{i psi})) -- a dozen numpy calls per Newton iteration.
        ``load_gradient`` returns the unit-load term computed at the last ``grad_hess`` point.
        """
        f1 = np.asarray(f1, dtype=float)
        if self.ne:

            def gh_general(x: np.ndarray, lam: float) -> tuple:
                return self.grad_hess(x, lam * f1)

            def lg_general(x: np.ndarray, lam: float) -> np.ndarray:
                return self.load_gradient(x, f1)

            return gh_general, lg_general

        F1Lp = complex(f1[0], -f1[1]) * self.Lp
        m1, nj, Kt, Kpsi, ab0 = f1[2], self.nj, self.Kt, self._Kpsi, self._ab
        last: list = [None, None]  # the last point and its unit-load terms F1 Lp e^{i psi}

        def unit(x: np.ndarray) -> np.ndarray:
            w = F1Lp * np.exp(1j * x)
            last[0], last[1] = x, w
            return w

        if self.banded:
            from reduced_models.paths.linalg import Banded  # long chains only: scipy's LAPACK

            def gh(x: np.ndarray, lam: float) -> tuple[np.ndarray, Banded]:
                w = unit(x)
                Kth = Kt * np.diff(x, prepend=0.0)
                g = Kth + lam * w.imag
                g[:-1] -= Kth[1:]
                g[-1] -= lam * m1
                ab = ab0.copy()
                ab[1] += lam * w.real
                return g, Banded(ab, 1, 1)

        else:
            diag = slice(None, None, nj + 1)

            def gh(x: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
                w = unit(x)
                H = Kpsi.copy()
                H.flat[diag] += lam * w.real
                g = Kpsi @ x + lam * w.imag
                g[-1] -= lam * m1
                return g, H

        def lg(x: np.ndarray, lam: float) -> np.ndarray:
            gW = (last[1] if last[0] is x else unit(x)).imag.copy()
            gW[-1] -= m1
            return gW

        return gh, lg

    def path_functions_small(self, f1: np.ndarray) -> tuple:
        """``path_functions`` of an inextensible chain on plain floats (``paths.floats``).

        ``grad_hess(x, lam) -> (g, (d, e))``: g = K_psi psi + lam (Im w - m1 e_tip), Hessian
        K_psi + lam diag(Re w) as its diagonal d and off-diagonal e, w_p = F1 Lp_p
        e^{i psi_p}; ``load_gradient`` = Im w - m1 e_tip.
        """
        nj = self.nj
        F1Lp = [complex(f1[0], -f1[1]) * lp for lp in self.Lp.tolist()]
        a, b = [w.real for w in F1Lp], [w.imag for w in F1Lp]
        kd, ko, m1 = self._kd.tolist(), self._ko.tolist(), float(f1[2])
        last = nj - 1
        cos, sin = math.cos, math.sin

        lo, hi = [0.0, *ko], [*ko, 0.0]  # row p: coefficients of psi_{p-1} and psi_{p+1}
        rows = list(zip(kd, lo, hi, a, b))

        seen: list = [None, None]  # the last point and its unit-load terms Im w

        def gh(x: list, lam: float) -> tuple[list, tuple[list, list]]:
            g, d, gw = [], [], []
            for xi, xl, xh, (k, cl, ch, ap, bp) in zip(x, [0.0, *x], [*x[1:], 0.0], rows):
                c, s = cos(xi), sin(xi)
                w = ap * s + bp * c
                gw.append(w)
                g.append(k * xi + cl * xl + ch * xh + lam * w)
                d.append(k + lam * (ap * c - bp * s))
            g[last] -= lam * m1
            seen[0], seen[1] = x, gw
            return g, (d, ko[:])

        def lg(x: list, lam: float) -> list:
            # called at the state just accepted: its terms were computed by gh
            gw = (
                seen[1][:]
                if seen[0] is x
                else [a[p] * sin(x[p]) + b[p] * cos(x[p]) for p in range(nj)]
            )
            gw[last] -= m1
            return gw

        return gh, lg

    def path_functions_scalar(self, f1: np.ndarray) -> tuple:
        """``path_functions_small`` of a one-joint inextensible chain on one bare float
        (``paths.floats.Scalar``): g = K psi + lam (a sin psi + b cos psi - m1), h = dg/dpsi,
        ``load_gradient`` = a sin psi + b cos psi - m1, with a + i b = F1 Lp."""
        w = complex(f1[0], -f1[1]) * float(self.Lp[0])
        a, b, k, m1 = w.real, w.imag, float(self._kd[0]), float(f1[2])
        cos, sin = math.cos, math.sin

        def gh(x: float, lam: float) -> tuple[float, float]:
            c, s = cos(x), sin(x)
            return k * x + lam * (a * s + b * c - m1), k + lam * (a * c - b * s)

        def lg(x: float, lam: float) -> float:
            return a * sin(x) + b * cos(x) - m1

        return gh, lg

    def potential(self, x: np.ndarray, f: np.ndarray) -> float:
        """Total potential V = U - (fx X + fy Y + m Phi) (force * length)."""
        X, Y, phi = self.tip(x)
        return self.strain_energy(x) - (f[0] * X + f[1] * Y + f[2] * phi)


def equilibrium_path(
    chain: PRBChain,
    f1: np.ndarray,
    factors: np.ndarray,
    guided: bool = False,
    xtol: float = 1e-10,
) -> PathResult:
    """Equilibria for loads ``lambda * f1`` at the reported ``factors`` (from the unloaded
    state) through the shared continuation engine (``reduced_models.paths.engine``).

    ``guided`` holds the tip-link angle at zero (fixed-guided beam; the tip moment is then a
    reaction and ``f1[2]`` is ignored).  Convergence: the last Newton update is below
    ``xtol`` (rad, or length / L) and the residual max |grad V| measured at the last
    evaluated iterate is below ``RESIDUAL_TOL`` EI/L.  The Hessian is symmetric, so the
    Newton systems are solved by Cholesky, which also decides stability (positive
    definiteness) of each reported state.
    """
    f1 = np.asarray(f1, dtype=float)
    if guided:
        f1 = np.array([f1[0], f1[1], 0.0])
    fixed = [chain.nj - 1] if guided else None
    gtol = RESIDUAL_TOL * chain.EI / chain.L
    if chain.ne == 0 and chain.nj == 1 and not guided:  # one pivot angle: a bare float
        gh1, lg1 = chain.path_functions_scalar(f1)
        return minimize_path(gh1, 0.0, factors, xtol=xtol, gtol=gtol, load_gradient=lg1)
    if chain.ne == 0 and chain.nj <= MAX_N:  # a few angles (unit scales): plain floats
        gh, lg = chain.path_functions_small(f1)
        return minimize_path(
            gh, [0.0] * chain.n, factors, xtol=xtol, gtol=gtol, fixed=fixed, load_gradient=lg
        )
    gh, lg = chain.path_functions(f1)
    return minimize_path(
        gh, np.zeros(chain.n), factors, scale=chain.scale, xtol=xtol, gtol=gtol, fixed=fixed,
        load_gradient=lg, symmetric=True,
    )  # fmt: skip
