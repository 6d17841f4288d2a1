"""Branch switching at a located bifurcation of a load-controlled FE path (the *Switch*
step of ``bifurcation.Watch``, whose module docstring states the rules): the state on the
branch along the critical mode (``branch_offset``), the landings of both signs of the mode,
the tie between a perfect structure's mirror branches, the snap a falling branch makes, and
the arc-length trace along a rising one.

Reference: Wriggers, Nonlinear Finite Element Methods (2008), Sec. 7.4 (branch switching by
eigenvector perturbation).
"""

from __future__ import annotations

import numpy as np

from fem_reference.statics import static as S
from fem_reference.statics.descent import settle

SWITCH_AMPLITUDE = 1e-2
# two rising branches whose factors at the switch amplitude agree to this fraction of their
# rise are mirror images (a perfect structure: equal to round-off, 1e-13 of the rise on a
# column; an asymmetric bifurcation differs at first order in the amplitude)
TIE_FACTOR = 1e-8


def branch_offset(
    sysm: object, crit: S.State, phi: np.ndarray, opts: S.Options, sign: float = 1.0
) -> S.State:
    """The state on the branch through the critical state ``crit`` along its mode ``phi``
    whose largest weighted mode component is moved by ``sign`` x ``SWITCH_AMPLITUDE`` (of
    the length scale, or rad) and held there (displacement control: its factor tells
    whether the branch rises or falls); ``info["predictor"]``: the displaced critical state
    it was solved from.  Raises ``SolveError``."""
    i = int(np.argmax(np.abs(phi) * np.sqrt(S.Scaler.of(sysm).w)))
    a = sign * SWITCH_AMPLITUDE * (1.0 if sysm.is_rotation[i] else sysm.length_scale())
    u0 = crit.u + a * phi / phi[i]
    off = S.newton(sysm, u0, crit.lam, opts, constraint=(i, 1.0, crit.u[i] + a))
    off.info = {**off.info, "predictor": u0}
    return off


class BranchSwitch:
    """The switch half of ``bifurcation.Watch`` (its ``sys``, ``opts``, ``points``, ``note``,
    ``tied``, ``stable`` and ``_eig``)."""

    def _stay_tied(self, point: dict, cur: S.State) -> S.State:
        """A bifurcation whose two branches land on distinct states of equal energy (``tied``
        by ``_switch``): a perfect structure's mirror branches.  The mirrored scene is the
        same scene, so a branch picked by any rule drawn from it (the mode's sign) would be
        the other branch once the mirrored answer is mirrored back: the answer would depend
        on how the scene is drawn.  The path stays on the fundamental branch (the one
        equilibrium the scene's symmetry allows, unstable beyond the point) and the note says
        so; the two branch states at the step's factor are kept in the point (``branches``):
        an imperfection picks one."""
        point["tied"], point["branches"] = True, self.tied
        self.tied = False
        self.note = (
            f"bifurcation at factor {point['factor']:.8g} into two mirror-image branches of "
            "equal energy (a perfect structure: no rule drawn from the scene picks one); the "
            "path stays on the fundamental branch, unstable beyond it; an imperfection picks "
            "a branch"
        )
        return cur

    def _jump(self, crit: S.State, new: S.State, bif: dict) -> None:
        """A switch that lands on a stable state far from the critical one at the factor
        ``lam_c`` of the bifurcation point ``bif`` (a subcritical bifurcation: the structure
        leaves it dynamically, DAS-2D Ex. 3's unguided shuttle) is also a snap, reported with
        the states before and after at ``lam_c`` as the elastica reports it.  A
        supercritical branch (a buckled column) returns to the critical state at ``lam_c``:
        no snap."""
        sysm, lam_c = self.sys, bif["factor"]
        try:
            to = S.newton(sysm, new.u, lam_c, self.opts)
        except S.SolveError:
            return
        moved = np.abs(to.u - crit.u)[~np.asarray(sysm.is_rotation, dtype=bool)]
        if np.max(moved, initial=0.0) <= SWITCH_AMPLITUDE * sysm.length_scale():
            return
        if not self.stable(to):
            return
        out = sysm.outputs
        point = {k: bif[k] for k in ("factor", "factor_roundoff") if k in bif}
        point.update(kind="snap", switched=True, **{"from": out(crit.u), "to": out(to.u)})
        self.points.append(point)

    def _switch(
        self, crit: S.State, phi: np.ndarray, lam_c: float, target: float
    ) -> S.State | None:
        """Stable state at ``target`` on a branch through ``crit`` along ``phi`` (or None): a
        rising branch is followed by arc-length; from a falling one (subcritical) the
        structure snaps, and where it settles is found by energy descent."""
        sysm, opts = self.sys, self.opts
        sc = S.Scaler.of(sysm)
        found = []
        for sign in (1.0, -1.0):
            try:
                off = branch_offset(sysm, crit, phi, opts, sign)
                if off.lam < lam_c:  # the branch falls: no stable state next to the critical one
                    land = self._descend(off.info["predictor"], target)
                else:
                    land = self._follow(S.State(off.u, off.lam), target, sc.unorm(off.u - crit.u))
            except S.SolveError:
                continue
            if self._eig(land) > 0.0:
                land.info = {**land.info, "branch_switch": 1.0}
                found.append((self._potential(land), land))
        if not found:
            return None
        # the lower total potential: an imperfect structure's own branch (a tie on one
        # landing -> the first sign; two distinct landings of equal energy are a perfect
        # structure's mirror branches, which no rule drawn from the scene can tell apart:
        # ``tied`` keeps their outputs for ``_stay_tied``)
        best = min(found, key=lambda e: e[0])
        tol = 1e-12 * max(abs(found[0][0]), 1e-300)
        if abs(found[0][0] - best[0]) <= tol:
            if len(found) == 2 and abs(found[1][0] - found[0][0]) <= tol:
                apart = sc.unorm(found[1][1].u - found[0][1].u)
                if apart > 1e-6 * sc.unorm(found[0][1].u):
                    self.tied = [sysm.outputs(land.u) for _, land in found]
            return found[0][1]
        return best[1]

    def _branch_off(self, crit: S.State, phi: np.ndarray, point: dict, cur: S.State) -> S.State:
        """Path analyses: the first state on the bifurcated branch (mode amplitude
        ``SWITCH_AMPLITUDE``, the sign whose branch rises; the lower of two that rise
        unequally) if a branch rises (supercritical:
        arc-length traces on from it); a falling branch (subcritical) is not switched to --
        the traced path stays on the fundamental branch and the note says so.  Two distinct
        rising branches at the same factor are a perfect structure's mirror branches: tied
        (``_stay_tied``), as a load analysis ties them (the sign of the mode is how the scene
        is drawn: a perfect column's path took the + branch, its mirror image the other)."""
        sysm, sc = self.sys, S.Scaler.of(self.sys)
        offs = []
        for sign in (1.0, -1.0):
            try:
                offs.append(branch_offset(sysm, crit, phi, self.opts, sign))
            except S.SolveError:
                continue
        rising = [o for o in offs if o.lam > crit.lam]
        if len(rising) == 2:
            a, b = rising
            same = abs(a.lam - b.lam) <= TIE_FACTOR * max(abs(a.lam - crit.lam), 1e-300)
            if same and sc.unorm(a.u - b.u) > 1e-6 * sc.unorm(a.u):
                toward = self._toward_stop(crit, a, b)
                if toward is None:
                    self.tied = [sysm.outputs(o.u) for o in rising]
                    return self._stay_tied(point, cur)
                rising = [toward]
        off = min(rising, key=lambda o: o.lam) if rising else None
        if off is None:
            self.note = (
                f"bifurcation at factor {point['factor']:.8g} (subcritical or not followed): "
                "the traced path stays on the fundamental branch, unstable beyond it"
            )
            return cur
        point["switched"] = True
        off.info = {**off.info, "branch_switch": 1.0}
        return off

    def _toward_stop(self, crit: S.State, a: S.State, b: S.State) -> S.State | None:
        """Of two mirror branch states, the one on which the path's stop output moves towards
        its stop value (``stop``: (value of a state, stop value), set by a path analysis), or
        None when the stop output cannot tell them apart (it is symmetric: a column's axial
        shortening).  A stop output the mirror flips (a tip rotation to +1.5 rad) picks the
        branch by a rule drawn from the scene: mirrored, it picks the mirrored branch."""
        if self.stop is None:
            return None
        val, goal = self.stop
        va, vb, vc = val(a), val(b), val(crit)
        if abs(va - vb) <= 1e-6 * (abs(va - vc) + abs(vb - vc)):
            return None
        return a if abs(va - goal) < abs(vb - goal) else b

    def _descend(self, u0: np.ndarray, target: float) -> S.State:
        """The stable state at ``target`` the structure settles at when it leaves ``u0`` (the
        critical state displaced along its mode) under the load step's factor (where the
        fundamental branch is unstable: the descent cannot return to it), by energy
        descent (``descent.settle``), as the reduced models land their snaps."""
        return settle(self.sys, u0, target, self.opts, SWITCH_AMPLITUDE)

    def _potential(self, st: S.State) -> float:
        """Total potential U(u) - lam f . u of a state (dead loads: conservative)."""
        f = np.asarray(self.sys.external(st.u), dtype=float)
        return float(self.sys.strain_energy(st.u)) - st.lam * float(f @ st.u)

    def _follow(self, st: S.State, target: float, ds: float) -> S.State:
        """Arc-length along the new branch from ``st`` until the factor crosses ``target``,
        then Newton at ``target`` (load control from next to a bifurcation would fall back
        onto the fundamental branch: its predictor is dominated by the nearly singular mode)."""
        sysm, opts = self.sys, self.opts
        sgn = 1.0 if target >= st.lam else -1.0
        arc = S.ArcLength(sysm, st, ds, opts, direction=sgn, ds_max=max(20.0 * ds, 0.05))
        prev = st
        for _ in range(opts.arc_max_steps):
            cur = arc.step()
            if (prev.lam - target) * (cur.lam - target) <= 0.0:
                w = (target - prev.lam) / (cur.lam - prev.lam) if cur.lam != prev.lam else 1.0
                land = S.newton(sysm, prev.u + w * (cur.u - prev.u), target, opts)
                land.iterations += cur.iterations
                return S.unwrap(sysm, land, st.u, opts)  # not the turns the arc went round
            prev = cur
        raise S.SolveError(f"new branch did not reach factor {target:.6g}")
