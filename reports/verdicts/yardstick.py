"""The yardstick: what an error of each output is divided by.

A designer judges an output on its own scale: a parallel guide that moves 1.25 mm is judged on
1.25 mm, not on its 50 mm leaves, so a model 25 % off in stiffness is 25 % off whatever the
deflection.  Two yardsticks are kept side by side and every stored error names its own:

``error_rel`` (the default: grading, ``recommend``, atlases, the report)
    The error of an output divided by that output's own **excursion** along the reference path:

    * a point's ``.ux .uy .x .y``: the largest displacement magnitude of that point,
      ``max_k |(ux_k, uy_k)|`` (both components share it, so a parasitic shortening is judged
      on the point's motion);
    * a rotation ``.rot`` (rad, from the undeformed state): ``max_k |rot_k|``;
    * a boom length: ``max_k |l_k - l_0|``;
    * anything else (load factor, energy, force, mechanical advantage): ``max_k |v_k|``.

    Where that excursion is tiny -- a parasitic rotation, a symmetric output, a point that
    barely moves -- the error is absolute against a **floor** instead, never divided by ~0.
    The floor is the case's (``[[tolerances]] floor``, case units) or the default
    ``FLOOR_FRACTION`` of the scene's characteristic motion: for translations the largest
    displacement of any output point along the reference path, for rotations the larger of the
    largest output rotation and that displacement over the length scale L; never below
    round-off (``ROUNDOFF_FRACTION`` of L, or rad).

``error_L`` (the classic one, kept for comparison)
    Translations divided by L (the longest member), rotations in rad, anything else by its
    largest reference magnitude.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

TRANSLATIONS = ("x", "y", "ux", "uy")
# below this fraction of the scene's own motion an excursion is "nothing moved": judged
# against the floor (1e-3: far above round-off, far below anything a designer reads off a
# path; a case states its own floor where that is wrong for it)
FLOOR_FRACTION = 1e-3
# and never below round-off of the geometry: 1e-6 of L for translations, 1e-6 rad (a scene
# that does not move at all, an inextensible bar in tension, is judged absolutely there)
ROUNDOFF_FRACTION = 1e-6
YARDSTICKS = {
    "error_rel": "relative to the output's own excursion along the reference path",
    "error_L": "translations / L, rotations in rad",
}


@dataclass(frozen=True)
class Yardstick:
    """Divisors of every output of one reference path.

    Attributes
    ----------
    scale : output key (or point name) -> divisor of its ``error_rel`` (case units, > 0).
    floored : keys whose excursion was below the floor (judged against the floor).
    length : the case's length scale L (for ``error_L``).
    """

    scale: Mapping[str, float] = field(default_factory=dict)
    floored: frozenset[str] = frozenset()
    length: float = 1.0

    def rel(self, key: str) -> float:
        """Divisor of ``key``'s ``error_rel`` (1.0 for a key the reference lacks)."""
        return self.scale.get(key, 1.0)


def quantity(key: str) -> str:
    """``tip.uy`` -> ``uy``; ``factor`` -> ``factor``."""
    return key.rsplit(".", 1)[-1]


def point(key: str) -> str | None:
    """The point a translation or rotation key belongs to (``tip.uy`` -> ``tip``), or None."""
    head, _, q = key.rpartition(".")
    return head if head and (q in TRANSLATIONS or q == "rot") else None


def scale_L(key: str, ref: np.ndarray, length: float) -> float:
    """Divisor of ``key``'s ``error_L``: L for translations, 1 for rotations (rad), else the
    largest reference magnitude (1 when that is 0)."""
    q = quantity(key)
    if key != "factor" and q in TRANSLATIONS:
        return length
    if q == "rot":
        return 1.0
    big = float(np.nanmax(np.abs(ref))) if np.any(np.isfinite(ref)) else 0.0
    return big if big > 0 else 1.0


def _nanmax(a: np.ndarray) -> float:
    return float(np.nanmax(a)) if a.size and np.any(np.isfinite(a)) else 0.0


def point_motion(outputs: Mapping[str, np.ndarray], p: str) -> np.ndarray:
    """Displacement magnitude of point ``p`` at every step, shape (n,): from ``.ux``/``.uy``
    (a component the path lacks counts as 0), else from ``.x``/``.y`` relative to the first
    step; empty when the point has no translation output."""
    comps = [outputs.get(f"{p}.ux"), outputs.get(f"{p}.uy")]
    if all(c is None for c in comps):
        comps = [outputs.get(f"{p}.{q}") for q in ("x", "y")]
        comps = [None if c is None else c - c[0] for c in comps]
    present = [c for c in comps if c is not None]
    if not present:
        return np.zeros(0)
    return np.hypot(*(c if c is not None else np.zeros_like(present[0]) for c in comps))


def yardstick(
    ref: Mapping[str, np.ndarray], length: float, floors: Mapping[str, float] | None = None
) -> Yardstick:
    """The divisors of every output of a reference path.

    Parameters
    ----------
    ref : output key -> its values along the reference path, shape (n,) (NaN where absent);
        ``factor`` included when it is an output to judge.
    length : the case's length scale L (case units).
    floors : output key or point name -> a floor stated by the case (case units).
    """
    floors = floors or {}
    points = sorted({p for k in ref if (p := point(k))})
    motion = {p: _nanmax(point_motion(ref, p)) for p in points}
    turn = {p: _nanmax(np.abs(ref[f"{p}.rot"])) for p in points if f"{p}.rot" in ref}
    move = max(motion.values(), default=0.0)
    floor_t = max(FLOOR_FRACTION * move, ROUNDOFF_FRACTION * length)
    char_rot = max(max(turn.values(), default=0.0), move / length if length > 0 else 0.0)
    floor_r = max(FLOOR_FRACTION * char_rot, ROUNDOFF_FRACTION)
    scale, floored = {}, set()
    for key, vals in ref.items():
        p, q = point(key), quantity(key)
        if p is not None and q != "rot":
            exc, floor = motion[p], floors.get(key, floors.get(p, floor_t))
        elif p is not None:
            exc, floor = turn.get(p, 0.0), floors.get(key, floors.get(p, floor_r))
        else:
            base = vals[np.isfinite(vals)][:1] if q == "length" else np.zeros(1)
            exc = _nanmax(np.abs(vals - (base[0] if base.size else 0.0)))
            # a quantity with no natural floor: 1e-12 of its excursion or an absolute floor of
            # one unit when the reference never leaves zero
            floor = floors.get(key, 1e-12 * exc if exc > 0 else 1.0)
        if exc < floor:
            floored.add(key)
        scale[key] = max(exc, floor)
    for p in points:
        scale[p] = max(motion[p], floors.get(p, floor_t))
        if motion[p] < floors.get(p, floor_t):
            floored.add(p)
    return Yardstick(scale, frozenset(floored), length)


def case_floors(meta: Mapping) -> dict[str, float]:
    """Floors a case states in ``[[tolerances]]`` (output key or point -> case units)."""
    return {t["output"]: t["floor"] for t in meta.get("tolerances") or () if t.get("floor")}


def judged_outputs(meta: Mapping) -> list[Mapping] | None:
    """The case's ``[[tolerances]]`` (the outputs a designer judges), or None for the default
    set (every named point's ``.ux .uy .rot``)."""
    tols = meta.get("tolerances") or ()
    return list(tols) if tols else None


def describe(name: str = "error_rel") -> str:
    """One line saying what a yardstick is (for captions and table headers)."""
    return f"{name}: {YARDSTICKS[name]}"


def as_arrays(steps: Sequence[Mapping], keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Output key -> values along JSON-level steps (NaN where absent), shape (n,)."""
    out = {}
    for key in keys:
        vals = []
        for s in steps:
            v = s.get(key) if key in ("factor", "energy") else s["outputs"].get(key)
            vals.append(np.nan if v is None else float(v))
        out[key] = np.array(vals, dtype=float)
    return out
