"""Arc-length continuation for ``path`` analyses (through limit points and snap-backs).

Unknowns z = (q_free, mu, lam).  Each step: tangent predictor z + ds t, then Newton on the
bordered system

    [[K, r_lam], [t_q^T, t_lam]] dz = -[r; t . (z - z_prev) - ds],

with K the KKT matrix, r_lam = d r / d lam (minus the load vector) and the arc length measured
on (q / length scale, lam) only (multipliers carry no length).  The step grows after easy
steps and halves on failure or when the corrector lands off the step (``JUMP_COS``,
``JUMP_ITERATIONS``).
A crossing of ``stop_output = stop_value`` is landed exactly
(the arc-length row replaced by the output row); a crossing of ``factor_end`` by a Newton
solve at that factor.  Load-factor extrema (sign changes of d lam / ds between steps) are
refined (zero of d lam / ds along the arc), inserted as steps with ``info["limit_point"]``
and listed in ``extras["limit_points"]``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cases.node_rotation import no_own_rotation
from reduced_models.mechanism.kkt import bordered_solve
from reduced_models.mechanism.newton import (
    FLOOR_ITERATIONS,
    FLOOR_RES,
    POLISH_BELOW,
    SolveError,
    State,
)
from reduced_models.mechanism.system import SceneError

# a corrector whose secant leaves the tangent by more than acos(JUMP_COS), or that needs more
# than JUMP_ITERATIONS Newton iterations, has left the path's neighbourhood (members with a
# stiff primal axial law, elastica or PRB-2RPR, landed past Lee's frame's snap-back and across
# the shallow arch's snap-through): the step is halved
JUMP_COS = 0.95
JUMP_ITERATIONS = 12
# an easy step (the next one 1.5x longer) reaches EASY_RES x the Newton tolerance within
# EASY_ITERATIONS: counted there, far above the residual's round-off floor, the count does
# not depend on how the scene is drawn (at the tolerance itself it did: a 64-segment chain's
# floor sits at 1e-10, and the shallow arch was sampled differently when rotated)
EASY_RES = 1e3
EASY_ITERATIONS = 3


class ArcLength:
    """Pseudo-arc-length stepping on a ``Run`` (``analyses.Run``)."""

    def __init__(self, run: object) -> None:
        self.run = run
        self.sv = run.solver
        s = run.s
        kind = np.array(s.lay.kind)[s.free]
        nf = len(s.free)
        self.w = np.concatenate(
            [
                np.where(kind == "r", 1.0, np.where(kind == "p", 0.0, 1.0 / s.lay.Lref)),
                np.zeros(s.m),
            ]
        )
        self.nf = nf

    def _z(self, st: State) -> np.ndarray:
        return np.concatenate([st.q[self.run.s.free], st.mu, [st.lam]])

    def _state(self, z: np.ndarray, base: State) -> State:
        q = base.q.copy()
        q[self.run.s.free] = z[: self.nf]
        return State(q, z[self.nf : -1].copy(), float(z[-1]))

    def tangent(self, st: State, prev_t: np.ndarray | None) -> np.ndarray:
        """Unit tangent (weighted norm) in z, oriented along ``prev_t`` (or +lam)."""
        v = self.sv.tangent(st, "lam")
        t = np.concatenate([v, [1.0]])
        t /= np.sqrt(np.sum((self.w * t[:-1]) ** 2) + 1.0)
        if prev_t is not None and self._dot(t, prev_t) < 0:
            t = -t
        return t

    def _dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(np.sum(self.w**2 * a[:-1] * b[:-1]) + a[-1] * b[-1])

    def corrector(
        self,
        z0: np.ndarray,
        t: np.ndarray,
        ds: float,
        base: State,
        row: tuple[int, float] | None = None,
    ) -> State:
        """Newton on the bordered system from the predictor; ``row = (index, value)`` replaces
        the arc-length equation by q[index] = value (landing on a stop value)."""
        s, sv = self.run.s, self.sv
        z = z0 + ds * t
        self.easy_at = None  # the first iteration at EASY_RES x tol (``run_path``'s step)
        best, since = np.inf, 0  # the lowest residual, iterations since it last halved
        for it in range(sv.max_iter + 1):
            st = self._state(z, base)
            R, K, res = sv.kkt(st)
            if self.easy_at is None and res <= EASY_RES * sv.tol:
                self.easy_at = it
            best, since = (res, 0) if res < 0.5 * best else (best, since + 1)
            floor = since >= FLOOR_ITERATIONS and res <= FLOOR_RES * sv.tol
            if row is None:
                a = np.concatenate([self.w**2 * t[:-1], [t[-1]]])
                extra = self._dot(t, z - z0) - ds
                scale = 1.0
            else:
                a = np.zeros(len(z))
                a[row[0]] = 1.0
                extra = z[row[0]] - row[1]
                scale = s.lay.Lref
            converged = (res <= sv.tol or floor) and abs(extra) <= sv.tol * scale
            if converged and res <= POLISH_BELOW * sv.tol:
                return State(st.q, st.mu, st.lam, it, res, K, False)
            if it == sv.max_iter and not converged:
                break
            col = np.zeros(K.shape[0])
            col[: self.nf] = s.reduced_load(st.q)
            try:
                dz = bordered_solve(K, col, a, -np.concatenate([R, [extra]]))
            except np.linalg.LinAlgError:
                dz = np.full(len(z), np.nan)
            if converged:  # one more update to round-off (``Solver.polish``), if it helps
                return self._polish(st, K, res, z + dz, base, it)
            if not np.all(np.isfinite(dz)):
                break
            z = z + dz
        raise SolveError("arc-length corrector did not converge")

    def _polish(
        self, st: State, K: object, res: float, z: np.ndarray, base: State, it: int
    ) -> State:
        """The corrector's converged state ``st`` or, when the update to ``z`` lowers the
        residual, that state.  Converged at tol the state still depends on the iterates that
        led there (on how the scene is drawn): at that level the Newton iteration counts that
        set the next step length differed (Lee's frame drawn with its members reversed took
        4 and 5 iterations at one step, and the rest of the path was sampled elsewhere).  The
        count stays the converged one: the step lengths are those of the unpolished path."""
        if not np.all(np.isfinite(z)):
            return State(st.q, st.mu, st.lam, it, res, K, False)
        new = self._state(z, base)
        R2, K2, res2 = self.sv.kkt(new)
        if not (np.isfinite(R2).all() and res2 < res):
            return State(st.q, st.mu, st.lam, it, res, K, False)
        return State(new.q, new.mu, new.lam, it, res2, K2, False)


def run_path(run: object) -> None:
    """The ``path`` analysis on ``run`` (module doc); raises SolveError on failure."""
    a, s = run.scene.analysis, run.s
    st = run.solver.newton(run.zero())
    run.record(st, st.lam, False)
    al = ArcLength(run)
    func = None
    if a.stop_output:
        name, q = a.stop_output.rsplit(".", 1)
        node = next(o.node for o in s.scene.outputs if o.name == name)
        if q == "rot":
            rs = s.lay.node_rot[node]
            if len(rs) > 1:  # a mean: the controls take one unknown (the loader refuses it)
                raise SceneError(no_own_rotation(a.stop_output))
            i = rs[0]
            off = 0.0
        else:
            i = s.lay.node_dof[node] + (1 if q in ("y", "uy") else 0)
            n0 = s.scene.node(node)
            off = (n0.y if q == "uy" else n0.x) if q in ("ux", "uy") else -s.origin[q == "y"]
        func = (i, off)  # value = q[i] - off
    t = al.tangent(st, None)
    if a.factor_end < 0:
        t = -t
    ds = abs(a.factor_end) / max(a.steps, 1) / max(abs(t[-1]), 1e-3) * abs(t[-1])
    ds = max(ds, 1e-8)
    if func is not None and func[0] in set(s.free.tolist()):
        k = int(np.flatnonzero(s.free == func[0])[0])
        rate = abs(t[k])  # output change per unit arc length
        if rate > 0:
            ds = min(ds, abs(a.stop_value - (st.q[func[0]] - func[1])) / max(a.steps, 1) / rate)
    # two significant digits: the tangent carries its solve's round-off, which would move
    # every later sample of the path with the scene's encoding (as ``FEM.ds0``)
    ds = float(f"{ds:.2g}")
    ds_max, cuts = 2.0 * ds, 0
    found: list[dict] = []
    for _ in range(a.max_steps):
        z0 = al._z(st)
        try:
            new = al.corrector(z0, t, ds, st)
            easy = al.easy_at is not None and al.easy_at <= EASY_ITERATIONS
        except SolveError:
            cuts += 1
            ds /= 2.0
            if cuts > 12:
                raise SolveError(f"arc-length step cut 12 times near factor {st.lam:.6g}") from None
            continue
        dz = al._z(new) - z0
        off = al._dot(dz, t) ** 2 < JUMP_COS**2 * al._dot(dz, dz) * al._dot(t, t)
        if (off or new.iterations > JUMP_ITERATIONS) and ds > 1e-6 * ds_max:
            ds /= 2.0  # the corrector landed off the step's direction: a snap may be jumped
            continue
        t_new = al.tangent(new, t)
        if al._dot(t_new, t) < 0.98 and ds > 1e-6 * ds_max:
            ds /= 2.0  # the tangent turned too far in one step: a branch may have been jumped
            continue
        cuts = 0
        done = False
        if func is not None:
            v0, v1 = st.q[func[0]] - func[1], new.q[func[0]] - func[1]
            if (v0 - a.stop_value) * (v1 - a.stop_value) <= 0 and v0 != v1:
                k = int(np.flatnonzero(s.free == func[0])[0])
                w = (a.stop_value - v0) / (v1 - v0)
                new = al.corrector(z0, t, w * ds, st, row=(k, a.stop_value + func[1]))
                done = True
        if not done and (st.lam - a.factor_end) * (new.lam - a.factor_end) <= 0 < abs(
            new.lam - st.lam
        ):
            w = (a.factor_end - st.lam) / (new.lam - st.lam)
            guess = State(st.q + w * (new.q - st.q), st.mu + w * (new.mu - st.mu), a.factor_end)
            new = run.solver.newton(guess)
            done = True
        if not done and t[-1] * t_new[-1] < 0:  # a load-factor extremum inside the step
            _limit_point(run, al, z0, t, ds, st, t_new[-1], found)
        t = al.tangent(new, t) if done else t_new
        st = new
        run.record(st, st.lam, False)
        if done:
            break
        if easy:
            ds = min(1.5 * ds, ds_max)
    else:
        raise SolveError(f"stop criterion not reached within {a.max_steps} steps")
    run.extras["limit_points"] = found


def _limit_point(
    run: object,
    al: ArcLength,
    z0: np.ndarray,
    t: np.ndarray,
    ds: float,
    st: State,
    g1: float,
    found: list,
) -> None:
    """Refine the extremum of the load factor between ``st`` and the arc length ``ds`` along
    ``t``: zero of d lam / ds (tangent's lam component) by Illinois regula falsi on the arc
    length; the refined state is recorded as a step (``info["limit_point"] = +1 max /
    -1 min``, ``stable`` None: marginal) and listed in ``found``.  Left unrefined (nothing
    recorded) if it fails."""
    a, b, ga, gb = 0.0, ds, float(t[-1]), float(g1)
    kind = 1.0 if ga > 0 else -1.0
    side, best = 0, None
    try:
        for _ in range(30):
            x = (a * gb - b * ga) / (gb - ga)
            cand = al.corrector(z0, t, x, st)
            g = float(al.tangent(cand, t)[-1])
            best = cand
            if abs(g) <= 1e-10 or abs(b - a) <= 1e-12 * ds:
                break
            if g * gb > 0:
                b, gb = x, g
                ga = ga / 2 if side == -1 else ga
                side = -1
            else:
                a, ga = x, g
                gb = gb / 2 if side == 1 else gb
                side = 1
    except SolveError:
        best = None
    if best is None:
        return
    run.record(best, best.lam, False)
    run.steps[-1].info["limit_point"] = kind
    # the tangent stiffness is singular there by construction (d lam / ds = 0): the sign of
    # its lowest eigenvalue is round-off (it differed between drawings): no verdict
    run.steps[-1] = replace(run.steps[-1], stable=None)
    found.append(
        {
            "factor": float(best.lam),
            "kind": "max" if kind > 0 else "min",
            "outputs": dict(run.steps[-1].outputs),
        }
    )
