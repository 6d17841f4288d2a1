"""Newton-Raphson core of the static solvers: options, converged states, norms and the
residual/tangent access shared by load control, displacement control and arc-length.

Convergence (``Options``): a state is converged when the scaled force residual
``||r_s|| <= rtol * fscale * max(|lam|, 1)`` (moments divided by the length scale; never
below the system's stated round-off floor ``residual_floor``) *and* the energy norm of the last
correction ``|du . r| <= etol * |du_0 . r_0|`` or a correction at round-off level
(``||du||_W < 1e-13``).  The residual is always that of the state returned, and it must be
within the tolerance: there is no slack.

Cost: the residual is checked *before* the tangent is formed (the tangent at the converged
state would be thrown away), and systems with the fast path (``FEMSystem.evaluate`` /
``factor``) assemble the tangent from the same element state straight into LAPACK band
storage.  Any other ``DiscreteSystem`` goes through ``residual_and_tangent`` and csr.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem_reference.banded import SingularTangent, factor, vdot
from fem_reference.system import DiscreteSystem


class SolveError(RuntimeError):
    """The solver could not reach the requested equilibrium (message says why).

    ``state`` is the last converged state reached before the failure (or None)."""

    def __init__(self, message: str, state: State | None = None, iterations: int = 0):
        super().__init__(message)
        self.state = state
        self.iterations = iterations


@dataclass(frozen=True)
class Options:
    """Solver settings (all dimensionless)."""

    rtol: float = 1e-9
    etol: float = 1e-16
    max_iter: int = 25
    max_cuts: int = 8
    grow: float = 2.0
    arc_iter_goal: int = 5
    arc_max_steps: int = 2000
    max_rot_step: float = 0.6  # rad per Newton correction before damping
    max_trans_step: float = 0.3  # x length scale per Newton correction before damping


@dataclass
class State:
    """A converged equilibrium: displacements, load factor and bookkeeping.

    ``lu``: a factorised tangent near the state (from the last Newton iteration), reused by
    predictors; ``prev``, ``prev2``: the previous two converged points ``(lam, u)`` of the same
    load-controlled branch, newest first (``static.predictor``); ``h_next``: the load step
    the stepping would try next;
    ``ev``: the solver's own evaluation at exactly ``(u, lam)`` (its element state and
    residual), so the stability test and the record need not evaluate the state again
    (``statics.inertia.evaluation``; valid only while ``ev.u is u``)."""

    u: np.ndarray
    lam: float
    iterations: int = 0
    cuts: int = 0
    residual: float = 0.0
    lu: object | None = field(default=None, repr=False)
    info: dict = field(default_factory=dict)
    prev: tuple[float, np.ndarray] | None = field(default=None, repr=False)
    prev2: tuple[float, np.ndarray] | None = field(default=None, repr=False)
    h_next: float | None = None
    ev: object | None = field(default=None, repr=False)


# -- residual / tangent access ---------------------------------------------------------------


class _Generic:
    """Fast-path interface over a plain ``DiscreteSystem`` (tangent formed with the residual)."""

    def __init__(self, system: DiscreteSystem):
        self.sys = system

    def evaluate(self, u: np.ndarray, lam: float) -> SimpleNamespace:
        r, K = self.sys.residual_and_tangent(u, lam)
        return SimpleNamespace(u=u, lam=lam, r=r, K=K)

    def factor(self, ev: SimpleNamespace) -> object:
        return factor(ev.K, getattr(self.sys, "bandwidth", None))


def ops(system: DiscreteSystem) -> object:
    """``evaluate(u, lam) -> ev`` (``ev.r`` the residual) and ``factor(ev) -> lu``."""
    if hasattr(system, "evaluate") and hasattr(system, "factor"):
        return system
    return _Generic(system)


def factor_at(o: object, ev: object, iterations: int = 0) -> object:
    """``o.factor(ev)`` with a singular tangent reported as ``SolveError``."""
    try:
        return o.factor(ev)
    except SingularTangent as err:
        raise SolveError(str(err), iterations=iterations) from None


def tangent_lu(system: DiscreteSystem, u: np.ndarray, lam: float) -> object:
    """Factorised tangent at ``(u, lam)``."""
    o = ops(system)
    return factor_at(o, o.evaluate(u, lam))


def bordered_solve(
    system: DiscreteSystem, ev: object, i: int, c: float, rhs_r: np.ndarray, rhs_g: float
) -> tuple[np.ndarray, float]:
    """``(du, dl)`` of ``K du - f dl = rhs_r``, ``c du_i = rhs_g``: the tangent bordered by
    the load and a displacement constraint, factorised together (sparse LU).  For a
    mechanism held only by its driver (rigid links without springs) ``K`` alone is singular
    and the bordered system is not."""
    K = system.tangent_csr(ev) if hasattr(system, "tangent_csr") else ev.K
    n = K.shape[0]
    f = np.asarray(system.external(ev.u), dtype=float).reshape(-1, 1)
    row = sp.csr_matrix(([c], ([0], [i])), shape=(1, n))
    A = sp.bmat([[K, sp.csr_matrix(-f)], [row, None]], format="csc")
    try:
        x = spla.splu(A).solve(np.append(rhs_r, rhs_g))
    except RuntimeError as err:  # exactly singular
        raise SolveError(f"singular bordered tangent ({err})") from None
    return x[:n], float(x[n])


def lu_of(system: DiscreteSystem, K: sp.csr_matrix) -> object:
    """Factorisation of a csr tangent of ``system`` (band when narrow); ``SolveError`` if
    singular."""
    try:
        return factor(K, getattr(system, "bandwidth", None))
    except SingularTangent as err:
        raise SolveError(str(err)) from None


# -- norms -----------------------------------------------------------------------------------


class Scaler:
    """Norms, tolerances and step damping of one system (constants built once per system,
    see ``Scaler.of``)."""

    def __init__(self, system: DiscreteSystem):
        self.sys = system
        self.L = float(system.length_scale())
        self.rs = np.where(system.is_rotation, 1.0 / self.L, 1.0)
        self.w = system.weights
        rf = getattr(system, "residual_floor", None)
        self.floor = float(rf()) if callable(rf) else 0.0
        self.rot = np.flatnonzero(system.is_rotation)
        self.trans = np.flatnonzero(~np.asarray(system.is_rotation))

    @classmethod
    def of(cls, system: DiscreteSystem) -> Scaler:
        """The cached scaler of ``system`` (created on first use)."""
        sc = getattr(system, "_flex_scaler", None)
        if sc is None or sc.sys is not system:
            sc = cls(system)
            try:
                system._flex_scaler = sc
            except AttributeError:  # pragma: no cover - a system without attribute storage
                pass
        return sc

    def rnorm(self, r: np.ndarray) -> float:
        x = r * self.rs
        return math.sqrt(vdot(x, x))

    def unorm(self, du: np.ndarray) -> float:
        return math.sqrt(vdot(du * du, self.w))

    def ftol(self, lam: float, opts: Options) -> float:
        return max(opts.rtol * self.sys.force_scale() * max(abs(lam), 1.0), self.floor)

    def max_rot(self, du: np.ndarray) -> float:
        """Largest rotation entry |du| (rad)."""
        return float(np.max(np.abs(du[self.rot]), initial=0.0))

    def _inv_limits(self, opts: Options) -> np.ndarray:
        """(ndof,) 1 / max_rot_step on rotations, 1 / (max_trans_step L) on translations."""
        key = (opts.max_rot_step, opts.max_trans_step)
        if getattr(self, "_lim_key", None) != key:
            self._lim = np.where(
                self.sys.is_rotation, 1.0 / opts.max_rot_step, 1.0 / (opts.max_trans_step * self.L)
            )
            mult = getattr(self.sys, "is_multiplier", None)
            if mult is not None:  # Lagrange multipliers (exact rigid links) are not damped
                self._lim[mult] = 0.0
            self._lim_key = key
        return self._lim

    def damp_check(self, du: np.ndarray, opts: Options) -> tuple[np.ndarray, float]:
        """``(damped du, largest |rotation| of du)``: du scaled so that no rotation exceeds
        ``max_rot_step`` and no translation ``max_trans_step * L``; the largest rotation is
        computed exactly only when it could exceed pi (else a bound below pi is returned)."""
        # the ufunc's own reduce: np.max's and ndarray.max's wrappers cost a microsecond each
        m = float(np.maximum.reduce(np.abs(du) * self._inv_limits(opts))) if du.size else 0.0
        mr = m * opts.max_rot_step  # >= every |rotation|
        if mr > math.pi:
            mr = self.max_rot(du)
        return (du / m if m > 1.0 else du), mr

    def damp(self, du: np.ndarray, opts: Options) -> np.ndarray:
        """``du`` scaled so that no rotation exceeds ``max_rot_step`` and no translation
        ``max_trans_step * L``."""
        return self.damp_check(du, opts)[0]


def converged(
    rn: float, tol: float, e: float, e0: float, dun: Callable[[], float], etol: float
) -> bool:
    """The convergence test of the module docstring; ``dun()`` gives ``||du||_W`` of the last
    correction (asked only when the other tests leave the answer open)."""
    if not rn <= tol:  # also rejects nan
        return False
    return e <= e0 * etol + 1e-300 or e0 == 0.0 or dun() < 1e-13


def newton(
    system: DiscreteSystem,
    u0: np.ndarray,
    lam: float,
    opts: Options,
    constraint: tuple[int, float, float] | None = None,
) -> State:
    """Newton-Raphson at fixed ``lam`` (or with a linear constraint, see below).

    ``constraint = (index, coef, value)`` switches to displacement control: ``lam`` becomes an
    unknown and ``coef * u[index] = value`` is enforced by bordering.
    Raises ``SolveError`` on divergence, a singular tangent or ``max_iter``.
    """
    o, sc = ops(system), Scaler.of(system)
    u = u0.copy()
    e0, e, du, rref, lu = 0.0, 0.0, None, 0.0, None

    def dun() -> float:
        return sc.unorm(du)

    if constraint is not None:
        i, c, v = constraint
        gtol = 1e-12 * (abs(v) + system.length_scale())
    tol = sc.ftol(lam, opts)  # lam moves only under a constraint
    for it in range(opts.max_iter + 1):
        ev = o.evaluate(u, lam)
        r = ev.r
        rn = sc.rnorm(r)
        rref = max(rref, rn) if it <= 1 else rref
        if it >= 3 and rn > 1e3 * rref:  # early exit: the step will be cut anyway
            raise SolveError(f"Newton diverging (|r| grew {rn / rref:.1e}x)", iterations=it)
        g = 0.0
        if constraint is not None:
            g = c * u[i] - v
            tol = sc.ftol(lam, opts)
        if not math.isfinite(rn):
            raise SolveError("non-finite residual", iterations=it)
        gok = constraint is None or abs(g) <= gtol
        # convergence is decided on the residual alone: no tangent at the converged state
        if it > 0 and gok and converged(rn, tol, e, e0, dun, opts.etol):
            return State(u, lam, it, 0, rn, lu, ev=ev)
        if it == 0 and rn <= tol * 1e-3 and gok:
            return State(u, lam, 0, 0, rn, None, ev=ev)
        if it == opts.max_iter:
            break
        try:
            lu = factor_at(o, ev, it)
        except SolveError:
            if constraint is None:
                raise
            lu = None  # singular alone, perhaps not with the constraint: factorised together
        if lu is None:
            du, dl = bordered_solve(system, ev, i, c, -r, -g)
            lam = lam + dl
        else:
            du = lu.solve(-r)
        if constraint is not None and lu is not None:
            dt = lu.solve(system.external(u))
            if abs(c * dt[i]) < 1e-300:
                raise SolveError("displacement control: controlled DOF does not respond to load")
            dl = -(g + c * du[i]) / (c * dt[i])
            du = du + dl * dt
            lam = lam + dl
        e = abs(vdot(du, r))
        if not math.isfinite(e):
            raise SolveError("non-finite Newton correction", iterations=it)
        du_d, mr = sc.damp_check(du, opts)
        if it >= 1 and mr > math.pi:
            raise SolveError("Newton diverging (rotation correction > pi)", iterations=it)
        if it == 0:
            e0 = e
        if constraint is None:
            du = du_d
        u = u + du
    raise SolveError(
        f"Newton did not converge in {opts.max_iter} iterations (|r|={rn:.3e})",
        iterations=opts.max_iter,
    )
