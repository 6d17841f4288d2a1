"""Independent geometrically exact (Simo-Reissner) plane beam in scikit-fem forms.

This is the cross-check of the corotational FE reference on single members.  It shares no
numerics with ``corotational.py``: the kinematics are the exact plane-beam strains, the
discretisation is a scikit-fem composite Lagrange element, and the weak forms (residual and
consistent tangent) are written as ``skfem.LinearForm`` / ``skfem.BilinearForm``.

Model
-----
A straight member of length ``L`` along the local x axis, arc length ``s`` in [0, L] is the
mesh coordinate (``MeshLine1`` takes 1-D coordinates only).  Unknown fields ``u(s)``, ``v(s)``
(displacements, length) and ``theta(s)`` (cross-section rotation, rad).  With
``a = 1 + u'``, ``b = v'``, ``c = cos(theta)``, ``s = sin(theta)`` the material strains are

* axial        ``eps   = a c + b s - 1``,
* shear        ``gamma = -a s + b c``,
* curvature    ``kappa = theta'``,

and the strain energy is ``int 1/2 (EA eps^2 + GA gamma^2 + EI kappa^2) ds`` (Reissner 1972,
doi:10.1007/BF01602645; Simo & Vu-Quoc 1986, doi:10.1016/0045-7825(86)90079-4).

Discretisation
--------------
``degree=2`` (default): ``ElementLineP2()`` for each field with the 2-point Gauss rule
(uniformly reduced integration); ``degree=1``: ``ElementLineP1()`` with the 1-point rule.
Reduced integration is what keeps the element free of shear and membrane locking when GA and
EA are large; the rule is passed explicitly to ``Basis(..., quadrature=...)``.  Under a pure
end moment ``theta`` is linear and is represented exactly; the tip position then carries the
quadrature error of integrating ``cos(theta)``, ``sin(theta)`` with the reduced rule, i.e.
O(h^2) for P1 and O(h^4) for P2 (both measured in ``tests/test_verify_reissner.py``).

Shear-rigid (Euler-Bernoulli) limit
-----------------------------------
Pass ``GA=math.inf`` (or ``EA=math.inf``): the constraint is then enforced by a penalty
stiffness ``RIGID_PENALTY * EI / L^2`` = ``1e8 EI / L^2``, which changes tip values by a
relative ``~1e-8 PL^2/EI`` (measured: the P2 tip error of a PL^2/EI = 10 cantilever levels off
near 1e-7) -- below the discretisation error of the meshes the cross-checks use -- while the
tangent stays well enough conditioned for Newton to reach round-off (reduced integration keeps
the penalty from locking).  Any finite GA is used as given.

Loads
-----
Clamp at ``s = 0``; at ``s = L`` a tip force ``(fx, fy)`` (local frame, at load factor 1) and
a tip moment ``m``.  ``follower=True`` makes the force turn with the tip cross-section:
``F = R(theta(L)) (fx, fy)``; its load stiffness ``-dF/dtheta(L)`` enters the tangent (the
tangent is then unsymmetric).  The load factor is ramped in ``steps`` equal increments with a
secant predictor, each solved by a mixed (Hellinger-Reissner) Newton iteration that carries the
stress resultants at the quadrature points (``ReissnerBeam.newton``; same converged answer,
robust when GA >> EA); an increment that fails is halved (by default at most 12 times).

Cost: one residual + tangent assembly through the scikit-fem forms is a few ms at 32 P2
elements; a 10-step PL^2/EI = 10 cantilever takes ~40 Newton iterations (~0.3 s).  This is a
verification tool, not the hot path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import (
    Basis,
    BilinearForm,
    ElementLineP1,
    ElementLineP2,
    Functional,
    LinearForm,
    MeshLine1,
)
from skfem.quadrature import get_quadrature

__all__ = ["ReissnerBeam", "ReissnerResult", "solve_cantilever"]

#: penalty used for an infinite EA or GA, in units of EI / L^2 (see module docstring)
RIGID_PENALTY = 1.0e8


@dataclass(frozen=True)
class ReissnerResult:
    """Tip state of a Reissner cantilever at the last converged load factor.

    Attributes
    ----------
    tip_x, tip_y : deformed tip position in the member frame (clamp at the origin, member
        along +x), length units.
    tip_rot : tip cross-section rotation (rad, counter-clockwise positive).
    converged : True only if the full load (factor 1) was reached with every increment
        converged.
    iterations : Newton iterations spent in total (including those of cut increments).
    message : one line (why it failed, or a summary).
    factor : last converged load factor (1.0 when converged).
    energy : strain energy at the last converged state (force * length).
    shape : (n_nodes, 2) deformed vertex positions from clamp to tip.
    history : ((factor, tip_x, tip_y, tip_rot), ...) at each converged nominal step,
        starting with factor 0.
    """

    tip_x: float
    tip_y: float
    tip_rot: float
    converged: bool
    iterations: int
    message: str
    factor: float = math.nan
    energy: float = math.nan
    shape: np.ndarray | None = field(default=None, compare=False, repr=False)
    history: tuple[tuple[float, float, float, float], ...] = field(default=(), compare=False)


def _strains(w: dict) -> tuple:
    """Exact plane strains at the quadrature points from the current fields in ``w``."""
    a = 1.0 + w["pu"].grad[0]
    b = w["pv"].grad[0]
    th = np.asarray(w["pt"])
    c, s = np.cos(th), np.sin(th)
    eps = a * c + b * s - 1.0
    gam = -a * s + b * c
    kap = w["pt"].grad[0]
    return c, s, eps, gam, kap


class ReissnerBeam:
    """Discretised clamped Reissner beam: residual, tangent and recovery.

    Parameters
    ----------
    L : length (length units).
    EI, EA, GA : bending (force length^2), axial and shear (force) rigidities; ``math.inf``
        for EA or GA means a penalty of ``RIGID_PENALTY * EI / L^2``.
    n_elements : number of elements on [0, L] (uniform).
    degree : 1 (P1, 1-point Gauss) or 2 (P2, 2-point Gauss).
    intorder : override the quadrature order (e.g. full integration to show locking).
    """

    def __init__(
        self,
        L: float,
        EI: float,
        EA: float,
        GA: float,
        n_elements: int,
        degree: int = 2,
        intorder: int | None = None,
    ) -> None:
        if not (L > 0 and EI > 0 and EA > 0 and GA > 0):
            raise ValueError("L, EI, EA and GA must be positive")
        if n_elements < 1 or degree not in (1, 2):
            raise ValueError("need n_elements >= 1 and degree in (1, 2)")
        penalty = RIGID_PENALTY * EI / L**2
        self.L, self.EI = float(L), float(EI)
        self.EA = penalty if math.isinf(EA) else float(EA)
        self.GA = penalty if math.isinf(GA) else float(GA)
        mesh = MeshLine1.init_tensor(np.linspace(0.0, L, n_elements + 1))
        e1 = ElementLineP1() if degree == 1 else ElementLineP2()
        if intorder is None:
            # reduced Gauss rule with n = degree points on the reference line [0, 1]; built by
            # hand because skfem's get_quadrature never returns fewer than 2 points
            gx, gw = np.polynomial.legendre.leggauss(degree)
            quad = (0.5 * gx[None, :] + 0.5, 0.5 * gw)
        else:
            quad = get_quadrature(mesh.elem.refdom, intorder)
        self.basis = Basis(mesh, e1 * e1 * e1, quadrature=quad)
        clamp = self.basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
        tip = self.basis.get_dofs(lambda x: np.isclose(x[0], L)).nodal
        self.tip = np.array([tip["u^1"][0], tip["u^2"][0], tip["u^3"][0]])
        self.free = np.setdiff1d(np.arange(self.basis.N), clamp)
        # vertex DOFs (3, n_nodes): rows u, v, theta, columns ordered by s
        self.vertex = self.basis.nodal_dofs[:, np.argsort(mesh.p[0])]
        self.s_nodes = np.sort(mesh.p[0])
        self._forms()

    def _forms(self) -> None:
        EA, GA, EI = self.EA, self.GA, self.EI

        @LinearForm
        def f_int(v1, v2, v3, w):  # noqa: ANN001, ANN202 - skfem form signature
            c, s, eps, gam, kap = _strains(w)
            N, Q, M = EA * eps, GA * gam, EI * kap
            da, db = v1.grad[0], v2.grad[0]
            return (
                N * (c * da + s * db + gam * v3)
                + Q * (-s * da + c * db - (1.0 + eps) * v3)
                + M * v3.grad[0]
            )

        @BilinearForm
        def k_tan(u1, u2, u3, v1, v2, v3, w):  # noqa: ANN001, ANN202
            c, s, eps, gam, _ = _strains(w)
            N, Q = w["N"], w["Q"]  # tracked stress resultants (mixed Newton, see newton())
            Da, Db, Dt = u1.grad[0], u2.grad[0], np.asarray(u3)
            da, db, dt = v1.grad[0], v2.grad[0], np.asarray(v3)
            de_D = c * Da + s * Db + gam * Dt
            de_d = c * da + s * db + gam * dt
            dg_D = -s * Da + c * Db - (1.0 + eps) * Dt
            dg_d = -s * da + c * db - (1.0 + eps) * dt
            # second variations of eps and gamma (geometric stiffness)
            cross_a = da * Dt + dt * Da
            cross_b = db * Dt + dt * Db
            h_eps = -s * cross_a + c * cross_b - (1.0 + eps) * dt * Dt
            h_gam = -c * cross_a - s * cross_b - gam * dt * Dt
            return (
                EA * de_d * de_D
                + GA * dg_d * dg_D
                + N * h_eps
                + Q * h_gam
                + EI * v3.grad[0] * u3.grad[0]
            )

        @Functional
        def energy(w):  # noqa: ANN001, ANN202
            _, _, eps, gam, kap = _strains(w)
            return 0.5 * (EA * eps**2 + GA * gam**2 + EI * kap**2)

        self._f_int, self._k_tan, self._energy = f_int, k_tan, energy

    def _fields(self, x: np.ndarray) -> dict:
        pu, pv, pt = self.basis.interpolate(x)
        return {"pu": pu, "pv": pv, "pt": pt}

    def external(self, x: np.ndarray, f0: np.ndarray, m: float, follower: bool) -> np.ndarray:
        """Tip load vector at load factor 1, shape (N,) (follower: rotated by theta(L))."""
        f = np.asarray(f0, dtype=float)
        if follower:
            c, s = math.cos(x[self.tip[2]]), math.sin(x[self.tip[2]])
            f = np.array([c * f[0] - s * f[1], s * f[0] + c * f[1]])
        out = np.zeros(self.basis.N)
        out[self.tip] = [f[0], f[1], m]
        return out

    def quad_strains(self, x: np.ndarray, dx: np.ndarray | None = None) -> tuple:
        """Axial and shear strain at the quadrature points, each (n_elements, n_qp).

        With ``dx``: their linearisation at ``x`` evaluated at ``x + dx``
        (``eps(x) + d eps[dx]``, ``gamma(x) + d gamma[dx]``).
        """
        w = self._fields(x)
        c, s, eps, gam, _ = _strains(w)
        if dx is None:
            return eps, gam
        du, dv, dt = self.basis.interpolate(dx)
        da, db, dt = du.grad[0], dv.grad[0], np.asarray(dt)
        return (
            eps + c * da + s * db + gam * dt,
            gam - s * da + c * db - (1.0 + eps) * dt,
        )

    def residual_and_tangent(
        self,
        x: np.ndarray,
        lam: float,
        f0: np.ndarray,
        m: float,
        follower: bool,
        stress: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, sp.csr_matrix]:
        """r = f_int(x) - lam f_ext(x) and K = dr/dx on all N DOFs (clamp not removed).

        ``stress = (N, Q)`` at the quadrature points, (n_elements, n_qp) each, replaces
        ``EA eps(x)``, ``GA gamma(x)`` in the geometric stiffness (mixed Newton); the default
        gives the exact Jacobian of ``r``.
        """
        w = self._fields(x)
        if stress is None:
            eps, gam = self.quad_strains(x)
            stress = (self.EA * eps, self.GA * gam)
        fe = self.external(x, f0, m, follower)
        r = self._f_int.assemble(self.basis, **w) - lam * fe
        K = self._k_tan.assemble(self.basis, N=stress[0], Q=stress[1], **w).tocsr()
        if follower:
            # d(lam F)/d theta_L = lam * (-F_y, F_x); the residual carries minus that
            iu, iv, it = self.tip
            load_k = sp.csr_matrix(
                (lam * np.array([fe[iv], -fe[iu]]), ([iu, iv], [it, it])), shape=K.shape
            )
            K = K + load_k
        return r, K

    def strain_energy(self, x: np.ndarray) -> float:
        """Elastic strain energy of state ``x`` (force * length)."""
        return float(self._energy.assemble(self.basis, **self._fields(x)))

    def shape(self, x: np.ndarray) -> np.ndarray:
        """Deformed vertex positions, shape (n_nodes, 2), clamp to tip."""
        u, v = x[self.vertex[0]], x[self.vertex[1]]
        return np.column_stack([self.s_nodes + u, v])

    def newton(
        self,
        x: np.ndarray,
        lam: float,
        f0: np.ndarray,
        m: float,
        follower: bool,
        fscale: float,
        stress: tuple[np.ndarray, np.ndarray] | None = None,
        rtol: float = 1e-10,
        max_iter: int = 30,
    ) -> tuple[np.ndarray, bool, int]:
        """Newton at fixed ``lam`` from ``x``; returns (x, converged, iterations).

        Mixed (Hellinger-Reissner) Newton: the stress resultants N, Q at the quadrature
        points are carried as unknowns next to ``x`` and updated from the *linearised*
        constitutive law, ``N <- EA (eps(x) + d eps[dx])``.  Eliminating them gives the
        displacement tangent with N, Q in the geometric term.  Because one-point (P1) and
        two-point (P2) reduced integration make the discrete mixed and displacement problems
        identical, the converged answer is the same; but the iteration no longer feeds
        ``GA * (second-order shear error)`` into the tangent, which made plain Newton oscillate
        when GA >> EA (e.g. GA = inf with EA L^2/EI = 1e4 took 15x more iterations).
        ``stress`` = (N, Q) to start from (default: those of ``x``).

        Converged when the displacement residual (N = EA eps(x)) on the free DOFs is below
        ``rtol * fscale`` (max norm) or the energy norm ``|dx . r|`` of the Newton correction
        is below ``(rtol * fscale * L)^2`` -- the latter accepts states whose residual sits at
        the round-off floor of a stiff (large EA/GA) member, while still requiring an
        equilibrium to machine accuracy.
        """
        fr = self.free
        x = x.copy()
        for it in range(max_iter + 1):
            r, K = self.residual_and_tangent(x, lam, f0, m, follower, stress)
            rf = r[fr]
            if not np.all(np.isfinite(rf)):
                return x, False, it
            if np.max(np.abs(rf)) <= rtol * fscale:
                return x, True, it
            if it == max_iter:
                break
            dx = np.zeros_like(x)
            dx[fr] = spla.spsolve(K[fr][:, fr].tocsc(), -rf)
            if not np.all(np.isfinite(dx)):
                return x, False, it
            if abs(dx[fr] @ rf) <= (rtol * fscale * self.L) ** 2:  # x (evaluated) is at
                return x, True, it + 1  # its round-off floor: accept it, not x + dx
            eps_lin, gam_lin = self.quad_strains(x, dx)
            stress = (self.EA * eps_lin, self.GA * gam_lin)
            x += dx
        return x, False, max_iter


def solve_cantilever(
    L: float,
    EI: float,
    EA: float,
    GA: float,
    fx: float,
    fy: float,
    m: float,
    n_elements: int,
    steps: int,
    follower: bool = False,
    *,
    degree: int = 2,
    intorder: int | None = None,
    rtol: float = 1e-10,
    max_cuts: int = 12,
) -> ReissnerResult:
    """Clamped-free Reissner beam under a tip force and moment, by load-stepped Newton.

    Parameters
    ----------
    L : length (length units); the member lies on the local +x axis, clamped at x = 0.
    EI : bending rigidity (force length^2).
    EA, GA : axial and shear rigidities (force); ``math.inf`` = rigid (penalty, see module
        docstring).  Large finite GA (e.g. ``1e8 EI / L^2``) approaches Euler-Bernoulli.
    fx, fy : tip force at load factor 1 (force), global (dead) or in the reference frame of
        the tip section (follower).
    m : tip moment at load factor 1 (force length), counter-clockwise positive.
    n_elements : uniform elements along the member.
    steps : equal load increments from factor 0 to 1 (cut internally when Newton fails).
    follower : the tip force turns with the tip section.
    degree, intorder : element degree (1 or 2) and optional quadrature order override.
    rtol : Newton tolerance relative to the force scale ``max(|F|, |m|/L, EI/L^2)``.
    max_cuts : how many times an increment may be halved before giving up.

    Returns
    -------
    ReissnerResult
        ``converged`` is False (with the reason in ``message``) if any increment could not be
        solved; the tip values then belong to the last converged ``factor``.
    """
    if steps < 1:
        raise ValueError("steps must be >= 1")
    beam = ReissnerBeam(L, EI, EA, GA, n_elements, degree=degree, intorder=intorder)
    f0 = np.array([fx, fy], dtype=float)
    fscale = max(math.hypot(fx, fy), abs(m) / L, EI / L**2)
    x = np.zeros(beam.basis.N)
    lam, total_iters = 0.0, 0
    history = [(0.0, float(L), 0.0, 0.0)]
    x_prev, lam_prev = None, None  # previous converged state for the secant predictor
    message = ""
    for k in range(1, steps + 1):
        target = k / steps
        dlam, cuts = target - lam, 0
        while lam < target - 1e-15:
            dlam = min(dlam, target - lam)
            guess = x
            if x_prev is not None and lam > lam_prev:
                guess = x + (dlam / (lam - lam_prev)) * (x - x_prev)
            # stress resultants start from the converged state, not from the predictor
            # (whose penalty stresses carry its second-order constraint error)
            eps, gam = beam.quad_strains(x)
            stress = (beam.EA * eps, beam.GA * gam)
            xn, ok, its = beam.newton(
                guess, lam + dlam, f0, m, follower, fscale, stress=stress, rtol=rtol
            )
            total_iters += its
            if ok:
                x_prev, lam_prev, x, lam = x, lam, xn, lam + dlam
                dlam *= 2.0  # recover the nominal increment after a cut
                continue
            cuts += 1
            if cuts > max_cuts:
                message = (
                    f"Newton failed at load factor {lam + dlam:.6g} after {max_cuts} step cuts "
                    f"(last converged factor {lam:.6g})"
                )
                break
            dlam *= 0.5
        if message:
            break
        tip = x[beam.tip]
        history.append((lam, float(L + tip[0]), float(tip[1]), float(tip[2])))
    converged = not message
    tip = x[beam.tip]
    if converged:
        message = f"converged: {steps} steps, {total_iters} Newton iterations"
    return ReissnerResult(
        tip_x=float(L + tip[0]),
        tip_y=float(tip[1]),
        tip_rot=float(tip[2]),
        converged=converged,
        iterations=total_iters,
        message=message,
        factor=float(lam),
        energy=beam.strain_energy(x),
        shape=beam.shape(x),
        history=tuple(history),
    )
