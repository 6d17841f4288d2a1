"""Arc-length continuation (Crisfield's cylindrical constraint) through limit points and
snap-backs.

References: Crisfield, Non-linear FE analysis of solids and structures, Vol. 1 (1991), Ch. 9;
Feng, Peric & Owen (1996) for the predictor sign; Ritto-Correa & Camotim (2008) for root
choice.
"""

from __future__ import annotations

import math

import numpy as np

from fem_reference.statics.newton import Options, Scaler, SolveError, State, factor_at, ops, vdot
from fem_reference.system import DiscreteSystem

EASY_RES = 1e3  # ``step`` sizes the next step by the iterations to this x the tolerance
# a corrector that needs more iterations to EASY_RES x tol has left the path's neighbourhood
# (Lee's frame under a follower load: 11 and 15 iterations, each landing elsewhere on the path,
# which it then traced backwards to factor -16000): the step is cut as on a failure
JUMP_ITERATIONS = 8


class ArcLength:
    """Crisfield's cylindrical arc-length continuation in the metric ``system.weights``.

    ``step()`` returns the next converged ``State`` on the path (cutting ``ds`` on failure).
    The predictor sign follows the previous increment (Feng et al.), so limit points and
    snap-backs are passed; of the two corrector roots the one closest in direction to the
    current increment is taken, a complex pair falls back to the linearised (normal-plane)
    correction.  Convergence: force residual within tolerance and the energy of the next
    correction ``|dr . r| <= etol e0`` (or a correction at round-off level), so the tangent
    is formed at every corrector point including the last.
    """

    def __init__(
        self,
        system: DiscreteSystem,
        st: State,
        ds: float,
        opts: Options,
        direction: float = 1.0,
        ds_max: float | None = None,
    ):
        self.sys, self.opts, self.sc = system, opts, Scaler.of(system)
        self.ops = ops(system)
        self.u, self.lam, self.ds = st.u.copy(), st.lam, ds
        self.ds_max = ds_max if ds_max is not None else 1e3 * ds
        self.ds_min = ds * 1e-7
        self.fscale = float(system.force_scale())
        rf = getattr(system, "residual_floor", None)
        self.floor = float(rf(centred=True)) if callable(rf) else 0.0
        self.du_prev: np.ndarray | None = None
        self.direction = direction

    def _dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return vdot(a * self.sc.w, b)

    def _try(self, ds: float) -> State:
        sys, opts, o = self.sys, self.opts, self.ops
        ev = o.evaluate(self.u, self.lam)
        r = ev.r
        lu = factor_at(o, ev)
        t = lu.solve(sys.external(self.u))
        tn = math.sqrt(max(self._dot(t, t), 1e-300))
        sgn = (
            self.direction
            if self.du_prev is None
            else math.copysign(1.0, self._dot(t, self.du_prev) or self.direction)
        )
        dl = sgn * ds / tn
        Du, Dl = dl * t - lu.solve(r), dl
        e0, rn = 1e-300, math.inf
        self.easy_at = opts.max_iter  # the first iteration at EASY_RES x tol (``step``)
        self.easy = float(opts.max_iter)  # ... interpolated between iterations
        for it in range(1, opts.max_iter + 1):
            u, lam = self.u + Du, self.lam + Dl
            ev = o.evaluate(u, lam)
            r, last = ev.r, rn
            rn = self.sc.rnorm(r)
            if not np.isfinite(rn):
                raise SolveError("non-finite residual")
            # the tolerance with its floor measured from the nodes' centroid (the floor itself
            # grows with the coordinates' size: a column drawn 3.7 off the origin had twice it)
            easy = EASY_RES * max(opts.rtol * self.fscale * max(abs(lam), 1.0), self.floor)
            if self.easy_at == opts.max_iter and rn <= easy:
                self.easy_at = it
                self.easy = _crossing(it, last, rn, easy)
            lu = factor_at(o, ev)
            dr = -lu.solve(r)
            if (
                it > 1
                and rn <= self.sc.ftol(lam, opts)
                and (abs(vdot(dr, r)) <= opts.etol * e0 or self.sc.unorm(dr) < 1e-12)
            ):
                return State(u, lam, it, 0, rn, lu, ev=ev)
            dt = lu.solve(sys.external(u))
            a = self._dot(dt, dt)
            b = 2.0 * self._dot(Du + dr, dt)
            c = self._dot(Du + dr, Du + dr) - ds * ds
            disc = b * b - 4.0 * a * c
            if disc >= 0.0 and a > 0.0:
                q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
                roots = [q / a, c / q] if q != 0.0 else [0.0]
                best = max(roots, key=lambda x: self._dot(Du + dr + x * dt, Du))
            else:  # normal-plane (Ramm) correction
                den = self._dot(Du, dt)
                if den == 0.0:
                    raise SolveError("arc-length: degenerate corrector")
                best = -self._dot(Du, dr) / den
            step = dr + best * dt
            if it == 1:
                e0 = max(abs(vdot(step, r)), 1e-300)
            Du, Dl = Du + step, Dl + best
            if self.sc.unorm(Du) > 10.0 * ds + 1e-300:
                raise SolveError("arc-length corrector diverged")
        raise SolveError("arc-length corrector did not converge")

    def step(self) -> State:
        """Next converged point (raises ``SolveError`` when ``ds`` falls below ds_min)."""
        cuts = 0
        while True:
            try:
                st = self._try(self.ds)
                if self.easy_at > JUMP_ITERATIONS and self.ds > 1e3 * self.ds_min:
                    raise SolveError(f"corrector took {st.iterations} iterations: off the path")
                break
            except SolveError as err:
                cuts += 1
                self.ds *= 0.25
                if self.ds < self.ds_min:
                    raise SolveError(
                        f"arc-length stalled at factor {self.lam:.6g}: {err}"
                    ) from None
        self.du_prev = st.u - self.u
        self.u, self.lam = st.u, st.lam
        # the iterations to EASY_RES x tol, and one to converge: counted above the residual's
        # round-off floor, where the count to convergence itself (its energy test at
        # round-off) moved with the encoding (DAD-eppo's arch renumbered: 4 iterations
        # instead of 5 at one step, every later sample elsewhere)
        # Interpolated between iterations and rounded to two significant digits: an integer
        # count flips where a residual sits at the threshold, and a perfect column traced
        # to a tip rotation, mirrored, was sampled elsewhere from its 10th step on
        ratio = math.sqrt(self.opts.arc_iter_goal / (self.easy + 1))
        self.ds = min(float(f"{self.ds * min(max(ratio, 0.5), 2.0):.2g}"), self.ds_max)
        st.cuts = cuts
        return st


def _crossing(it: int, before: float, at: float, level: float) -> float:
    """Where the residual crossed ``level``, in iterations: ``it`` where it got there at once,
    else between ``it - 1`` (residual ``before``) and ``it`` (``at``), geometrically -- so the
    count moves continuously with the residuals, and agrees with ``it`` at either end.  A
    residual below ``level / EASY_RES`` counts as that: below it the residual is round-off,
    which differs between drawings of one scene."""
    at = max(at, level / EASY_RES)
    if it == 1 or not before > level or before <= at:
        return float(it)
    return it - 1 + math.log(before / level) / math.log(before / at)
