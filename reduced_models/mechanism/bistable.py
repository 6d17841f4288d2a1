"""Bistable driver search (DAS-2D "Synthesis -> Bistable": find the bistable driver).

Given a scene and a candidate driver (``analysis.driver``: a link rotation or a node / slider
displacement), the energy sweep over the driver's range is searched for two stable equilibria
with an unstable one between (the driving force crosses zero falling, rising, falling).  For
the first such triple the summary ``bistable(run)`` reports

* ``stable`` = [first, second] stable driver coordinates, ``unstable`` = the one between;
* ``barrier`` = {"forward": Pi(unstable) - Pi(first), "backward": Pi(unstable) - Pi(second)}
  in total potential energy at the held loads (strain energy when the scene has no loads);
* ``critical`` = the switching loads: the extremum of the driving force between the first
  stable and the unstable position (``forward``, the force that pushes the mechanism over the
  barrier) and between the unstable and the second stable position (``backward``), each with
  the coordinate where it is reached, refined to dF/d(driver) = 0 (KKT tangent), not the
  grid value.

A scene that is not bistable along the driver gets ``{"bistable": False, "reason": ...}``.
``search(scene, name, spec_of)`` runs the sweep (the ``bistable`` synthesis goal); the
critical-load synthesis adds the same summary to its answer.  Without a driver,
``search_drivers`` tries every candidate driver, both senses (DAS-2D: "the module will check
if the mechanism has a driver that results in bistable behavior"): each rigid link's rotation
and each free node's x and y motion, and reports which are bistable and their barriers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from cases.schema import Driver, Member, Scene
from reduced_models.base import Solution, not_applicable
from reduced_models.mechanism import analyses
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.newton import SolveError, State
from reduced_models.mechanism.system import SceneError


def energy_scene(scene: Scene) -> Scene:
    """The scene's driver sweep as a plain ``energy`` analysis."""
    return replace(scene, analysis=replace(scene.analysis, kind="energy", synthesis=None))


class At:
    """Equilibria of a finished energy run at any driver coordinate (Newton from the nearest
    reported states, interpolated)."""

    def __init__(self, run: analyses.Run) -> None:
        self.r = run
        s = run.s
        base = float(s.q0[s.driver_dof]) if run.scene.analysis.driver.kind == "displacement" else 0
        self.apply = run.set_driver(s.driver_row, base, s.driver_scale)
        self.vals = np.array([st.factor for st in run.steps])
        self.d = run.solver.driver_index()

    def state(self, v: float) -> State:
        """Converged state with the driver at ``v`` (raises SolveError)."""
        x = self.vals
        sgn = 1.0 if x[-1] >= x[0] else -1.0
        k = int(np.clip(np.searchsorted(sgn * x, sgn * v), 1, len(x) - 1))
        a, b = self.r.states[k - 1], self.r.states[k]
        w = (v - x[k - 1]) / (x[k] - x[k - 1])
        guess = State(a.q + w * (b.q - a.q), a.mu + w * (b.mu - a.mu), a.lam)
        try:
            return self.r.solver.newton(self.apply(guess, v))
        finally:
            self.apply(None, float(x[-1]))  # leave the driver row where the sweep ended

    def force(self, v: float) -> float:
        """Driving force (torque) along +coordinate at ``v``."""
        return -float(self.state(v).mu[self.d])

    def slope(self, v: float) -> tuple[float, float]:
        """Driving force at ``v`` and its derivative along the driver (KKT tangent)."""
        st = self.state(v)
        dx = self.r.solver.tangent(st, "driver")
        return -float(st.mu[self.d]), -float(dx[self.r.solver.nf + self.d])

    def potential(self, v: float) -> float:
        st = self.state(v)
        return self.r.s.potential(st.q, st.lam)


def peak(at: At, lo: float, hi: float, sign: float) -> tuple[float, float]:
    """(coordinate, force) of the extremum sign * F -> max on [lo, hi]: the grid's best point,
    refined where dF/d(driver) (the KKT tangent) changes sign around it (Brent)."""
    x = at.vals
    F = np.array([s.outputs[force_key(at.r)] for s in at.r.steps])
    inside = np.flatnonzero((x - lo) * (x - hi) <= 0.0)
    k = int(inside[np.argmax(sign * F[inside])])
    best = (float(x[k]), float(F[k]))
    a, b = float(x[max(k - 1, 0)]), float(x[min(k + 1, len(x) - 1)])
    a, b = max(min(a, b), min(lo, hi)), min(max(a, b), max(lo, hi))
    if not b > a:
        return best
    (_, ga), (_, gb) = at.slope(a), at.slope(b)
    if ga * gb >= 0.0:  # no interior extremum between the neighbours
        return best
    # the bracket holds a sign change of dF/dx: Brent's method finds the extremum
    v = brentq(lambda u: at.slope(u)[1], a, b, xtol=1e-12 * max(abs(hi - lo), 1e-300))
    f = at.slope(v)[0]
    return (v, f) if sign * f >= sign * best[1] else best


def force_key(run: analyses.Run) -> str:
    return "driver.torque" if run.scene.analysis.driver.kind == "rotation" else "driver.force"


def bistable(run: analyses.Run) -> dict:
    """Bistability summary of a finished ``energy`` run (module doc); raises SolveError when
    an equilibrium cannot be re-solved."""
    eq = run.extras.get("equilibria", [])
    drv = run.scene.analysis.driver
    stop = run.extras.get("stopped_at")
    rng = f"[{drv.start:g}, {drv.stop:g}]"
    if stop is not None:  # a sweep stopped short speaks for the part it swept only
        rng = f"[{drv.start:g}, {stop:g}] (the sweep stopped there, short of {drv.stop:g})"
    kinds = [e["kind"] for e in eq]
    trip = next(
        (i for i in range(len(eq) - 2) if kinds[i : i + 3] == ["stable", "unstable", "stable"]),
        None,
    )
    if trip is None:
        stab = [e["coordinate"] for e in eq if e["kind"] == "stable"]
        if not stab:
            why = f"no stable equilibrium along the driver range {rng}"
        elif len(stab) == 1:
            why = f"one stable equilibrium only (at {stab[0]:.6g}) along the driver range {rng}"
        else:
            why = f"no unstable equilibrium between the stable ones along {rng}"
        return {"bistable": False, "reason": why, "equilibria": len(eq)}
    e1, eu, e2 = eq[trip : trip + 3]
    at = At(run)
    c1, cu, c2 = (e["coordinate"] for e in (e1, eu, e2))
    p1, pu, p2 = (at.potential(c) for c in (c1, cu, c2))
    # moving from the first stable towards the unstable one the driver pushes along
    # d = sign(cu - c1); its force there is the switching load forward (sign d)
    d = math.copysign(1.0, cu - c1)
    fwd = peak(at, c1, cu, d)
    bwd = peak(at, cu, c2, -d)
    return {
        "bistable": True,
        "stable": [c1, c2],
        "unstable": cu,
        "energy": {"stable": [p1, p2], "unstable": pu},
        "barrier": {"forward": pu - p1, "backward": pu - p2},
        "critical": {
            "forward": fwd[1],
            "forward_at": fwd[0],
            "backward": bwd[1],
            "backward_at": bwd[0],
        },
    }


def describe(b: dict) -> str:
    """One line for the solution message."""
    if not b["bistable"]:
        return f"not bistable along this driver: {b['reason']}"
    c = b["critical"]
    return (
        f"bistable: stable at {b['stable'][0]:.6g} and {b['stable'][1]:.6g}, unstable at "
        f"{b['unstable']:.6g}; barrier {b['barrier']['forward']:.6g} (back "
        f"{b['barrier']['backward']:.6g}); switching load {c['forward']:.6g} at "
        f"{c['forward_at']:.6g}, back {c['backward']:.6g} at {c['backward_at']:.6g}"
    )


def search(scene: Scene, name: str, spec_of: Callable[[Member], tuple]) -> Solution:
    """The ``bistable`` synthesis goal: sweep the driver, report the bistability summary in
    ``extras["bistable"]`` (and the sweep as the path)."""
    sc = energy_scene(scene)
    try:
        r = analyses.run(build(sc, spec_of), "energy")
    except SceneError as err:
        return not_applicable(scene, name, str(err))
    if r.exc is not None:
        return Solution(scene.name, name, "failed", f"bistable search: {r.exc}", tuple(r.steps))
    try:
        b = bistable(r)
    except (SolveError, np.linalg.LinAlgError) as err:
        return Solution(scene.name, name, "failed", f"bistable search: {err}", tuple(r.steps))
    extras = {**r.extras, "bistable": b}
    return Solution(scene.name, name, "converged", describe(b), tuple(r.steps), extras)


def candidates(scene: Scene) -> list[Driver]:
    """Every driver DAS-2D's bistable search tries, both senses: the rotation of each rigid
    link over a full turn, and the x and y motion of each node no support fixes in that
    direction over the longest member's length."""
    span = max(scene.member_length(m.id) for m in scene.members)
    out = [
        Driver("rotation", 0.0, sense * 360.0, member=m.id)
        for m in scene.members
        if m.kind == "rigid"
        for sense in (1.0, -1.0)
    ]
    for n in scene.nodes:
        sup = scene.support_at(n.id)
        if sup is not None and sup.type in ("pin", "clamp"):
            continue
        for d in ("x", "y"):
            out += [Driver("displacement", 0.0, s * span, node=n.id, direction=d) for s in (1, -1)]
    return out


def driver_label(d: Driver) -> str:
    """``crank ccw``, ``N3 -y``."""
    if d.kind == "rotation":
        return f"{d.member} {'ccw' if d.stop > 0 else 'cw'}"
    return f"{d.node} {'+' if d.stop > 0 else '-'}{d.direction}"


def search_drivers(scene: Scene, name: str, spec_of: Callable[[Member], tuple]) -> Solution:
    """The ``bistable`` goal without a driver: every candidate (``candidates``) swept, each
    reported in ``extras["drivers"]`` (bistable or why not, barrier, switching loads, the
    range swept); the path and ``extras["bistable"]`` are those of the bistable driver with
    the lowest energy barrier (``extras["bistable"]["driver"]``; of equal ones, all listed in
    ``extras["bistable"]["tied"]``, the first by ``rank``), or of the first candidate swept
    when none is bistable.  The model's postprocess
    re-solves every bistable candidate by fem-auto."""
    found, runs, swept, first = [], [], [], None
    for d in candidates(scene):
        sc = replace(scene, analysis=replace(scene.analysis, kind="energy", driver=d))
        sc = replace(sc, analysis=replace(sc.analysis, synthesis=None))
        entry = {"driver": driver_label(d), **found_driver(d)}
        try:
            r = analyses.run(build(sc, spec_of), "energy")
            if r.exc is not None and "equilibria" not in r.extras:
                raise SolveError(r.exc)
            b = bistable(r)
        except (SceneError, SolveError, np.linalg.LinAlgError) as err:
            b = {"bistable": False, "reason": str(err)}
        else:
            entry["swept"] = [d.start, r.extras.get("stopped_at", d.stop)]
            swept.append((d, r, b))
        found.append({**entry, **b})
        if b["bistable"]:
            runs.append((b["barrier"]["forward"], d, r, b))
    ok = [e["driver"] for e in found if e["bistable"]]
    tied = []
    if runs:  # shown: the lowest barrier (energy: comparable across drivers)
        low = min(x[0] for x in runs)
        tied = sorted(
            (x for x in runs if x[0] <= (1.0 + 1e-6) * low), key=lambda x: rank(scene, x[1])
        )
        first = tied[0][1:]
    msg = f"bistable along {len(ok)} of {len(found)} candidate drivers"
    if first is None:  # the path shown: the first candidate swept
        if not swept:
            return Solution(scene.name, name, "failed", msg, (), {"drivers": found})
        first = swept[0]
    d, r, b = first
    msg += f" ({', '.join(ok)})" if ok else ""
    msg += f"; {driver_label(d)}: {describe(b)}"
    extras = {**r.extras, "drivers": found, "bistable": {**b, "driver": found_driver(d)}}
    extras["bistable"]["label"] = driver_label(d)
    extras["bistable"]["tied"] = [driver_label(x[1]) for x in tied]
    return Solution(scene.name, name, "converged", msg, tuple(r.steps), extras)


def rank(scene: Scene, d: Driver) -> tuple:
    """Order among drivers of equal barrier, the same however the scene is drawn (node ids,
    member order, the frame and the units differ between equivalent drawings; the candidate
    order follows them): a link rotation before a node motion (an x/y motion is tied to the
    drawing's frame), a grounded link (a pin or clamp at an end) before a floating one, then
    the member id; a node motion by its distance from the nearest fixed support relative to
    the longest member, then its candidate order."""
    fixed = [s.node for s in scene.supports if s.type in ("pin", "clamp")]
    if d.kind == "rotation":
        m = scene.member(d.member)
        return (0, not {m.a, m.b} & set(fixed), m.id)
    span = max(scene.member_length(m.id) for m in scene.members)
    n = scene.node(d.node)
    dist = min(
        (math.hypot(n.x - scene.node(f).x, n.y - scene.node(f).y) for f in fixed), default=0.0
    )
    return (1, round(dist / span, 9), "")


def found_driver(d: Driver) -> dict:
    """The driver as the case file's ``[analysis.driver]`` table."""
    return {k: v for k, v in vars(d).items() if v is not None}


__all__ = [
    "At",
    "bistable",
    "candidates",
    "describe",
    "energy_scene",
    "force_key",
    "peak",
    "search",
    "search_drivers",
]
