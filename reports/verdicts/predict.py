"""Every reduced model states its expected error: a lookup in the predicted-error table.

``attach(name, scene, sol)`` adds to a reduced model's Solution (DESIGN.md, "Predicted error
of reduced models"):

* ``extras["predicted_error"]``: the largest table error (``error_rel``, the default yardstick)
  over every flexible member's end-load state along the path (float; None when no state
  could be looked up, ``predicted_error_note`` says why);
* ``extras["predicted_error_at"]``: where that largest error is (member, load factor, the
  state PL^2/EI, alpha, ML/EI);
* ``extras["unpredicted_factors"]``: the load factors of the states the table cannot speak
  for (outside it, or where the model failed or declined next to them in the atlas; sorted,
  only when there are any): ``predicted_error`` does not cover them;
* ``extras["validity_warning"]`` (the message, a str) and ``extras["validity_message"]`` (the
  model's own warning and this one, joined) where the prediction exceeds ``THRESHOLD`` or a
  state lies outside the table ("outside the atlas: PL^2/EI = 14 > 10").

The load state of a member, in its own frame (``reports.verdicts.predict_table``):

* a single beam (``cantilever_of``): the scene's tip loads times the step's load factor; a
  guided tip adds the guide's reaction moment M = -(r x F) / 2 (the guided elastica is point
  symmetric about its midpoint, where the moment vanishes), r the model's own tip position
  from its shape;
* a member of a mechanism: from the model's own deformed shape, the end b's position and
  rotation relative to the tangent at end a, matched to the nearest exact state of the table
  (a member loaded at its ends only is an elastica clamped at a); a state farther than
  ``MATCH_MAX`` from every table state is outside the atlas.

Cost: one vectorised interpolation (``map_coordinates``) or KD-tree query per member, measured
0.15 ms on a cantilever and 0.2 ms on a fixed-guided beam (a prb-3r solve there: 0.6 ms, its
post-processing with shapes 1.2-1.5 ms) and 0.4 ms on the two-leaf parallel guide (solve 5.6
ms).  It runs on the post-processed solution (``reports.api.finish``), never inside a timed
solve (``run_model(post=False)``, what the runner and ``recommend`` time).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import pathlib
import re

import numpy as np
from scipy.ndimage import map_coordinates
from scipy.spatial import cKDTree

from cases.schema import Scene
from reduced_models.base import Solution
from reduced_models.beam.single_beam import Cantilever, cantilever_of

THRESHOLD = 0.01
# table states are ~0.05-0.3 apart (L units / rad) in (ux, uy, rot); farther is off the table
MATCH_MAX = 0.3
RING = 0.1  # |(uy/L, rot)| below which a member's state is matched on its direction only
# the table's file and grid edges (``reports.verdicts.predict_table`` builds it on this grid)
PATH = pathlib.Path(__file__).parent / "data" / "predicted_error.npz"
ANGLES = np.array([0.0, 15, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 179.9])
RHO_MAX = 10.0
_CHANNEL = np.arange(4.0)[:, None]  # lookup's channel coordinate


@functools.lru_cache(maxsize=1)
def table() -> dict[str, np.ndarray]:
    """The shipped table (``reports/verdicts/data/predicted_error.npz``)."""
    with np.load(PATH) as z:
        return {k: z[k] for k in z.files}


@functools.lru_cache(maxsize=256)
def table_model(name: str | None) -> str | None:
    """The table's entry for a model name: itself, or for ``linear-N``, ``cbcm-N``,
    ``prb-fsm-N`` the table's member of that family with the largest N <= the given one (a
    coarser discretisation errs more: conservative), else None."""
    names = [str(n) for n in table()["models"]]
    if name in names:
        return name
    m = re.fullmatch(r"(linear|cbcm|prb-fsm)-(\d+)", name or "")
    if not m:
        return None
    fam, n = m.group(1), int(m.group(2))
    sizes = [int(x.rsplit("-", 1)[1]) for x in names if re.fullmatch(rf"{fam}-\d+", x)]
    below = [s for s in sizes if s <= n]
    return f"{fam}-{max(below)}" if below else None


@functools.lru_cache(maxsize=64)
def _channels(model: str, family: str) -> np.ndarray:
    """(4, angles[, betas], rhos) grids of one model: log10 error of the translations and of
    the rotation, the exact tip's largest displacement and rotation on the ramp so far."""
    t = table()
    i = list(t["models"]).index(model)
    err = t[f"{family}_error"][i].astype(float)  # log10 already (predict_table.stored)
    ref = t[f"{family}_ref"].astype(float)
    move = np.fmax.accumulate(np.hypot(ref[..., 0], ref[..., 1]), axis=-1)
    turn = np.fmax.accumulate(np.abs(ref[..., 2]), axis=-1)
    return np.stack([err[..., 0], err[..., 1], move, turn])


def _index(axis: str, x: np.ndarray) -> np.ndarray:
    """Fractional grid index of x on the table's sorted axis ``axis`` (clamped to its ends)."""
    return np.interp(x, *_axis(axis))


@functools.lru_cache(maxsize=8)
def _axis(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The table's axis ``name`` and its grid indices 0, 1, ... (made once)."""
    axis = table()[name]
    return axis, np.arange(axis.size, dtype=float)


def lookup(
    model: str,
    p: np.ndarray,
    alpha: np.ndarray,
    m: np.ndarray,
    *,
    follower: bool = False,
) -> np.ndarray:
    """Table values at states (PL^2/EI >= 0, alpha in [0, 180] deg, signed ML/EI), each (k,).

    Returns (4, k): error of the tip translations and of the tip rotation (``error_rel`` of
    the ramp to that state), the exact tip's largest displacement and rotation on that ramp.
    Trilinear in (alpha, beta, rho), errors in log10.  States are clamped into the table (rho
    below the first ring reads the first ring: the yardstick makes error_rel tend to a constant
    as the load vanishes; alpha above 179.9 deg reads the imperfect-column row).  NaN where the
    model failed or declined next to the state.
    """
    rho = np.hypot(p, m)
    ia, ir = _index("angles", alpha), _index("rhos", rho)
    if follower:
        coords = [ia, ir]
    else:
        coords = [ia, _index("betas", np.degrees(np.arctan2(m, p))), ir]
    grids = _channels(model, "follower" if follower else "dead")
    k = ia.size  # one call for the four channels: the channel is an exact integer coordinate
    at = np.empty((len(coords) + 1, 4, k))
    at[0] = _CHANNEL
    at[1:] = np.array(coords)[:, None, :]
    at = at.reshape(len(coords) + 1, 4 * k)
    # an output array of our own: without one scipy looks up the dtype's name (~20 us)
    out = np.empty(4 * k)
    map_coordinates(grids, at, out, order=1, mode="nearest", prefilter=False)
    out = out.reshape(4, k)
    out[:2] = 10.0 ** out[:2]
    return out


@dataclasses.dataclass
class States:
    """End-load states of one member along a path, each (k,): nondimensional, mirrored.

    ``values`` (4, k) is ``lookup``'s answer at each state; ``rotation`` whether the tip
    rotation is the member's own (a free end) or set from outside (a guide, a mechanism).
    """

    member: str
    model: str
    factor: np.ndarray
    p: np.ndarray
    alpha: np.ndarray
    m: np.ndarray
    values: np.ndarray
    outside: np.ndarray
    rotation: bool = True
    from_shape: bool = False

    def path_error(self) -> np.ndarray:
        """(k,) each state's error over the path's excursion, not the ramp's to that state.

        The table's error at a state is over the exact tip's largest motion on the ramp to it;
        a path is judged over its largest motion (``reports.verdicts.yardstick``), so each state's
        error is rescaled by motion-so-far / motion-over-the-path (for the translations and,
        on a free end, the rotation).
        """
        c = 2 if self.rotation else 1  # the channels judged: translations[, rotation]
        err, motion = self.values[:c], self.values[2 : 2 + c]
        top = np.fmax.reduce(motion, axis=1)  # NaN only where every entry is (as nanmax)
        moved = top > 0
        w = np.where(moved[:, None], motion / np.where(moved, top, 1.0)[:, None], 1.0)
        return (err * np.fmin(w, 1.0)).max(axis=0)


def _tip_vectors(sol: Solution, beam: Cantilever) -> np.ndarray:
    """(k, 2) beam-frame root-to-tip vectors of each step (the model's own shape; the
    undeformed (L, 0) where a step has none)."""
    c, s = beam.c, beam.s
    ends = np.full((len(sol.steps), 2, 2), np.nan)
    for i, st in enumerate(sol.steps):
        pts = st.shapes.get(beam.member) if st.shapes else None
        if pts is not None and len(pts) >= 2:
            ends[i] = pts[0], pts[-1]
    d = ends - np.asarray(beam.origin)  # (k, end, 2): the tip is the end farther from the root
    first_is_tip = np.hypot(*d[:, 0].T) > np.hypot(*d[:, 1].T)
    d = np.where(first_is_tip[:, None], d[:, 0], d[:, 1])
    out = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
    return np.where(np.isnan(out), [beam.L, 0.0], out)


def beam_states(model: str, sol: Solution, beam: Cantilever) -> States:
    """States of a single beam's member from the scene's loads (module docstring)."""
    lam = np.array([st.factor for st in sol.steps], dtype=float)
    fx, fy, mm = lam * beam.fx, lam * beam.fy, lam * beam.m
    if beam.guided:  # the guide's reaction: zero moment at the midpoint
        r = _tip_vectors(sol, beam)
        mm = mm - 0.5 * (r[:, 0] * fy - r[:, 1] * fx)
    L, EI = beam.L, beam.EI
    alpha = np.degrees(np.arctan2(-fy, fx))
    flip = alpha < 0  # mirror so that the transverse force points to -y
    alpha, mm = np.abs(alpha), np.where(flip, -mm, mm)
    p, m = np.hypot(fx, fy) * L**2 / EI, mm * L / EI
    outside = np.hypot(p, m) > RHO_MAX * (1 + 1e-9)
    if beam.follower:
        outside |= np.abs(m) > 0  # the follower table has no end moment
    values = lookup(model, p, alpha, m, follower=beam.follower)
    return States(beam.member, model, lam, p, alpha, m, values, outside, not beam.guided)


@functools.lru_cache(maxsize=32)
def _tree(model: str) -> tuple[cKDTree, np.ndarray, np.ndarray]:
    """KD-tree of the table's exact end states (and their mirror images), the table values
    (4, n) and the (p, alpha, m) states (n, 3) there."""
    t = table()
    ref = t["dead_ref"].astype(float).reshape(-1, 3)
    vals = _channels(model, "dead").reshape(4, -1).copy()
    vals[:2] = 10.0 ** vals[:2]
    a, b, r = np.meshgrid(t["angles"], np.radians(t["betas"]), t["rhos"], indexing="ij")
    load = np.column_stack([(r * np.cos(b)).ravel(), a.ravel(), (r * np.sin(b)).ravel()])
    ok = np.all(np.isfinite(ref), axis=1)
    pts = np.concatenate([ref[ok], ref[ok] * [1, -1, -1]])
    return cKDTree(pts), np.tile(vals[:, ok], 2), np.tile(load[ok], (2, 1))


def shape_states(
    model: str, member_id: str, length: float, factor: np.ndarray, shapes: list
) -> States:
    """States of a mechanism member from its deformed shapes (k steps of (n, 2) points, at
    load factors ``factor`` (k,)): the nearest exact table state to its end b's position and
    rotation in the frame of its tangent at end a."""
    pts = np.stack([np.asarray(s, dtype=float) for s in shapes])  # (k, n, 2)
    seg = np.diff(pts, axis=1)
    ang = np.unwrap(np.arctan2(seg[..., 1], seg[..., 0]), axis=1)
    rot = ang[:, -1] - ang[:, 0]
    chord = pts[:, -1] - pts[:, 0]
    c, s = np.cos(ang[:, 0]), np.sin(ang[:, 0])
    ux = (c * chord[:, 0] + s * chord[:, 1]) / length - 1.0
    uy = (-s * chord[:, 0] + c * chord[:, 1]) / length
    # the table's members are inextensible: a member's axial stretch (ux > 0, or a
    # shortening larger than its bending explains) is not part of its state.  A barely bent
    # member is matched on its direction (uy : rot) scaled up to the table's first ring,
    # where the geometric shortening is second order (ux -> 0).
    size = np.hypot(uy, rot)
    small = size < RING
    f = np.where(small, RING / np.where(size > 0, size, 1.0), 1.0)
    qx = np.where(small, 0.0, np.fmin(ux, 0.0))
    tree, vals, load = _tree(model)
    dist, j = tree.query(np.column_stack([qx, uy * f, rot * f]))
    values = vals[:, j]
    values[2] = np.hypot(ux, uy)  # the member's own motion weighs its states along the path
    p, alpha, m = load[j].T
    return States(member_id, model, factor, p, alpha, m, values, dist > MATCH_MAX, False, True)


def member_states(name: str, scene: Scene, sol: Solution) -> tuple[list[States], list[str]]:
    """Every flexible member's states along the path, and notes on members left out."""
    beam = cantilever_of(scene)
    if isinstance(beam, Cantilever) and name != "mixed":
        return [beam_states(table_model(name), sol, beam)], []
    out, notes = [], []
    for mem in scene.members:
        if mem.kind != "flexible":
            continue
        law = table_model(mem.model if name == "mixed" else name)
        if law is None:
            notes.append(f"member {mem.id!r}: no table for its model {mem.model!r}")
        elif mem.sweep_deg:
            notes.append(f"outside the atlas: member {mem.id!r} is a circular arc")
        else:
            have = [(st.factor, st.shapes[mem.id]) for st in sol.steps if mem.id in st.shapes]
            if not have:
                notes.append(f"member {mem.id!r}: the solution carries no shape")
                continue
            lam = np.array([h[0] for h in have], dtype=float)
            L = scene.member_length(mem.id)
            out.append(shape_states(law, mem.id, L, lam, [h[1] for h in have]))
    return out, notes


def applies(name: str) -> bool:
    """Whether ``name`` gets a prediction: a model of the table (or its family), ``mixed``."""
    return name == "mixed" or table_model(name) is not None


def _where(st: States, i: int) -> dict[str, object]:
    return {
        "member": st.member,
        "model": st.model,
        "factor": float(st.factor[i]),
        "PL^2/EI": round(float(st.p[i]), 4),
        "alpha_deg": round(float(st.alpha[i]), 2),
        "ML/EI": round(float(st.m[i]), 4),
    }


def _outside_text(st: States, i: int) -> str:
    if st.from_shape:
        return (
            f"outside the atlas: member {st.member!r}'s deformed state is farther than "
            f"{MATCH_MAX:g} from every table state"
        )
    p, m, lim = float(st.p[i]), float(st.m[i]), f"{RHO_MAX:g}"
    if abs(m) < 1e-12:
        what = f"PL^2/EI = {p:.3g} > {lim}"
    elif p < 1e-12:
        what = f"ML/EI = {abs(m):.3g} > {lim}"
    else:
        what = f"PL^2/EI = {p:.3g}, ML/EI = {m:.3g} (radius {math.hypot(p, m):.3g} > {lim})"
    return f"outside the atlas: {what} (member {st.member!r})"


def _text(at: dict[str, object], err: float) -> str:
    return (
        f"predicted error {err:.2%} > {THRESHOLD:.0%} (validity atlas at member "
        f"{at['member']!r}: PL^2/EI = {at['PL^2/EI']:.3g}, alpha = {at['alpha_deg']:g} deg, "
        f"ML/EI = {at['ML/EI']:.3g}, load factor {at['factor']:.3g})"
    )


def predict(name: str, scene: Scene, sol: Solution) -> dict[str, object]:
    """``predicted_error``, ``predicted_error_at`` (or ``predicted_error_note``) and the
    warnings (list of str) of one solution."""
    states, notes = member_states(name, scene, sol)
    warnings = [n for n in notes if n.startswith("outside")]
    best, at, blind = -1.0, None, set()
    for st in states:  # a path's 21 states: plain floats, one conversion per array
        factor, outside = st.factor.tolist(), st.outside.tolist()
        live = [i for i, f in enumerate(factor) if f != 0]
        if not live:
            continue
        out = [i for i in live if outside[i]]
        if out:
            radius = np.hypot(st.p, st.m).tolist()
            warnings.append(_outside_text(st, max(out, key=radius.__getitem__)))
        err = st.path_error().tolist()
        nan = [i for i in live if math.isnan(err[i])]
        blind.update(factor[i] for i in out + nan)
        if nan:
            w = _where(st, nan[0])
            warnings.append(
                f"{st.model} failed or declined in the atlas near member {st.member!r}'s state "
                f"PL^2/EI = {w['PL^2/EI']:.3g}, alpha = {w['alpha_deg']:g} deg, "
                f"ML/EI = {w['ML/EI']:.3g}: no prediction there"
            )
        seen = [i for i in live if not math.isnan(err[i])]
        if not any(math.isfinite(err[i]) for i in seen):
            continue
        j = max(seen, key=err.__getitem__)  # the first of equal largest, as nanargmax
        if err[j] > best:
            best, at = err[j], _where(st, j)
    result: dict[str, object] = {"predicted_error": best if at else None, "warnings": warnings}
    if blind:
        result["unpredicted_factors"] = sorted(blind)
    if at is None:
        result["predicted_error_note"] = "; ".join(notes) or "no member state to look up"
        return result
    result["predicted_error_at"] = at
    if best > THRESHOLD:
        warnings.insert(0, _text(at, best))
    return result


def attach(name: str, scene: Scene, sol: Solution) -> Solution:
    """``sol`` with its predicted error in ``extras`` (module docstring); unchanged for a model
    without a table (the exact references, FE, kinetostatic) or a solution without steps."""
    if not sol.steps or not applies(name):
        return sol
    pred = predict(name, scene, sol)
    extras = dict(sol.extras)
    warnings = pred.pop("warnings")
    extras.update(pred)
    if warnings:
        text = "; ".join(warnings)
        own = extras.get("validity_message") if extras.get("validity_warning") else None
        extras["validity_warning"] = text
        extras["validity_message"] = f"{own}; {text}" if own else text
    return Solution(sol.case, sol.model, sol.status, sol.message, sol.steps, extras)
