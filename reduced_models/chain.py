"""Chained-segment kinematics and the shared solver of the linear-N, bcm and cbcm-N models.

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from cases.schema import Scene
from reduced_models import single_beam
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.continuation import Banded, minimize_path

NB = 4  # unknowns per node: X, Y, phi, p
HALF_BAND = 2 * NB - 1  # block-tridiagonal with 4x4 blocks -> 7 off-diagonals


@dataclass(frozen=True)
class SegmentLaw:
    """Coefficient matrices (2x2) of the segment-normalised mixed Lagrangian (module doc)."""

    G: np.ndarray
    P: np.ndarray
    Q: np.ndarray

    def lagrangian(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value (N,), gradient (N, 4) and Hessian (N, 4, 4) in (ux, y, a, p)."""
        (g11, g12), (_, g22) = self.G
        (p11, p12), (_, p22) = self.P
        (q11, q12), (_, q22) = self.Q
        # 2x2 symmetric products written out: this runs in every Newton iteration
        Gw0, Gw1 = g11 * y + g12 * a, g12 * y + g22 * a
        Pw0, Pw1 = p11 * y + p12 * a, p12 * y + p22 * a
        Qw0, Qw1 = q11 * y + q12 * a, q12 * y + q22 * a
        wPw = y * Pw0 + a * Pw1
        D = k - (y * Qw0 + a * Qw1)
        p2 = p * p
        val = 0.5 * (y * Gw0 + a * Gw1) + p * (ux + 0.5 * wPw) - 0.5 * p2 * D
        grad = np.empty((ux.size, 4))
        grad[:, 0] = p
        grad[:, 1] = Gw0 + p * Pw0 + p2 * Qw0
        grad[:, 2] = Gw1 + p * Pw1 + p2 * Qw1
        grad[:, 3] = ux + 0.5 * wPw - p * D
        hess = np.zeros((ux.size, 4, 4))
        hess[:, 0, 3] = hess[:, 3, 0] = 1.0
        hess[:, 1, 1] = g11 + p * p11 + p2 * q11
        hess[:, 1, 2] = hess[:, 2, 1] = g12 + p * p12 + p2 * q12
        hess[:, 2, 2] = g22 + p * p22 + p2 * q22
        hess[:, 1, 3] = hess[:, 3, 1] = Pw0 + 2.0 * p * Qw0
        hess[:, 2, 3] = hess[:, 3, 2] = Pw1 + 2.0 * p * Qw1
        hess[:, 3, 3] = -D
        return val, grad, hess

    def energy(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> np.ndarray:
        """Segment strain energy (N,) at the stationary axial force p (normalised EI/h)."""
        w = np.stack([y, a], axis=1)
        wGw = np.einsum("ni,ij,nj->n", w, self.G, w)
        wQw = np.einsum("ni,ij,nj->n", w, self.Q, w)
        return 0.5 * wGw + 0.5 * p**2 * (k - wQw)

    def stiffness(self, p: np.ndarray) -> np.ndarray:
        """Transverse stiffness G + p P + p^2 Q, shape (N, 2, 2)."""
        p = np.asarray(p, dtype=float)[:, None, None]
        return self.G + p * self.P + p**2 * self.Q


def local_coords(nodes: np.ndarray, h: float) -> tuple[np.ndarray, ...]:
    """Segment-frame tip coordinates from node states.

    Parameters
    ----------
    nodes : (N + 1, 3) normalised node states (X, Y, phi).
    h : normalised segment length 1/N.

    Returns
    -------
    xi, eta, a, c, s : each (N,): normalised local tip position, segment rotation, and
    cos/sin of the previous node's angle.
    """
    X, Y, phi = nodes[:, 0], nodes[:, 1], nodes[:, 2]
    c, s = np.cos(phi[:-1]), np.sin(phi[:-1])
    dX, dY = X[1:] - X[:-1], Y[1:] - Y[:-1]
    xi = (c * dX + s * dY) / h
    eta = (-s * dX + c * dY) / h
    return xi, eta, phi[1:] - phi[:-1], c, s


def _band_index(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Scatter maps: local (N, 8) gradient -> global, local (N, 8, 8) -> flat band storage."""
    n = NB * (N + 1)
    gdof = NB * np.arange(N)[:, None] + np.arange(2 * NB)[None, :]  # (N, 8)
    rows = gdof[:, :, None]
    cols = gdof[:, None, :]
    band_row = HALF_BAND + rows - cols  # ab[u + i - j, j]
    return gdof, (band_row * n + cols)


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
        self.gdof, self.bidx = _band_index(N)
        # scatter map of the condensed (X, Y, phi) segment Hessians, upper band storage
        rdof = 3 * np.arange(N)[:, None] + np.arange(6)[None, :]
        r, cc = rdof[:, :, None], rdof[:, None, :]
        # (N, 6, 6): ab[5 + i - j, j] for i <= j; lower-triangle entries go to a dump slot
        self.ridx = np.where(r <= cc, (5 + r - cc) * 3 * (N + 1) + cc, 6 * 3 * (N + 1))
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
        self._cache: tuple | None = None

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node states (N + 1, 3) and segment axial forces (N,) from the unknown vector."""
        q = x.reshape(self.N + 1, NB)
        return q[:, :3], q[1:, 3]

    def local(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment gradients (N, 8) and Hessians (N, 8, 8) of N * l_i in the local unknowns
        (X0, Y0, phi0, p0, X1, Y1, phi1, p1) of each segment (no load terms)."""
        if self._cache is not None and np.array_equal(self._cache[0], x):
            return self._cache[1]  # stability() asks again at the state just converged
        N, h = self.N, self.h
        nodes, p = self.split(x)
        xi, eta, a, c, s = local_coords(nodes, h)
        _, dl, d2l = self.law.lagrangian(xi - 1.0, eta, a, p, self.k)
        # d(ux, y, a, p)/d(local unknowns): (N, 4, 8)
        J = np.zeros((N, 4, 2 * NB))
        ch, sh = c / h, s / h
        J[:, 0, 0], J[:, 0, 1], J[:, 0, 2], J[:, 0, 4], J[:, 0, 5] = -ch, -sh, eta, ch, sh
        J[:, 1, 0], J[:, 1, 1], J[:, 1, 2], J[:, 1, 4], J[:, 1, 5] = sh, -ch, -xi, -sh, ch
        J[:, 2, 2], J[:, 2, 6], J[:, 3, 7] = -1.0, 1.0, 1.0
        gloc = N * np.einsum("nij,ni->nj", J, dl)
        Hloc = N * (J.transpose(0, 2, 1) @ d2l @ J)
        # curvature of xi and eta in phi_{i-1} (row/column 2 of their second derivatives)
        zero = np.zeros_like(c)
        vxi = np.stack([sh, -ch, -xi, zero, -sh, ch, zero, zero], axis=1)
        veta = np.stack([ch, sh, -eta, zero, -ch, -sh, zero, zero], axis=1)
        G2 = N * (dl[:, 0:1] * vxi + dl[:, 1:2] * veta)
        Hloc[:, 2, :] += G2
        Hloc[:, :, 2] += G2
        Hloc[:, 2, 2] -= G2[:, 2]
        self._cache = (x.copy(), (gloc, Hloc))
        return gloc, Hloc

    def update(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """Retraction used by the continuation instead of ``x + dx``.

        The update is mapped to segment deformations (ux, y, a) through the kinematic
        Jacobian (exact to first order), and the node positions and angles are rebuilt from
        the new deformations by forward kinematics (cumulative sums).  Without it a Newton
        step that rotates a long chain leaves O(phi^2) errors in every segment's local
        coordinates, which are large against the small per-segment deformations of a long
        chain and make Newton diverge for N >~ 64.
        """
        N, h = self.N, self.h
        nodes, p = self.split(x)
        xi, eta, a, c, s = local_coords(nodes, h)
        d = dx.reshape(N + 1, NB)
        dd = d[1:] - d[:-1]
        dX, dY, dphi = dd[:, 0], dd[:, 1], dd[:, 2]
        dphi0 = d[:-1, 2]
        # J of local_coords (same as in ``local``) applied to the node increments
        dxi = (c * dX + s * dY) / h + eta * dphi0
        deta = (-s * dX + c * dY) / h - xi * dphi0
        xi2, eta2, a2 = xi + dxi, eta + deta, a + dphi
        phi = np.concatenate([[nodes[0, 2] + d[0, 2]], nodes[0, 2] + d[0, 2] + np.cumsum(a2)])
        cp, sp = np.cos(phi[:-1]), np.sin(phi[:-1])
        out = np.empty_like(x).reshape(N + 1, NB)
        out[0, :3] = nodes[0] + d[0, :3]
        out[1:, 0] = out[0, 0] + np.cumsum(h * (cp * xi2 - sp * eta2))
        out[1:, 1] = out[0, 1] + np.cumsum(h * (sp * xi2 + cp * eta2))
        out[:, 2] = phi
        out[:, 3] = x[3::NB] + d[:, 3]
        return out.ravel()

    def grad_hess(self, x: np.ndarray, lam: float) -> tuple[np.ndarray, Banded]:
        """Residual (n,) and tangent (band storage, 7 + 7 diagonals) at load factor lam."""
        gloc, Hloc = self.local(x)
        g = np.bincount(self.gdof.ravel(), gloc.ravel(), minlength=self.n)
        nb = 2 * HALF_BAND + 1
        ab = np.bincount(self.bidx.ravel(), Hloc.ravel(), minlength=nb * self.n)
        ab = ab.reshape(nb, self.n)
        fX, fY, m = lam * self.loads
        t = self.tip
        if self.follower:
            phi = x[t + 2]
            cp, sp = math.cos(phi), math.sin(phi)
            g[t] -= cp * fX - sp * fY
            g[t + 1] -= sp * fX + cp * fY
            # d(-F)/dphi in rows X_N, Y_N, column phi_N: ab[u + i - j, j]
            ab[HALF_BAND - 2, t + 2] += sp * fX + cp * fY
            ab[HALF_BAND - 1, t + 2] += -(cp * fX - sp * fY)
        else:
            g[t] -= fX
            g[t + 1] -= fY
        g[t + 2] -= m
        return g, Banded(ab, HALF_BAND, HALF_BAND, symmetric=not self.follower)

    def stability(self, x: np.ndarray, lam: float, H: Banded) -> bool | None:
        """Is the equilibrium a strict minimum of the strain energy minus the load work?

        The axial forces are condensed out segment by segment (each p_i lives in one
        segment only), which leaves the Hessian of the energy in (X, Y, phi) with 3x3-block
        tridiagonal structure; a banded Cholesky factorisation then decides positive
        definiteness in O(N).  Where a segment has no axial compliance (linear segments,
        BCM with EA not given) the condensation uses D = max(k - w.Q.w, 1e-9), i.e. an
        axial penalty that can only move a critical load by a relative ~1e-9 N^-2.
        Follower loads are not conservative: None.
        """
        if self.follower:
            return None
        _, Hloc = self.local(x)
        Hpp = np.minimum(Hloc[:, 7, 7], -self.N * 1e-9)
        keep = np.array([0, 1, 2, 4, 5, 6])
        Hr = Hloc[:, keep[:, None], keep[None, :]] - (
            Hloc[:, keep, 7][:, :, None] * Hloc[:, 7, keep][:, None, :] / Hpp[:, None, None]
        )
        nr = 3 * (self.N + 1)
        ab = np.bincount(self.ridx.ravel(), Hr.ravel(), minlength=6 * nr + 1)[: 6 * nr]
        R = Banded(ab.reshape(6, nr), 0, 5)
        fixed = [0, 1, 2] + ([3 * self.N + 2] if self.guided else [])
        R.fix(np.array(fixed))
        try:
            sla.cholesky_banded(R.ab, lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            return False
        return True

    def tip_loads(self, x: np.ndarray) -> np.ndarray:
        """Loads (fX, fY, m) the last segment carries at the tip, from its constitutive law.

        Normalised, beam frame.  At equilibrium they equal the applied tip loads (and the
        guided-tip reaction moment).
        """
        nodes, p = self.split(x)
        xi, eta, a, c, s = local_coords(nodes[-2:], self.h)
        _, dl, _ = self.law.lagrangian(xi - 1.0, eta, a, p[-1:], self.k)
        pl, fl, ml = dl[0, 0], dl[0, 1], dl[0, 2]
        N2 = self.N**2
        return np.array([N2 * (c[0] * pl - s[0] * fl), N2 * (s[0] * pl + c[0] * fl), self.N * ml])


def chain_shape(nodes: np.ndarray, xl: np.ndarray, yl: np.ndarray, h: float) -> np.ndarray:
    """Global points of a chain from per-segment local shapes.

    Parameters
    ----------
    nodes : (N + 1, 3) normalised node states.
    xl, yl : (N, s) segment-normalised local coordinates, xl[:, 0] = 0 at the segment root.
    h : normalised segment length.

    Returns
    -------
    (N (s - 1) + 1, 2) normalised beam-frame points from root to tip.
    """
    c, s = np.cos(nodes[:-1, 2])[:, None], np.sin(nodes[:-1, 2])[:, None]
    X = nodes[:-1, 0:1] + h * (c * xl - s * yl)
    Y = nodes[:-1, 1:2] + h * (s * xl + c * yl)
    pts = np.stack([X[:, :-1].ravel(), Y[:, :-1].ravel()], axis=1)
    return np.vstack([pts, nodes[-1:, :2]])


class ChainModel:
    """A chained-segment energy model of a single beam (base of LinearChain and ChainedBCM).

    Subclasses set ``law`` (SegmentLaw), ``family``, ``_card`` (ModelCard template) and
    implement ``shape(ux, y, a, p, k, sigma) -> (xl, yl, kappa)`` (each (N, s), segment
    units) and ``warnings(ux, y, a, p, k) -> list[str]``.

    Parameters
    ----------
    n : number of segments.
    shape_points : sample points per segment for shapes and stress (default: about 48 per
        beam, at least 5 per segment).
    """

    law: SegmentLaw
    family = "chain"
    _card: ModelCard
    extensible = False

    def __init__(self, n: int = 1, shape_points: int | None = None) -> None:
        if int(n) < 1:
            raise ValueError("segment count must be >= 1")
        self.N = int(n)
        self.shape_points = shape_points or max(5, math.ceil(48 / self.N) + 1)
        self.name = f"{self.family}-{self.N}"
        self.card = ModelCard(
            name=self.name,
            family=self._card.family,
            summary=self._card.summary.format(N=self.N),
            assumptions=self._card.assumptions,
            validity=self._card.validity,
            references=self._card.references,
        )

    # -- subclass hooks --------------------------------------------------------------------
    def shape(
        self,
        ux: np.ndarray,
        y: np.ndarray,
        a: np.ndarray,
        p: np.ndarray,
        k: float,
        sigma: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local segment shapes from segment states (each (N,)) at positions sigma (s,).

        Returns xl, yl (segment units, xl[:, 0] = 0) and curvature kappa (1/h), each (N, s).
        """
        raise NotImplementedError

    def warnings(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> list[str]:
        """Messages for segment states outside the model's validity range (none here)."""
        return []

    # -- Model protocol --------------------------------------------------------------------
    def applies_to(self, scene: Scene) -> str | None:
        """None if ``scene`` is a clamped beam with tip loads, else the reason."""
        beam = single_beam.cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if not (math.isfinite(beam.EI) and beam.EI > 0 and beam.L > 0):
            return "flexible member needs finite positive E and I"
        return None

    def problem(self, beam: single_beam.Cantilever) -> ChainProblem:
        """The normalised chain problem of a cantilever."""
        L, EI = beam.L, beam.EI
        h = L / self.N
        k = EI / (beam.EA * h**2) if (self.extensible and math.isfinite(beam.EA)) else 0.0
        loads = (beam.fx * L**2 / EI, beam.fy * L**2 / EI, beam.m * L / EI)
        return ChainProblem(self.law, self.N, k, loads, beam.follower, beam.guided)

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path by load continuation (see ``continuation.minimize_path``)."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        beam = single_beam.cantilever_of(scene)
        prob = self.problem(beam)
        factors = load_factors(scene)
        res = minimize_path(
            prob.grad_hess,
            prob.x0,
            factors,
            scale=prob.scale,
            fixed=prob.fixed,
            max_step=prob.max_step,
            stability=prob.stability,
            update=prob.update,
        )
        L, EI = beam.L, beam.EI
        sigma = np.linspace(0.0, 1.0, self.shape_points)
        steps, all_nodes, all_p = [], [], []
        warned: dict[str, str] = {}  # warning -> first factor it appeared at
        a_cfg = scene.analysis
        v0 = None
        for j, lam in enumerate(res.factors):
            x = res.states[j]
            nodes, p = prob.split(x)
            xi, eta, a, _, _ = local_coords(nodes, prob.h)
            ux = xi - 1.0
            energy = EI / L * self.N * float(np.sum(self.law.energy(ux, eta, a, p, prob.k)))
            xl, yl, kappa = self.shape(ux, eta, a, p, prob.k, sigma)
            pts = chain_shape(nodes, xl, yl, prob.h) * L
            tip = nodes[-1]
            outputs = single_beam.tip_outputs(scene, beam, tip[0] * L, tip[1] * L, tip[2])
            loads = prob.tip_loads(x)
            for w in self.warnings(ux, eta, a, p, prob.k):
                warned.setdefault(w, f"{w} (from factor {lam:.4g})")
            steps.append(
                Step(
                    factor=float(lam),
                    outputs=outputs,
                    energy=energy,
                    iterations=int(res.iterations[j]),
                    stable=res.stable[j],
                    shapes={beam.member: beam.rotate_to_global(pts)},
                    max_stress=single_beam.stress_from_curvature(scene, beam, kappa * self.N / L),
                    info={
                        "tip.fx": float(loads[0] * EI / L**2),
                        "tip.fy": float(loads[1] * EI / L**2),
                        "tip.m": float(loads[2] * EI / L),
                        "residual": float(res.residuals[j]),
                        "cuts": float(res.cuts[j]),
                        "max_segment_y": float(np.max(np.abs(eta))),
                    },
                )
            )
            all_nodes.append(nodes * np.array([L, L, 1.0]))
            all_p.append(p)
            # a "path" analysis stops once its stop output reaches the stop value
            if a_cfg.kind == "path" and a_cfg.stop_output and a_cfg.stop_value is not None:
                v = outputs.get(a_cfg.stop_output)
                v0 = v if v0 is None else v0
                if (
                    v is not None
                    and j > 0
                    and (v - a_cfg.stop_value) * (v0 - a_cfg.stop_value) <= 0
                ):
                    break
        extras: dict[str, object] = {
            "nodes": np.array(all_nodes),
            "axial": np.array(all_p),
            "k": prob.k,
        }
        if warned:
            extras["validity_warning"] = True
            extras["validity_message"] = "; ".join(warned.values())
        if not res.ok:
            return Solution(scene.name, self.name, "failed", res.reason, tuple(steps), extras)
        msg = f"{len(steps)} steps, {int(res.iterations.sum())} Newton iterations"
        if warned:
            msg += "; outside validity range: " + "; ".join(warned.values())
        return Solution(scene.name, self.name, "converged", msg, tuple(steps), extras)
