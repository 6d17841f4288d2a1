"""Stability loss along a load-controlled FE path: detection, critical factor, branch switch.

Load control follows whichever equilibrium branch it starts on.  A perfect structure that
reaches a *bifurcation* (a straight column at its Euler load) stays on the fundamental branch,
which is unstable beyond it, and Newton converges there happily.  ``Watch`` checks every
reported state of ``Runner.run_load`` (``models.py``):

1. *Detection*: the scaled symmetric tangent ``D K D`` (``D`` = length scale on translations,
   see ``static.stability``) turns indefinite between two reported factors while load control
   passed without a snap (a limit point is crossed by arc-length and reported as a snap).
2. *Critical factor*: the lowest eigenvalue of ``D K D`` along the fundamental branch is
   zero at ``lam_c`` (Brent's method; each evaluation re-solves the fundamental branch by
   Newton at fixed ``lam``).
3. *Kind*: with ``phi`` the critical mode, ``|phi . f| / (|phi| |f|) < KIND_TOL`` is a
   bifurcation (the load does no work on the mode), otherwise a limit point.
4. *Switch* (bifurcations only): the mode is imposed with amplitude ``SWITCH_AMPLITUDE * L``
   on the DOF where it is largest (Newton bordered by that displacement constraint, the load
   factor free), for both signs of the mode; of the stable results the one with the lower
   total potential is kept (an imperfect structure's own branch).  Two distinct states of
   equal energy are a perfect structure's mirror branches: none is picked, the path stays
   on the fundamental branch (``_stay_tied``).  When the fundamental path cannot be
   re-solved inside the bracket (an imperfect near-bifurcation that load control crossed
   onto the complementary branch) the critical factor is interpolated from the eigenvalues
   and the switch starts from the last stable state.  That is a
   displacement-controlled imperfection of 1e-2 L, independent of the mesh and removed as
   soon as the state is reached (the path is then followed by plain load control, which
   carries no imperfection).  A rising branch (supercritical) is followed by arc-length to
   the target factor.  On a falling one (subcritical: no stable state next to the critical
   one) the structure snaps: where it settles at the target factor is found by energy
   descent from the displaced critical state (``descent.settle``, as the reduced models land
   their snaps), and the snap is reported at the critical factor (``_jump``).  When no
   stable state is reached the path goes on on the unstable fundamental branch and says so.

5. *Natural path* (``natural``): when the fundamental path cannot be re-solved inside the
   bracket, the load step is retraced by arc-length from its last stable state; a traced
   path that stays stable with the factor rising to the target is the smooth path of an
   imperfect structure whose knee load control jumped (onto the complementary branch): a
   step too large, not a critical point, and its state at the target is kept.
6. *Snaps* (``snap``): a load step that moved ``JUMP_RATIO`` x more per unit factor than the
   one before (or passed a limit point by arc-length), or that ended unstable where the
   fundamental path cannot be re-solved (``_snap_limit``), is retraced likewise; where the
   traced factor turns back, the limit point is refined, the structure lands by energy
   descent from it at the step's factor (wherever Newton converged is not an answer: one
   mesh on the far branch, the next on an intermediate one), and the limit point and the
   snap (states before and after at its factor) are reported.  A path analysis's step that
   went over a fold (``_fold_passed``) is traced on, not branched off.

Reported in ``extras['critical_points']``: factor, kind, n_neg after it, the mode's largest
component and whether the branch was switched (snaps: ``from`` / ``to`` outputs).

Reference: Wriggers, Nonlinear Finite Element Methods (2008), Sec. 7.4 (stability points,
branch switching by eigenvector perturbation); Riks (1979) for the kind test.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq

from fem_reference.statics import static as S
from fem_reference.statics.conditioning import factor_roundoff
from fem_reference.statics.descent import lowest_mode
from fem_reference.statics.inertia import jacobi_verdict, state_stability
from fem_reference.statics.switch import BranchSwitch

KIND_TOL = 1e-3
NATURAL_STEPS = 32  # arc-length steps (to start with) retracing a load step that lost stability
TRACE_STEPS = 8 * NATURAL_STEPS  # the most arc-length steps spent retracing one load step
JUMP_RATIO = 4.0  # a load step moving this much more than the previous one (per unit factor)
NATURAL_SAME = 1e-6  # a retraced state this close (x the step's move) is load control's own
# Newton failing inside Brent's bracket (next to a perfect structure's bifurcation the
# tangent is singular to round-off; bistable-toggle's replay: 7e-9 from it) still locates the
# critical factor when the eigenvalue's secant across the bracket lands this close (x the
# factor) to one of its ends
LOCATE_TIGHT = 1e-6


def is_conservative(system: object) -> bool:
    """False when follower loads make the tangent unsymmetric (no static stability test)."""
    fol = getattr(system, "fol_dofs", None)
    return fol is None or fol.shape[0] == 0


def _narrowest(points: list[tuple]) -> tuple[tuple, tuple] | None:
    """Of evaluations ``(lam, eigenvalue, ...)``, the two nearest the eigenvalue's zero from
    either side -- the least positive and the largest non-positive -- or None when one side
    has none."""
    stable = [t for t in points if t[1] > 0.0]
    unstable = [t for t in points if t[1] <= 0.0]
    if not (stable and unstable):
        return None
    return min(stable, key=lambda t: t[1]), max(unstable, key=lambda t: t[1])


class Critical(NamedTuple):
    """A stability loss found by ``Watch.locate``: its factor, the critical state (last
    stable one where not located), the mode, whether the factor was located on the
    re-solved fundamental path (else interpolated) and its round-off bound (located only,
    ``conditioning.factor_roundoff``)."""

    factor: float
    state: S.State
    mode: np.ndarray
    located: bool
    roundoff: float | None


class Watch(BranchSwitch):
    """Stability watch of one load-controlled FE run (see module docstring)."""

    def __init__(self, system: object, opts: S.Options):
        self.sys, self.opts = system, opts
        self.points: list[dict] = []
        self.note = ""
        self.active = is_conservative(system)
        self._cache: tuple = (None, None, None)  # (id, stability dict, state kept alive)
        self.dense_max = 60
        self._fast: tuple = (None, None)  # (state, jacobi_verdict) of the last fast check
        self._step: tuple | None = None  # (|du|_W, |dlam|) of the last load step
        # the last switch found two mirror branches of equal energy: their outputs, or False
        self.tied: list | bool = False
        # a path analysis's stop criterion (value of a state, stop value), which may tell two
        # mirror branches apart (``BranchSwitch._toward_stop``)
        self.stop: tuple | None = None

    def _eig(self, st: S.State, scale: np.ndarray | None = None) -> float:
        return lowest_mode(self.sys, st.u, st.lam, scale)[0]

    def stable(self, st: S.State) -> bool:
        """Positive definiteness of the symmetric tangent: Cholesky (LAPACK ``dpbtrf``) of
        its Jacobi-scaled band (well conditioned even for EA L^2/EI ~ 1e8, where the
        length-scaled matrix lets round-off pass an indefinite one; ``inertia.jacobi_verdict``,
        from the solver's own evaluation of the state); ``static.stability`` when there is
        no band fast path.  The band and verdict are kept for ``stability`` of the same
        state (the runner's record)."""
        if self._cache[2] is st:
            return bool(self._cache[1]["jacobi_pd"] or self._cache[1]["stable"])
        if self._fast[0] is st:  # the previous step's current state
            pre = self._fast[1]
        else:
            pre = jacobi_verdict(self.sys, st)
            if pre[0] is None:
                return bool(self.stability(st)["stable"])
            self._fast = (st, pre)
        # a failed Cholesky is no verdict on a neutral mode (a pinned root's rigid swing at
        # zero load, eigenvalue -3e-11 of round-off): the eigen test's tolerance decides, as
        # in the state's record -- else the watch skipped the step from it and the beam
        # swung up onto its unstable branch or down by round-off
        return pre[1] is not None or bool(self.stability(st)["stable"])

    def stability(self, st: S.State) -> dict:
        """``inertia.state_stability`` of ``st`` (cached for the last state asked: the runner
        reports the same dict instead of computing it twice)."""
        if self._cache[0] != id(st) or self._cache[2] is not st:
            pre = self._fast[1] if self._fast[0] is st else None
            res = state_stability(self.sys, st, self.dense_max, pre=pre)
            self._cache = (id(st), res, st)
        return self._cache[1]

    def check(self, prev: S.State, cur: S.State, target: float, path: bool = False) -> S.State:
        """``cur`` if the path stayed stable (or cannot be judged); otherwise the state at
        ``target`` on the stable branch after the critical point, or ``cur`` with
        ``self.note`` saying why it is unstable.  ``path``: an arc-length step of a path
        analysis, where limit points are traced, not notes."""
        if not self.active or self.note:
            return cur
        if not self.stable(prev) or self.stable(cur):
            return cur
        if cur.info.get("snap"):
            return cur  # a limit point crossed by arc-length: the snapped-to state is judged
        if path and self._fold_passed(prev, cur) and self.stability(cur).get("n_neg", 1) <= 1:
            return cur  # arc-length went over a limit point (alone) within the step: traced
        found = self.locate(prev, cur)
        located = found.located
        # not re-solvable inside the bracket: load control may have jumped the knee of an
        # imperfect structure's smooth path onto the complementary branch
        smooth = None if located or path else self.natural(prev, cur, target)
        if smooth is not None:
            return smooth
        snapped = None if located or path else self._snap_limit(prev, cur, target)
        if snapped is not None:
            return snapped
        return self._act(found, cur, target, path)

    def _fold_passed(self, prev: S.State, cur: S.State) -> bool:
        """Did the traced step ``prev -> cur`` (factor higher at ``cur``) pass over a limit
        point?  Then the path's factor is falling at ``cur`` in the direction of travel: the
        tangent ``K^-1 f`` there points against the step (W metric).  A bifurcation leaves the
        fundamental path's factor rising: the stability loss it causes is a branch point (one
        passed in the same step as a fold leaves two negative eigenvalues: ``check`` locates it)."""
        sysm = self.sys
        try:
            t = S.tangent_lu(sysm, cur.u, cur.lam).solve(sysm.external(cur.u))
        except S.SolveError:
            return False
        sc = S.Scaler.of(sysm)
        return float(np.dot(t * sc.w, cur.u - prev.u)) < 0.0

    def snap(self, prev: S.State, cur: S.State) -> S.State:
        """Record a snap passed within the load step ``prev -> cur``: a limit point that load
        control jumped over (or arc-length passed, ``info['snap']``).  A step that moved more
        than ``JUMP_RATIO`` x the previous one per unit factor is retraced by arc-length from
        ``prev``; where its factor turns back, the limit point is refined (``refine_extremum``)
        and the state at that factor on the branch load control landed on is solved:
        ``{"kind": "snap", "factor", "from": outputs at the limit point, "to": outputs on the
        landed branch at the same factor, "switched": True}`` (the path goes on from there).

        Returns the state the path goes on from: ``cur``, or -- where the retraced path
        reaches ``cur``'s factor without turning back and stays stable (``natural``) but
        ends elsewhere -- that state: Newton jumped from the knee of an imperfect structure's
        natural path onto a stable part of the complementary branch (an imperfect column
        just past its Euler load, bending against its imperfection), a step too large."""
        if not self.active:
            return cur
        sc = S.Scaler.of(self.sys)
        du = sc.unorm(cur.u - prev.u)
        dl = abs(cur.lam - prev.lam)
        last, self._step = self._step, (du, dl)
        jumped = last is not None and du * last[1] > JUMP_RATIO * last[0] * dl
        if not (jumped or cur.info.get("snap")):
            return cur
        lim = self.limit(prev, cur)
        if lim is None:
            smooth = self.natural(prev, cur, cur.lam)
            if smooth is None or sc.unorm(smooth.u - cur.u) <= NATURAL_SAME * du:
                return cur
            self._step = (sc.unorm(smooth.u - prev.u), dl)
            return smooth
        land = self._settle_after(lim, cur)
        if land is not cur:
            self._step = (sc.unorm(land.u - prev.u), dl)
        return land

    def _trace(self, prev: S.State, cur: S.State):  # noqa: ANN202 - a generator of S.State
        """States of the path traced by arc-length from ``prev`` towards ``cur.lam``: initial
        step ``1 / NATURAL_STEPS`` of the load step's tangent increment (at least of the
        distance to ``cur`` over ``NATURAL_STEPS**2``: a path that does not move under load),
        at most ``TRACE_STEPS`` steps; a failed step ends it."""
        sysm, sc = self.sys, S.Scaler.of(self.sys)
        sgn = 1.0 if cur.lam >= prev.lam else -1.0
        try:
            t = S.tangent_lu(sysm, prev.u, prev.lam).solve(sysm.external(prev.u))
            ds = sc.unorm(t) * abs(cur.lam - prev.lam) / NATURAL_STEPS
            ds = max(ds, sc.unorm(cur.u - prev.u) / NATURAL_STEPS**2)
            arc = S.ArcLength(sysm, prev, ds, self.opts, direction=sgn, ds_max=max(8 * ds, 0.1))
            for _ in range(TRACE_STEPS):
                yield arc.step()
        except S.SolveError:
            return

    def limit(self, prev: S.State, cur: S.State) -> S.State | None:
        """The first limit point on the path traced from ``prev`` towards ``cur.lam`` (None
        if the factor reaches it monotonically, tracing fails, or the factor turns back
        outside the step: load control crossed the point within it, and a trace started on a
        singular tangent -- a pinned root at zero load -- ran off to factor -1e14)."""
        sgn = 1.0 if cur.lam >= prev.lam else -1.0
        lo, hi = sorted((prev.lam, cur.lam))
        slack = 1e-12 * max(abs(lo), abs(hi), 1.0)

        def inside(lam: float) -> bool:
            return lo - slack <= lam <= hi + slack

        a, b = None, prev
        for c in self._trace(prev, cur):
            if sgn * (c.lam - b.lam) < 0.0 and a is not None:
                if not inside(b.lam):
                    return None
                try:
                    lim = S.refine_extremum(self.sys, a, b, c, self.opts)
                except S.SolveError:
                    return None
                return lim if inside(lim.lam) else None
            if sgn * (c.lam - cur.lam) >= 0.0:
                return None
            a, b = b, c
        return None

    def natural(self, prev: S.State, cur: S.State, target: float) -> S.State | None:
        """The state at ``target`` on the path traced from the stable ``prev``, if that path
        stays stable with the factor rising monotonically: load control jumped across the
        knee of an imperfect structure's natural path onto the complementary branch ``cur``
        (a step too large, not a critical point).  None when the traced path loses
        stability or turns back (a bifurcation or a limit point: judged as before)."""
        sgn = 1.0 if target >= prev.lam else -1.0
        last, its = prev, 0
        for st in self._trace(prev, cur):
            its += st.iterations
            if sgn * (st.lam - last.lam) <= 0.0 or not self.stable(st):
                return None
            if sgn * (st.lam - target) >= 0.0:
                w = (target - last.lam) / (st.lam - last.lam)
                try:
                    land = S.newton(self.sys, last.u + w * (st.u - last.u), target, self.opts)
                except S.SolveError:
                    return None
                land.iterations += its
                return land if self.stable(land) else None
            last = st
        return None

    def _snap_limit(self, prev: S.State, cur: S.State, target: float) -> S.State | None:
        """Load control crossed a limit point of the path from the stable ``prev`` (the
        fundamental path cannot be re-solved inside the bracket, and the path traced from
        ``prev`` turns back: an imperfect structure's snap, not a bifurcation) and landed on
        the unstable ``cur``.  The limit point is refined, the structure snaps there: the
        stable state at ``target`` it settles at by energy descent from the limit state is
        returned, and the limit point and the snap (states before and after at its factor)
        are recorded.  None when the traced path does not turn back or the descent fails."""
        lim = self.limit(prev, cur)
        if lim is None:
            return None
        land = self._settle_after(lim, cur, target)
        return None if land is cur else land

    def _settle_after(self, lim: S.State, cur: S.State, target: float | None = None) -> S.State:
        """Record the snap at the limit point ``lim`` and return where the structure settles
        at ``target`` (default ``cur.lam``): energy descent from ``lim`` at that factor, the
        first stable basin a damped structure falls into (not wherever Newton happened to
        converge: a far branch on one mesh, an intermediate one on the next); ``cur`` when
        the descent fails.  Recorded: the limit point and the snap, with the states before
        (``lim``) and after (the landing brought back to the limit factor)."""
        sysm = self.sys
        target = cur.lam if target is None else target
        try:
            land = self._descend(lim.u, target)
        except S.SolveError:
            land = cur
        try:
            to = S.newton(sysm, land.u, lim.lam, self.opts)
        except S.SolveError:
            to = land
        point = {"factor": float(lim.lam), "switched": True}
        self.points.append({**point, "kind": "limit", "located": True})
        self.points.append({**point, "kind": "snap", "from": sysm.outputs(lim.u)})
        self.points[-1]["to"] = sysm.outputs(to.u)
        if land is not cur:  # the step snapped (and, past an unstable landing, switched)
            land.info = {**cur.info, **land.info, "snap": 1.0, "branch_switch": 1.0}
        return land

    def locate(self, prev: S.State, cur: S.State) -> Critical:
        """The ``Critical`` point (factor, state, mode, located, roundoff) of the stability
        loss between a stable ``prev`` and an unstable ``cur`` on one branch (module doc);
        ``roundoff``: how far round-off alone moves a located ``lam_c``
        (``conditioning.factor_roundoff``; None when not located)."""
        sysm, opts = self.sys, self.opts

        def fundamental(lam: float) -> S.State:
            w = (lam - prev.lam) / (cur.lam - prev.lam)
            return S.newton(sysm, prev.u + w * (cur.u - prev.u), lam, opts)

        seen: list[tuple[float, float, S.State]] = []  # Brent's evaluations (lam, eig, state)

        def eig(lam: float) -> float:
            st = fundamental(lam)
            seen.append((lam, self._eig(st, scale), st))
            return seen[-1][1]

        scale = lowest_mode(sysm, prev.u, prev.lam)[2]  # one Jacobi scaling for the bracket
        try:
            lam_c = brentq(eig, prev.lam, cur.lam, xtol=1e-12 * max(abs(cur.lam), 1.0), rtol=1e-13)
            crit = fundamental(lam_c)
        except S.SolveError:
            # Newton failed next to the critical point (its tangent singular there to
            # round-off) after Brent came close: the eigenvalue's secant through the two
            # evaluations of least |eigenvalue| (across the root or, when Newton failed on
            # one side, extrapolated from the other: fem-auto's 16-element Ex. 3 came within
            # 3e-8 from the stable side only and was interpolated across the whole step, 3e-5
            # off), if it lands that close to one of them -- evaluations Brent solved inside
            # the step: the step's own start or end has not closed in on anything (a pinned
            # root's bifurcation at factor ~0 would be "located" next to the start)
            inner = [t for t in seen if t[0] not in (prev.lam, cur.lam)]
            if len(inner) < 2:
                return self._interpolated(prev, cur, scale, seen)
            # across the root: interpolated; else the two nearest it, extrapolated
            pair = _narrowest(inner) or sorted(inner, key=lambda t: abs(t[1]))[:2]
            (la, ea, sa), (lb, eb, _) = sorted(pair, key=lambda t: abs(t[1]))
            if ea == eb:
                return self._interpolated(prev, cur, scale, seen)
            lam_c = la + (lb - la) * ea / (ea - eb)
            if not abs(lam_c - la) <= LOCATE_TIGHT * max(abs(cur.lam), 1.0):
                return self._interpolated(prev, cur, scale, seen)
            crit = sa
        except ValueError:
            return self._interpolated(prev, cur, scale, seen)
        _, phi, _ = lowest_mode(sysm, crit.u, lam_c, scale)
        return Critical(
            float(lam_c), crit, phi, True, factor_roundoff(sysm, prev, crit, lam_c, phi)
        )

    def _interpolated(
        self, prev: S.State, cur: S.State, scale: np.ndarray, seen: list | None = None
    ) -> Critical:
        """``locate``'s answer where the fundamental path cannot be re-solved inside the
        bracket: an imperfect near-bifurcation (load control jumped onto the complementary
        branch), or Newton failing next to the critical factor.  Critical factor by linear
        interpolation of the eigenvalue across the narrowest bracket the re-solved states
        ``seen`` (lam, eigenvalue, state) give (across the whole step, DAS-2D Ex. 3's replay
        in m was 1e-6 off the same scene in mm); the switch starts from the last stable
        state with the mode of the unstable one."""
        ep, ec = self._eig(prev, scale), self._eig(cur, scale)
        pts = [(prev.lam, ep), (cur.lam, ec)] + [t[:2] for t in seen or ()]
        (la, ea), (lb, eb) = _narrowest(pts) or pts[:2]
        lam_c = la + (lb - la) * ea / (ea - eb) if ea != eb else 0.5 * (la + lb)
        _, phi, _ = lowest_mode(self.sys, cur.u, cur.lam, scale)
        return Critical(float(lam_c), prev, phi, False, None)

    def _act(self, found: Critical, cur: S.State, target: float, path: bool) -> S.State:
        """Classify the critical point ``found`` by ``locate`` and switch (``check``)."""
        lam_c, crit, phi, located, roundoff = found
        sysm = self.sys
        f = np.asarray(sysm.external(crit.u), dtype=float)
        work = abs(float(phi @ f)) / max(np.linalg.norm(phi) * np.linalg.norm(f), 1e-300)
        kind = "bifurcation" if work < KIND_TOL else "limit"
        point = {"factor": float(lam_c), "kind": kind, "load_work": work, "switched": False}
        point["located"] = located
        if roundoff is not None:
            point["factor_roundoff"] = roundoff
        if kind != "bifurcation":
            if not path:  # (a path analysis refines its limit points itself)
                self.points.append(point)
                self.note = f"stability lost at a limit point (factor {lam_c:.8g}) not crossed"
            return cur
        self.points.append(point)
        if path:
            return self._branch_off(crit, phi, point, cur)
        new = self._switch(crit, phi, lam_c, target)
        if self.tied:
            return self._stay_tied(point, cur)
        if new is None:
            self.note = (
                f"bifurcation at factor {lam_c:.8g}: no stable branch next to it "
                "(subcritical); the path continues on the unstable fundamental branch"
            )
            return cur
        point["switched"] = True
        self._jump(crit, new, point)
        return new
