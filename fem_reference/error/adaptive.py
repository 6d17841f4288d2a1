"""Per-member mesh refinement of ``fem-auto`` on scenes with several flexible members.

A uniform mesh spends as many elements on a stubby, barely bent member as on a slender,
strongly bent one.  ``fem-auto`` instead measures each member's share of the discretisation
error and gives each member the elements its share needs:

1. *Indicator* (Richardson per member): the scene is solved on ``N_INDICATOR`` and twice as
   many elements per member.  Each member's own error shows in its deflection from the chord
   of its deformed ends (the ends' motion, which other members' errors move, is taken out):
   its largest change ``d_m`` between the two meshes, over the path (path analyses: the end
   point), estimates the member's error, ``e_m = d_m / L / (2^p - 1)`` with the element's
   formal order p = 2.  Both meshes are uniform: refining one member alone would break the
   symmetry of a symmetric scene (a bistable switch then snaps where the perfect one
   bifurcates).
2. *Allocation*: with ``e_m ~ C_m / n_m^2`` equal shares need ``n_m ~ sqrt(C_m)``: the member
   with the largest indicator gets the top count of the mesh sequence, every other member
   ``2^-j_m`` of it, ``j_m = floor(log2(sqrt(e_max / e_m)))`` (rounded down: never fewer
   elements than equal shares ask for), at most ``log2(sequence[0])`` halvings so every
   member keeps at least one element on the coarsest mesh.  Indicators below ``NOISE`` are
   round-off (straight bars); when every member's is, the counts stay equal.
3. *Richardson and target*: the meshes of the sequence scale every member by the same ratio,
   so ``richardson.combine`` extrapolates and estimates exactly as on a uniform sequence
   (same contract: ``extras['error_estimate']`` etc.).  With a ``target``, while the largest
   estimate over the path (translations / L, rotations in rad) exceeds it, the sequence is
   extended by one doubling (up to ``MAX_TOP``); the last four meshes are combined.  Without
   one, the sequence's top count is the cost budget (as on a uniform sequence).

``extras['fidelity']`` records the chosen counts per member, the indicators, the top count
sequence, the estimate and the target; ``extras['per_member']`` the indicator details.
"""

from __future__ import annotations

import math

import numpy as np

from cases.schema import Scene
from reduced_models.base import Solution

N_INDICATOR = 8
P_FORMAL = 2.0
MAX_TOP = 512
NOISE = 1e-10  # indicators below this (relative) are round-off, not discretisation error


def flexible_ids(scene: Scene) -> list[str]:
    """Ids of the scene's flexible members, in scene order."""
    return [m.id for m in scene.members if m.kind == "flexible"]


def _length(scene: Scene) -> float:
    return max((scene.member_length(m.id) for m in scene.members), default=1.0) or 1.0


def _local_shapes(runner: object, steps: list) -> dict[str, np.ndarray]:
    """Each flexible member's deflection from the chord of its deformed ends, at its mesh
    points: ``{id: (n_steps, n_pts, 2)}``, with the points' arc length in ``[id + '.s']``."""
    out = {}
    for mm in runner.system.members:
        if mm.kind != "flexible":
            continue
        xy = np.array([st.shapes[mm.id] for st in steps])  # (n_steps, n_pts, 2)
        t = (mm.s / mm.s[-1])[None, :, None]
        out[mm.id] = xy - ((1.0 - t) * xy[:, :1] + t * xy[:, -1:])
        out[mm.id + ".s"] = mm.s / mm.s[-1]
    return out


def member_changes(scene: Scene, n1: int, n2: int, options: dict) -> dict[str, float] | str:
    """``{member id: d_m}``: largest change (length) of each flexible member's deflection from
    the chord of its deformed ends between uniform meshes of ``n1`` and ``n2`` elements, over
    the path (path analyses: the end point); or why it could not be measured."""
    from fem_reference.models import FEM

    # the stability watch stays on: a path that snaps must land where the reference lands
    opts = {**options, "stability": False, "limit_points": False}
    shapes = []
    for n in (n1, n2):
        r, status, msg = FEM(n, **opts).runner(scene)
        if status != "converged" or not r.steps:
            return f"indicator mesh n = {n}: {msg or status}"
        steps = r.steps[-1:] if scene.analysis.kind == "path" else r.steps
        shapes.append((len(steps), _local_shapes(r, steps)))
    (k1, a), (k2, b) = shapes
    if k1 != k2:
        return "indicator meshes reached different numbers of steps"
    out = {}
    for m in flexible_ids(scene):
        s1, s2 = a[m + ".s"], b[m + ".s"]
        fine = np.stack(
            [np.array([np.interp(s1, s2, b[m][k, :, c]) for k in range(k2)]) for c in (0, 1)],
            axis=-1,
        )
        out[m] = float(np.max(np.hypot(*np.moveaxis(fine - a[m], -1, 0)), initial=0.0))
    return out


def indicators(scene: Scene, options: dict) -> dict[str, float] | str:
    """``{member id: e_m}`` (module docstring, step 1), or why they could not be measured."""
    d = member_changes(scene, N_INDICATOR, 2 * N_INDICATOR, options)
    if isinstance(d, str):
        return d
    return {m: v / _length(scene) / (2**P_FORMAL - 1) for m, v in d.items()}


def halvings(ind: dict[str, float], top0: int) -> dict[str, int]:
    """``{member id: j_m}``: each member gets ``top / 2^j_m`` elements (module docstring)."""
    jmax = int(math.floor(math.log2(top0)))
    e_max = max(ind.values(), default=0.0)
    if e_max <= NOISE:  # no member bends measurably (bars): nothing to tell them apart
        return dict.fromkeys(ind, 0)
    return {
        m: min(jmax, max(0, int(math.floor(0.5 * math.log2(e_max / max(e, NOISE))))))
        for m, e in ind.items()
    }


def mesh_of(top: int, j: dict[str, int]) -> dict[str, int]:
    """Per-member counts of the mesh whose top count is ``top``."""
    return {m: max(1, top >> jm) for m, jm in j.items()}


def relative_estimate(scene: Scene, sol: Solution) -> float:
    """Largest error estimate over the path of the node outputs (translations / L, rad)."""
    steps = sol.extras.get("error_estimate_steps") or {
        k: [v] for k, v in (sol.extras.get("error_estimate") or {}).items()
    }
    L = _length(scene)
    worst = 0.0
    for key, vals in steps.items():
        q = key.rsplit(".", 1)[-1]
        if q in ("ux", "uy", "x", "y", "rot"):
            v = np.asarray(vals, dtype=float)
            if v.size and np.any(np.isfinite(v)):
                worst = max(worst, float(np.nanmax(v)) / (1.0 if q == "rot" else L))
    return worst if worst > 0.0 or steps else math.nan


def solve_per_member(
    scene: Scene, name: str, sequence: tuple[int, ...], options: dict, target: float | None
) -> Solution:
    """``fem-auto`` with per-member meshes (module docstring)."""
    from fem_reference.error.richardson import combine
    from fem_reference.models import FEM

    ind = indicators(scene, options)
    note = ""
    if isinstance(ind, str):  # cannot measure: equal counts (the uniform sequence)
        note, ind = ind, dict.fromkeys(flexible_ids(scene), 1.0)
    j = halvings(ind, sequence[0])
    coarse = {**options, "stability": False}
    seq = list(sequence)
    runs = [FEM(mesh_of(n, j), **coarse).runner(scene) for n in seq[:-1]]
    runs.append(FEM(mesh_of(seq[-1], j), **options).runner(scene))
    sol = combine(scene, name, tuple(seq), runs)
    est = relative_estimate(scene, sol)
    while target and sol.status == "converged" and not est <= target and 2 * seq[-1] <= MAX_TOP:
        seq.append(2 * seq[-1])
        runs.append(FEM(mesh_of(seq[-1], j), **options).runner(scene))
        sol = combine(scene, name, tuple(seq[-4:]), runs[-4:])
        est = relative_estimate(scene, sol)
    fidelity = {
        "n": mesh_of(seq[-1], j),
        "sequence": seq,
        "estimate": est,
        "target": target,
        "target_reached": bool(est <= target) if target else None,
        "per_member": True,
    }
    extras = {
        **sol.extras,
        "fidelity": fidelity,
        "per_member": {
            "indicator_n": N_INDICATOR,
            "indicator": ind,
            "halvings": j,
            "n": mesh_of(seq[-1], j),
            **({"note": note} if note else {}),
        },
    }
    msg = sol.message
    if target and sol.status == "converged" and not est <= target:
        msg = (msg + "; " if msg else "") + (
            f"error estimate {est:.2e} above the target {target:.0e} at the largest mesh"
        )
    return Solution(sol.case, sol.model, sol.status, msg, sol.steps, extras)


__all__ = [
    "flexible_ids",
    "halvings",
    "indicators",
    "member_changes",
    "mesh_of",
    "solve_per_member",
]
