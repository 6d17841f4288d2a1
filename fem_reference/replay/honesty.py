"""What the replay says about itself: its mesh error, static snap factors, time limits.

* ``mesh_error``: the replay settles on a fixed mesh (``n_elements``, default 32), so it
  differs from ``fem-auto`` by that mesh's discretisation error.  The static FE on the same
  mesh and on half of it gives the two-mesh estimate per output at the last factor, by the
  same rule as ``fem-auto``'s (``richardson.gci``: ``3 |f_n - f_{n/2}| / (2^2 - 1)``, order 2
  of the corotational element assumed, Roache's safety factor 3); the replay states it.
* ``static_limit``: where the *static* path from the last stable settled state before a
  jump loses stability (a bifurcation, or the limit point where load control stalls), and
  whether the jump is a snap or the switch onto a supercritical branch: reported as the
  jump's factor, the dynamic onset seen in the transient (which lags behind it by the ramp
  rate) alongside.
* ``same_branch``: an increment whose settled end is far from its settled start is a snap
  only if the two lie on different branches: the static path traced by arc-length from the
  start (``bifurcation.Watch.natural``, the FE's own natural-path test) reaches the end's
  factor stably and lands on the end for the smooth path of an imperfect structure, and
  turns back (a limit point), loses stability or lands elsewhere for a snap.
* ``JUMP_MIN_DISTANCE``: a jump must move some point by at least this fraction of the scene's
  length scale (a 1e-9 L settling move dissipating energy is not a snap).
* ``Deadline``: a wall-clock budget; a replay that runs past it fails with the reason.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from cases.schema import Scene
from fem_reference.error.richardson import gci
from fem_reference.statics import static as S

JUMP_MIN_DISTANCE = 1e-4  # fraction of the length scale
SAME_BRANCH = 1e-3  # a traced state this close (x the increment's move) is the settled end
REFINE_DEPTH = 3  # ``static_limit``: shorter steps (1 / substeps each) round an unlocated loss


def mesh_error(
    scene: Scene, n: int, fine: dict[str, float] | None = None, switched: bool = False
) -> dict[str, float] | None:
    """Estimate (``richardson.gci``) of the n-element discretisation error of every output at
    the last load factor, from static FE solves on n and n // 2 elements (None if either
    fails).  ``fine``: the n-element outputs there, when known (the replay's own last
    settled state: the static FE one of that mesh to the settling tolerance), so that only
    the coarse mesh is solved.  ``switched``: the replay left its starting branch (a snap,
    a bifurcation): the FE solves watch their stability and switch branch as the FE
    reference does (without, a perfect column's FE stays on its unstable straight path,
    and the "error" is the buckled replay's whole deflection)."""
    from fem_reference.models import FEM

    if n < 2:
        return None
    a = dataclasses.replace(scene.analysis, steps=max(1, min(scene.analysis.steps, 4)))
    sc = dataclasses.replace(scene, analysis=a)
    meshes = (n // 2,) if fine is not None else (n // 2, n)
    runs = [FEM(m, stability=switched, bifurcation=switched).solve(sc) for m in meshes]
    if any(r.status != "converged" or not r.steps for r in runs):
        return None
    coarse = runs[0].steps[-1].outputs
    fine = runs[1].steps[-1].outputs if fine is None else fine
    return {k: float(gci(coarse[k], fine[k], n / (n // 2))) for k in fine if k in coarse}


def worst_mesh_error(est: dict[str, float], length: float) -> float:
    """Largest estimate, translations divided by ``length`` (rotations in rad)."""
    vals = [v / length if not k.endswith(".rot") else v for k, v in est.items()]
    return max(vals, default=0.0)


def static_limit(
    system: object,
    q: np.ndarray,
    lam: float,
    target: float,
    substeps: int = 8,
    depth: int = 0,
) -> tuple[float, str, float | None] | None:
    """Factor at which the static path from the stable equilibrium ``(q, lam)`` towards
    ``target`` loses stability, its kind and its round-off bound (located bifurcations,
    ``conditioning.factor_roundoff``; else None): marched by load control in ``substeps`` equal
    steps (short enough to stay on the branch next to a bifurcation, where one long step may
    land on the other branch and leave the bracket without a path through it), located in
    the first step that ends unstable (``bifurcation.Watch.locate``: Brent's method on the
    lowest eigenvalue, or its linear interpolation across that short step where the path
    cannot be re-solved inside it), or the limit point where load control stalls (traced
    by arc-length and refined, ``Watch.limit``; else the stall); None if it gets there
    stably.  A load-control step that lands past a fold on its unstable side is located on
    the path traced ahead of it (bistable-offload: 0.15743, the elastica's limit point
    0.15737; the interpolation inside the step said 0.1554).

    The kind is "bifurcation" where the stability loss is a located bifurcation (the load
    does no work on its mode, ``bifurcation.KIND_TOL``) whose branch rises (supercritical,
    ``_rises``: a buckled column, which does not snap), else "snap"."""

    from fem_reference.statics.bifurcation import KIND_TOL, Watch

    opts = S.Options()
    try:
        watch = Watch(system, opts)
        prev = S.State(np.array(q, float), lam)
        if not (watch.active and watch.stable(prev)):
            return None
        for k in range(1, substeps + 1):
            lam_k = lam + (target - lam) * k / substeps
            try:
                cur, stalled = S.load_control(system, prev, lam_k, abs(lam_k - prev.lam), opts), 0
            except S.SolveError as err:  # load control stalls: a limit point ahead
                if err.state is None:
                    return None
                cur, stalled = err.state, 1
            if not watch.stable(cur):
                lam_c, crit, phi, located, roundoff = watch.locate(prev, cur)
                if not located:  # load control jumped onto the unstable side of a fold
                    lim = watch.limit(prev, S.State(cur.u, target))  # ahead, not inside
                    if lim is not None:
                        return float(lim.lam), "snap", None
                    # or Brent's Newton diverged right at a bifurcation (singular there to
                    # round-off): the eigenvalue's interpolation is refined in a shorter step
                    inner = None
                    if depth < REFINE_DEPTH:
                        inner = static_limit(system, prev.u, prev.lam, cur.lam, substeps, depth + 1)
                    return inner or (lam_c, "snap", None)
                f = np.asarray(system.external(crit.u), dtype=float)
                work = abs(float(phi @ f)) / max(np.linalg.norm(phi) * np.linalg.norm(f), 1e-300)
                rises = work < KIND_TOL and _rises(system, crit, phi, lam_c)
                return lam_c, "bifurcation" if rises else "snap", roundoff
            if stalled:  # the limit point, traced over by arc-length and refined
                lim = watch.limit(prev, S.State(cur.u, lam_k))
                return float(cur.lam if lim is None else lim.lam), "snap", None
            prev = cur
        return None
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError, S.SolveError):
        return None


def _rises(system: object, crit: S.State, phi: np.ndarray, lam_c: float) -> bool:
    """Whether the branch through the critical state ``crit`` (at or next to the critical
    factor ``lam_c``) along its mode ``phi`` rises: its factor at the switch amplitude above
    ``lam_c`` (the FE's test, ``switch.branch_offset``); False where that state cannot
    be solved."""
    from fem_reference.statics.switch import branch_offset

    try:
        return bool(branch_offset(system, crit, phi, S.Options()).lam > lam_c)
    except S.SolveError:
        return False


def same_branch(
    system: object,
    q0: np.ndarray,
    lam0: float,
    q1: np.ndarray,
    lam1: float,
    w: np.ndarray,
    dist: float,
) -> bool | None:
    """Whether the settled states ``(q0, lam0)`` and ``(q1, lam1)``, ``dist`` L apart
    (weights ``w``: 1 on translations, L on rotations), lie on one stable static path: the
    path traced from the first stays stable, its factor rising monotonically, and lands
    within ``SAME_BRANCH`` x ``dist`` of the second.  None when the system has no static
    path trace (a test system, a servo's)."""
    from fem_reference.statics.bifurcation import Watch

    try:
        watch = Watch(system, S.Options())
        start, end = S.State(np.array(q0, float), float(lam0)), S.State(np.array(q1), lam1)
        land = watch.natural(start, end, lam1) if watch.active else None
    except (AttributeError, TypeError, NotImplementedError):
        return None
    if land is None:
        return False
    L = system.length_scale()
    return bool(np.max(np.abs(w * (land.u - q1))) / L <= SAME_BRANCH * dist)


class Deadline:
    """A wall-clock budget (seconds) checked inside the replay's time loop."""

    def __init__(self, seconds: float):
        self.seconds = seconds
        self.end = time.perf_counter() + seconds

    def passed(self) -> bool:
        return time.perf_counter() > self.end
