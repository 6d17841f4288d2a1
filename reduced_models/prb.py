"""Pseudo-rigid-body (PRB) models of a cantilever through the PRB matrix.

Every PRB model here is a chain of rigid segments described by a PRB matrix
``[[k_theta, k_ex, gamma], ...]`` (see ``prb_tables``): segment i has length gamma_i L (plus an
axial stretch u_i when k_ex_i is finite), a torsion spring k_theta_i EI/L at its proximal end
(absent when infinite) and an axial spring k_ex_i EA/L (rigid when infinite).

Equilibrium is the stationary point of the total potential energy
``V = sum 1/2 K_theta theta^2 + sum 1/2 K_ex u^2 - (fx X + fy Y + m Phi)``
(dead tip loads; X, Y tip position, Phi tip-link angle), found by Newton's method with the
analytic gradient and Hessian (vectorised over segments; tridiagonal in absolute link angles)
along the load ramp with step cutting, through the shared ``reduced_models.continuation``.

Shape and stress (seed 000_265bc60728766176.txt, "Computing Beam Shape and Stress"): the end
loads are recovered from the spring torques through the Moore-Penrose pseudo-inverse of the
Jacobian transpose, then the elastica is solved for those loads
(``reduced_models.elastica.shape_under_tip_load``); without that module the PRB polyline and
the bending moments at the joints are used instead.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import cholesky_banded

from cases.schema import Scene
from reduced_models import prb_tables as T
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.continuation import Banded, PathResult, minimize_path
from reduced_models.single_beam import Cantilever, cantilever_of, tip_outputs

_REF = "Venkiteswaran & Su, Precis. Eng. 40:46-54, 2015, doi 10.1016/j.precisioneng.2014.10.002"
_SEED = "seed 000_265bc60728766176.txt: PRB matrix, Jacobian, shape and stress slides"
#: largest accepted max |grad V| at a reported state, in units of EI/L
RESIDUAL_TOL = 1e-8

_COMMON = (
    "rigid segments joined by linear torsion springs (PRB matrix)",
    "dead tip loads only (energy formulation; follower loads are declined)",
    "shape and stress from the elastica under the end loads recovered by pinv(J^T)",
)


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
    ``continuation`` as a ``Banded`` matrix (linear cost in N).

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
        # A (S, nj): segment i has angle psi[owner[i]]; sums over a joint's links are z @ A
        # (small chains; long chains use add.reduceat, the links of a joint are contiguous)
        self.A = (owner[:, None] == np.arange(self.nj)[None, :]).astype(float) if S <= 24 else None
        self.root = owner < 0  # rigid root links (angle 0)
        self.scale = np.concatenate([np.ones(self.nj), np.full(self.ne, L)])
        # spring stiffness in psi: sum K_p (psi_p - psi_{p-1})^2 / 2 -> tridiagonal K_psi
        Kn = np.append(self.Kt[1:], 0.0)
        self._kd, self._ko = self.Kt + Kn, -self.Kt[1:]
        self._Kpsi = np.diag(self._kd) + np.diag(self._ko, 1) + np.diag(self._ko, -1)
        self._small = S <= 24
        self.banded = self.ne == 0 and self.nj > 12

    # -- kinematics --------------------------------------------------------------------------
    def _links(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Link vectors z_i = l_i e^{i phi_i} (S,) and unit directions e^{i psi_p} (nj,)."""
        Ep = np.exp(1j * x[: self.nj])
        E = np.where(self.root, 1.0 + 0j, Ep[self.owner])
        if self.ne:
            ln = self.gL.copy()
            ln[self.eidx] += x[self.nj :]
            return ln * E, Ep
        return self.gL * E, Ep

    def theta(self, x: np.ndarray) -> np.ndarray:
        """Relative joint rotations theta_p = psi_p - psi_{p-1} (rad), shape (nj,)."""
        th = x[: self.nj].copy()
        th[1:] -= x[: self.nj - 1]
        return th

    def springs(self, x: np.ndarray) -> np.ndarray:
        """Spring coordinates [theta (nj,), u (ne,)]."""
        return np.concatenate([self.theta(x), x[self.nj :]])

    def _displacements(self, x: np.ndarray) -> np.ndarray:
        # z_i - l0_i as l0 (e^{i phi} - 1) + u e^{i phi}, with e^{i phi} - 1 = 2i sin(phi/2)
        # e^{i phi/2}: exact zero without load and full precision for tiny rotations
        psi = x[: self.nj]
        half = np.where(self.root, 0.0, 0.5 * psi[np.maximum(self.owner, 0)])
        d = self.gL * (2j * np.sin(half) * np.exp(1j * half))
        if self.ne:
            d[self.eidx] += x[self.nj :] * np.exp(2j * half[self.eidx])
        return d

    def tip(self, x: np.ndarray) -> tuple[float, float, float]:
        """Tip x, y (beam frame, length) and tip-link angle (rad)."""
        t = self._displacements(x).sum()
        return float(self.L + t.real), float(t.imag), float(x[self.nj - 1])

    def points(self, x: np.ndarray) -> np.ndarray:
        """Joint and end points of the chain, shape (S + 1, 2), beam frame."""
        p = np.concatenate([[0.0], np.cumsum(self._displacements(x))])
        s = np.concatenate([[0.0], np.cumsum(self.gL)])
        return np.column_stack([s + p.real, p.imag])

    def jacobian_T(self, x: np.ndarray) -> np.ndarray:
        """J^T: one row per spring coordinate (theta_p, then u_e), columns d(X, Y, Phi),
        shape (nj + ne, 3) (seed slide "Computing Beam Shape and Stress")."""
        z, Ep = self._links(x)
        T = np.cumsum(z[::-1])[::-1][self.jidx]  # tip minus joint p
        e = Ep[self.eown] if self.ne else np.zeros(0, complex)
        e = np.where(self.eown < 0, 1.0 + 0j, e)
        rows_t = np.column_stack([-T.imag, T.real, np.ones(self.nj)])
        rows_e = np.column_stack([e.real, e.imag, np.zeros(self.ne)])
        return np.vstack([rows_t, rows_e])

    def spring_forces(self, x: np.ndarray) -> np.ndarray:
        """Spring torques and axial forces tau = K [theta, u], shape (nj + ne,)."""
        return self.Kspring * self.springs(x)

    def strain_energy(self, x: np.ndarray) -> float:
        """Elastic energy stored in the springs (force * length)."""
        q = self.springs(x)
        return float(0.5 * np.dot(self.Kspring * q, q))

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
        FZ = F * (z @ self.A if self._small else np.add.reduceat(z, self.jidx))
        Kth = self.Kt * self.theta(x)
        gpsi = FZ.imag + Kth
        gpsi[:-1] -= Kth[1:]
        gpsi[-1] -= f[2]
        if self.banded and not dense:
            ab = np.zeros((3, self.nj))
            ab[0, 1:] = self._ko
            ab[1] = self._kd + FZ.real
            ab[2, :-1] = self._ko
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

    def potential(self, x: np.ndarray, f: np.ndarray) -> float:
        """Total potential V = U - (fx X + fy Y + m Phi) (force * length)."""
        X, Y, phi = self.tip(x)
        return self.strain_energy(x) - (f[0] * X + f[1] * Y + f[2] * phi)


def equilibrium_path(
    chain: PRBChain,
    f1: np.ndarray,
    factors: np.ndarray,
    guided: bool = False,
    xtol: float = 1e-6,
) -> PathResult:
    """Equilibria for loads ``lambda * f1`` at the reported ``factors`` (from the unloaded
    state) through the shared Newton/continuation (``reduced_models.continuation``).

    ``guided`` holds the tip-link angle at zero (fixed-guided beam; the tip moment is then a
    reaction and ``f1[2]`` is ignored).  ``xtol`` bounds the last Newton update (rad, or
    length / L); with quadratic convergence the accepted state is accurate to ~xtol^2, and the
    residual evaluated there is returned (``PRBModel.solve`` checks it against
    ``RESIDUAL_TOL``).
    """
    f1 = np.asarray(f1, dtype=float)
    if guided:
        f1 = np.array([f1[0], f1[1], 0.0])

    def gh(x: np.ndarray, lam: float) -> tuple:
        return chain.grad_hess(x, lam * f1)

    fixed = [chain.nj - 1] if guided else None
    return minimize_path(
        gh,
        np.zeros(chain.n),
        factors,
        scale=chain.scale,
        xtol=xtol,
        fixed=fixed,
        stability=_positive_definite,
    )


def _positive_definite(x: np.ndarray, lam: float, H: np.ndarray | Banded) -> bool:
    """Stable equilibrium: Cholesky of the (symmetric by construction) Hessian succeeds."""
    try:
        if isinstance(H, Banded):
            cholesky_banded(H.upper(), lower=False, check_finite=False)
        else:
            np.linalg.cholesky(H)
        return True
    except np.linalg.LinAlgError:
        return False


def recover_tip_loads(
    chain: PRBChain, x: np.ndarray, f_known: np.ndarray | None = None
) -> tuple[np.ndarray, int]:
    """End loads (fx, fy, m) from the spring forces through pinv(J^T) (seed slide).

    With fewer than three independent spring rows (PRB-1R, PRB-2R) the pseudo-inverse only
    recovers the load components in the row space of J^T.  The seed's remedy turns rigid links
    into very stiff axial springs; in the stiff limit their forces are the known end load
    projected on the links, which amounts to completing the null-space component from
    ``f_known`` when it is given.  Returns ``(f, rank of J^T)``.
    """
    JT = chain.jacobian_T(x)
    tau = chain.spring_forces(x)
    U, sv, Vt = np.linalg.svd(JT, full_matrices=False)
    keep = sv > 1e-12 * max(1.0, float(sv[0])) if sv.size else sv > 0
    rank = int(keep.sum())
    Vk = Vt[keep]
    f = Vk.T @ ((U[:, keep].T @ tau) / sv[keep])
    if rank < 3 and f_known is not None:
        fk = np.asarray(f_known, dtype=float)
        f = f + fk - Vk.T @ (Vk @ fk)
    # components at round-off level (below the equilibrium tolerance) are zero: a tip moment
    # of 1e-16 would otherwise send the elastica to its slower combined-load route
    size = np.abs(f) * np.array([1.0, 1.0, 1.0 / chain.L])
    f[size < 1e-10 * max(float(size.max()), 1e-300)] = 0.0
    return f, rank


def _elastica_shape() -> object | None:
    try:
        from reduced_models import elastica
    except ImportError:
        return None
    return getattr(elastica, "shape_under_tip_load", None)


def shape_and_stress(
    scene: Scene, beam: Cantilever, chain: PRBChain, x: np.ndarray, f: np.ndarray
) -> tuple[dict, float | None, dict]:
    """Deformed shape (global points) and largest bending stress for recovered end loads f.

    Primary route: the elastica under f (seed).  Fallback (module missing or the elastica
    fails for these loads): the PRB polyline and the bending moment m + (tip - p) x f at the
    root and at every joint.  Returns ``(shapes, max_stress, info)``.
    """
    mem = scene.member(beam.member)
    info: dict[str, float] = {}
    shape_fn = _elastica_shape()
    kappa = None
    if shape_fn is not None:
        try:
            xy, kappa = shape_fn(chain.L, chain.EI, float(f[0]), float(f[1]), float(f[2]), n=41)
            xy, kappa = np.asarray(xy, dtype=float), np.asarray(kappa, dtype=float)
            if not (np.all(np.isfinite(xy)) and np.all(np.isfinite(kappa))):
                raise ValueError("non-finite elastica shape")
            tx, ty, _ = chain.tip(x)
            info["shape_tip_gap"] = float(np.hypot(xy[-1, 0] - tx, xy[-1, 1] - ty) / chain.L)
            info["shape_from_elastica"] = 1.0
        except Exception:  # noqa: BLE001 - any elastica failure degrades to the polyline
            kappa = None
    if kappa is None:
        xy = chain.points(x)
        tip = xy[-1]
        p = np.vstack([[0.0, 0.0], xy[chain.jidx]])
        M = f[2] + (tip[0] - p[:, 0]) * f[1] - (tip[1] - p[:, 1]) * f[0]
        kappa = M / chain.EI
        info["shape_from_elastica"] = 0.0
    stress = None
    if mem.thickness is not None and mem.E is not None:
        stress = float(mem.E * mem.thickness * np.max(np.abs(kappa)) / 2.0)
    return {beam.member: beam.rotate_to_global(xy)}, stress, info


class PRBModel:
    """A PRB model of a single cantilever defined by a PRB matrix (subclasses pick it)."""

    name = "prb"
    card = ModelCard(name="prb", family="prb", summary="PRB chain", assumptions=_COMMON)

    def __init__(self, matrix: object = None, shapes: bool = True) -> None:
        self._matrix = None if matrix is None else check_matrix(matrix)
        self.shapes = bool(shapes)

    # subclasses override: (matrix, tip-angle factor, note) for this cantilever, or a reason
    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """PRB matrix, tip-angle factor and a note for this cantilever, or why not."""
        if self._matrix is None:
            return "no PRB matrix given"
        return self._matrix, 1.0, ""

    def _beam(self, scene: Scene) -> Cantilever | str:
        beam = cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if beam.follower:
            return (
                "follower tip loads are non-conservative; energy-based PRB models take dead loads"
            )
        if scene.analysis.kind != "load":
            return f"analysis kind {scene.analysis.kind!r}: PRB models follow a load ramp only"
        if not (math.isfinite(beam.EI) and beam.EI > 0):
            return "flexural rigidity EI of the beam is not given"
        return beam

    def applies_to(self, scene: Scene) -> str | None:
        """None if this PRB model can solve the scene, else the reason."""
        beam = self._beam(scene)
        if isinstance(beam, str):
            return beam
        s = self.setup(beam)
        if isinstance(s, str):
            return s
        nj = int(np.isfinite(s[0][:, 0]).sum())
        if beam.guided and nj < 2:
            return "a guided tip needs at least two PRB joints (tip angle held at zero)"
        return None

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of the scene's load ramp."""
        reason = self.applies_to(scene)
        if reason is not None:
            return not_applicable(scene, self.name, reason)
        beam = self._beam(scene)
        matrix, rot_factor, note = self.setup(beam)
        chain = PRBChain(matrix, beam.L, beam.EI, beam.EA)
        f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
        path = equilibrium_path(chain, f1, load_factors(scene), guided=beam.guided)
        steps = []
        failed = "" if path.ok else path.reason
        for lam, q, it, st, res, cuts in zip(
            path.factors, path.states, path.iterations, path.stable, path.residuals, path.cuts
        ):
            res = float(res) * chain.L / chain.EI  # max |grad V| in EI/L (forces times L)
            if not res <= RESIDUAL_TOL:
                failed = f"residual {res:.2e} EI/L above {RESIDUAL_TOL:g} at factor {lam:.6g}"
                break
            x, y, phi = chain.tip(q)
            rot = 0.0 if beam.guided else rot_factor * phi
            f_known = None if beam.guided else lam * f1
            f, rank = recover_tip_loads(chain, q, f_known)
            info = {
                "residual": res,
                "step_cuts": float(cuts),
                "load_fx": float(f[0]),
                "load_fy": float(f[1]),
                "load_m": float(f[2]),
                "jt_rank": float(rank),
            }
            shapes, stress = {}, None
            if self.shapes:
                shapes, stress, extra = shape_and_stress(scene, beam, chain, q, f)
                info.update(extra)
            steps.append(
                Step(
                    factor=float(lam),
                    outputs=tip_outputs(scene, beam, x, y, rot),
                    energy=chain.strain_energy(q),
                    iterations=int(it),
                    stable=st,
                    shapes=shapes,
                    max_stress=stress,
                    info=info,
                )
            )
        extras = {
            "prb_matrix": matrix.tolist(),
            "tip_angle_factor": rot_factor,
            # chain coordinates [psi (rad), u (length)] per reported step (mechanism assembly)
            "prb_states": [list(map(float, q)) for q in path.states[: len(steps)]],
        }
        if failed:
            return Solution(scene.name, self.name, "failed", failed, tuple(steps), extras)
        msg = "converged" + (f"; {note}" if note else "")
        if np.any(np.isfinite(matrix[:, 1])) and chain.ne == 0:
            msg += "; axial springs treated as rigid (EA not given)"
        return Solution(scene.name, self.name, "converged", msg, tuple(steps), extras)


# ---------------------------------------------------------------------------------------------
# The registered PRB models
# ---------------------------------------------------------------------------------------------


class PRBShort(PRBModel):
    """Small-length flexural pivot applied to the whole beam: pivot at L/2, K = EI/L."""

    card = ModelCard(
        name="prb-short",
        family="prb",
        summary="small-length flexural pivot: one pivot at mid-length, K = EI/L",
        assumptions=_COMMON + ("the flexible segment is short next to the rigid link it joins",),
        validity=(
            "accurate when the flexible length l is much shorter than the rigid segment it "
            "connects (Howell & Midha 1994); on a whole cantilever it is a one-spring model "
            "with large errors"
        ),
        references=(
            "Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",
            "Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.4",
            _SEED,
        ),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.PRB_SHORT, shapes)


class PRB1R(PRBModel):
    """Howell's PRB-1R with load-ratio-dependent gamma(n), K_Theta(n), c_theta(n)."""

    card = ModelCard(
        name="prb-1r",
        family="prb",
        summary="Howell's 1R model: characteristic pivot, gamma(n), K_Theta(n), c_theta(n)",
        assumptions=_COMMON
        + (
            "parameters depend on the load ratio n = axial/transverse tip force (n > 0 "
            "compressive); fixed along a proportional load ramp",
            "tip slope = c_theta * Theta (parametric angle coefficient)",
            "a pure end moment uses Howell's moment parameters gamma 0.7346, K_Theta 2.0643, "
            "c_theta 1.5164; a force combined with a moment is declined",
            "K_Theta is a large-deflection average: at small loads the model is stiffer than "
            "linear theory by the factor K_Theta/(3 gamma) (about 3.8 % at n = 0)",
            "pinv(J^T) has rank 1: end loads for shape/stress completed from the applied loads",
        ),
        validity=(
            "tip locus of the characteristic radius within 0.5 % of the deflection up to "
            "Theta_max ~ 64.3 deg for n = 0 (Howell 2001 Table 5.1); fits cover -5 < n <= 10; "
            "pure moment: tip slope to ~124.4 deg"
        ),
        references=(
            "Howell & Midha, J. Mech. Des. 117:156-165, 1995, doi 10.1115/1.2826101",
            "Howell, Midha & Norton, J. Mech. Des. 118:126-131, 1996, doi 10.1115/1.2826843",
            "Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.5-5.6, Table 5.1",
        ),
    )

    def __init__(self, params: str = "fit", shapes: bool = True) -> None:
        super().__init__(None, shapes)
        if params not in ("fit", "average"):
            raise ValueError("prb-1r option params must be 'fit' or 'average'")
        self.params = params

    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """Howell's parameters for this cantilever's load ratio."""
        fx, fy, m = beam.fx, beam.fy, beam.m
        if fx == 0.0 and fy == 0.0 and m != 0.0:
            p = T.HOWELL_MOMENT
            return T.prb1r_matrix(p["gamma"], p["K_Theta"]), p["c_theta"], "pure-moment parameters"
        if m != 0.0:
            return "tip force combined with a moment: Howell's PRB-1R covers one or the other"
        if fy == 0.0 and fx != 0.0:
            return "purely axial tip force: the PRB-1R load ratio n is unbounded"
        n = -fx / abs(fy) + 0.0 if fy != 0.0 else 0.0  # + 0.0: no '-0' in messages
        if self.params == "average":
            p = T.HOWELL_AVERAGE
            return T.prb1r_matrix(p["gamma"], p["K_Theta"]), p["c_theta"], "average parameters"
        lo, hi = T.HOWELL_N_RANGE
        if not lo < n <= hi:
            return f"load ratio n = {n:.3g} outside Howell's fitted range ({lo:g}, {hi:g}]"
        g, k, c = T.howell_gamma(n), T.howell_k_theta(n), T.howell_c_theta(n)
        return T.prb1r_matrix(g, k), c, f"n = {n:.4g}: gamma {g:.4f}, K_Theta {k:.4f}, c {c:.4f}"


class PRB2R(PRBModel):
    """Two-joint PRB model with parameters derived here (no checked published set found)."""

    card = ModelCard(
        name="prb-2r",
        family="prb",
        summary="2R chain, parameters fitted here to the elastica (see prb_tables.PRB_2R_FIT)",
        assumptions=_COMMON
        + (
            "parameters are NOT a published set: derived with prb_fit.fit_prb(2) against the "
            "exact elastica for a transverse tip force and a pure end moment",
            "pinv(J^T) has rank 2: end loads for shape/stress completed from the applied loads",
        ),
        validity=(
            "fitted for a transverse tip force PL^2/EI <= 10 and an end moment ML/EI <= 2: "
            "max tip position error 3.8 % of L, tip angle 0.024 rad (measured at the fit)"
        ),
        references=(_REF, _SEED, "FlexBench derivation: reduced_models/prb_tables.py"),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.PRB_2R, shapes)


class PRB3R(PRBModel):
    """Su's PRB-3R (gamma 0.10/0.35/0.40/0.15) with one of the three stiffness sets."""

    kset = "average"

    def __init__(self, stiffness: str | None = None, shapes: bool = True) -> None:
        kset = stiffness or self.kset
        if kset not in T.SU_K:
            raise ValueError(f"prb-3r option stiffness must be one of {sorted(T.SU_K)}")
        super().__init__(T.prb3r_matrix(kset), shapes)
        self.kset = kset
        self.card = ModelCard(
            name="prb-3r" if kset == "average" else f"prb-3r-{kset}",
            family="prb",
            summary=f"Su's 3R model, stiffness set: {T.SU_SOURCE[kset]}",
            assumptions=_COMMON
            + (
                "load-independent parameters: gamma 0.10 (rigid root), 0.35, 0.40, 0.15; "
                f"k = {', '.join(str(k) for k in T.SU_K[kset])} (EI/L)",
            ),
            validity=(
                "combined tip force and moment; Su reports errors much smaller than the 1R "
                "model and a 1.2 % maximum tip-deflection error in his four-bar example vs FEA"
            ),
            references=(
                "Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148, Sec. 4, "
                "Eq. (24), (25), (27), Table 1",
                _SEED,
            ),
        )


class PRB3RForce(PRB3R):
    """PRB-3R with Su's stiffness set optimised for a pure tip force (Eq. 27)."""

    kset = "force"


class PRB3RMoment(PRB3R):
    """PRB-3R with Su's stiffness set optimised for a pure end moment (Eq. 25)."""

    kset = "moment"


class PRB2RPR(PRBModel):
    """PRB-2(RP)R: Su's 3R with prismatic springs in the two middle segments (derived)."""

    card = ModelCard(
        name="prb-2rpr",
        family="prb",
        summary="3R chain whose two middle links stretch: axial extension included",
        assumptions=_COMMON
        + (
            "revolute parameters = Su's PRB-3R (Table 1); prismatic springs DERIVED here: "
            "series axial compliance equals L/EA, split in proportion to segment length",
            "needs EA (area) for the axial springs; without it the links are rigid",
        ),
        validity="as PRB-3R for bending; axial stretch exact for a straight bar in tension",
        references=(_REF, "Su 2009, doi 10.1115/1.3046148", _SEED),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.prb2rpr_matrix(), shapes)


class PRBFSM(PRBModel):
    """Finite segment model: N elements, a spring N EI/L at each element centre (or end)."""

    def __init__(self, n: int, placement: str = "mid", shapes: bool = True) -> None:
        super().__init__(T.fsm_matrix(int(n), placement), shapes)
        where = "element centres" if placement == "mid" else "proximal element ends"
        self.card = ModelCard(
            name=f"prb-fsm-{n}",
            family="prb",
            summary=f"finite segment model, {n} elements, springs N EI/L at the {where}",
            assumptions=_COMMON
            + (
                "each element of length L/N is a small-length flexural pivot at its centre "
                "(midpoint rule: tip error O(1/N^2)); placement='end' gives O(1/N)",
            ),
            validity="converges to the inextensible elastica as N grows (rate asserted in tests)",
            references=(
                "Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",
                _REF,
                _SEED,
            ),
        )


class PRBCustom(PRBModel):
    """PRB matrix given in the case file: [[models]] name = "prb-custom", options.matrix."""

    card = ModelCard(
        name="prb-custom",
        family="prb",
        summary="user PRB matrix [[k_theta, k_ex, gamma], ...] from the case file",
        assumptions=_COMMON + ("parameters as given by the user (e.g. from flexbench fit-prb)",),
        validity="whatever the matrix was fitted for",
        references=(_REF, _SEED),
    )

    def __init__(
        self, matrix: object = None, tip_angle_factor: float = 1.0, shapes: bool = True
    ) -> None:
        self._error = None
        try:
            super().__init__(matrix, shapes)
        except ValueError as exc:
            super().__init__(None, shapes)
            self._error = f"options.matrix: {exc}"
        self.rot_factor = float(tip_angle_factor)

    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """The user's matrix, or why it cannot be used."""
        if self._error:
            return self._error
        if self._matrix is None:
            return "prb-custom needs options.matrix = [[k_theta, k_ex, gamma], ...] in the case"
        return self._matrix, self.rot_factor, ""
