"""Validity atlases: each reduced model's error against the exact elastica over load space.

Families (a clamped beam, L = 1, EI = 1, EA = 1e12 EI/L^2 so that the inextensible elastica
is the exact answer and the atlas shows model error, not axial stretch):

* ``force``: dead tip force of magnitude PL^2/EI in (0, 10] (``n_mag`` values) at angle alpha
  from the beam axis in [0, 180] deg (``n_ang`` values, default 41 so that 90 is on the grid):
  0 pure tension, 90 transverse, 180 pure compression (Howell's load ratio n = -cot alpha);
* ``follower``: follower tip force of the same magnitudes at angle alpha to the tip tangent;
* ``moment``: end moment ML/EI in (0, 2 pi] (one row: the roll-up to a full circle).

Batching: one load ramp per direction, whose ``n_mag`` steps are the atlas's magnitudes, so a
40 x 40 atlas is 40 continuation runs per model (the path to each magnitude is reused), not
1600 separate solves.  The error at a state is on the report's default yardstick
(``error_rel``, ``state_error_rel``): the largest of |d ux|, |d uy| over the tip's largest
displacement on the ramp to that state and |d rot| over its largest rotation (``pos`` keeps
the tip position error over L).  ``locus`` is the distance from
the model's tip to the elastica's tip path of the same direction, divided by the tip
deflection: our stricter reading of Howell's 0.5 % claim (the model's own tip, not the
characteristic-radius circle Howell measures; the claim itself is judged in
``reports.verdicts.claims``); for the ``force`` family that path is solved ``FINE`` times denser
than the grid, for the others (no claim reads their locus) it is the grid's own.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

import cases
from cases.schema import Scene
from reduced_models.base import Solution
from reduced_models.beam import prb_tables as T
from reduced_models.registry import DEFAULT_NAMES
from reports import api
from reports.verdicts import yardstick as Y

# the default run's reduced single-beam models: not the exact references (the atlas is
# measured against the elastica), the mechanism-only models or the self-refining *-auto
MODELS = tuple(
    n
    for n in DEFAULT_NAMES
    if not n.startswith("elastica")
    and n not in ("kinetostatic", "mixed")
    and not n.endswith("-auto")
)
FAMILIES = ("force", "follower", "moment")
CONTOURS = (1e-3, 1e-2, 5e-2)
MAG_MAX = {"force": 10.0, "follower": 10.0, "moment": 2.0 * math.pi}
EA_OVER_EI = 1e12
# elastica steps per atlas step: the dense tip path is the locus Howell's claim is judged on
# (a force-family claim); the other families' locus is read off the atlas grid itself
FINE = {"force": 8}


@dataclass
class Atlas:
    """Errors of one family on a (direction, magnitude) grid.

    Attributes
    ----------
    family : ``force`` | ``follower`` | ``moment``.
    mags : (m,) load magnitudes (PL^2/EI, or ML/EI).
    angles : (a,) directions in deg (one 0 for ``moment``).
    ref : (a, m, 3) elastica tip ux, uy, rot (NaN where it failed).
    error, pos, locus : model -> (a, m) error on the default yardstick (``error_rel``, see
        ``state_error_rel``), tip position error / L and locus error / deflection (NaN where
        the model declined or failed).
    status : model -> (a,) statuses of the direction's run; message : model -> first reason.
    seconds : model -> CPU seconds of its whole atlas; single_s : model -> CPU seconds of one
        ordinary 20-step solve of a single state (per-state cost ratio = single_s /
        (seconds / states)).
    """

    family: str
    mags: np.ndarray
    angles: np.ndarray
    ref: np.ndarray
    error: dict[str, np.ndarray] = field(default_factory=dict)
    pos: dict[str, np.ndarray] = field(default_factory=dict)
    locus: dict[str, np.ndarray] = field(default_factory=dict)
    status: dict[str, list[str]] = field(default_factory=dict)
    message: dict[str, str] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    single_s: dict[str, float] = field(default_factory=dict)


@functools.lru_cache(maxsize=1)
def _base() -> Scene:
    """The catalog cantilever, parsed once (an atlas builds a scene per direction)."""
    return cases.load("cantilever-tip-load")


def scene_for(family: str, magnitude: float, angle_deg: float, steps: int) -> Scene:
    """The atlas's cantilever with its load at factor 1 and ``steps`` equal load steps."""
    base = _base()
    mem = dataclasses.replace(base.members[0], A=EA_OVER_EI * base.members[0].I)
    a = math.radians(angle_deg)
    (load,) = base.loads
    if family == "moment":
        load = dataclasses.replace(load, fx=0.0, fy=0.0, moment=magnitude)
    else:
        fx, fy = magnitude * math.cos(a), -magnitude * math.sin(a)
        load = dataclasses.replace(load, fx=fx + 0.0, fy=fy + 0.0, follower=family == "follower")
    name = f"atlas-{family}-{angle_deg:g}deg"
    return dataclasses.replace(
        base,
        name=name,
        members=(mem,),
        loads=(load,),
        references=(),
        analysis=dataclasses.replace(base.analysis, steps=steps),
    )


def grid(family: str, n_mag: int = 40, n_ang: int = 41) -> tuple[np.ndarray, np.ndarray]:
    """(magnitudes (n_mag,), angles in deg (n_ang,)) of a family's atlas."""
    mags = MAG_MAX[family] * np.arange(1, n_mag + 1) / n_mag
    angles = np.zeros(1) if family == "moment" else np.linspace(0.0, 180.0, n_ang)
    return mags, angles


def _tips(sol: Solution, n_mag: int) -> np.ndarray:
    """(n_mag, 3) tip ux, uy, rot at steps 1..n_mag (NaN beyond a failure)."""
    out = np.full((n_mag, 3), np.nan)
    for s in sol.steps[1 : n_mag + 1]:
        j = int(round(s.factor * n_mag)) - 1
        if 0 <= j < n_mag:
            out[j] = [s.outputs["tip.ux"], s.outputs["tip.uy"], s.outputs["tip.rot"]]
    return out


def _locus_distance(pts: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance of points (m, 2) to the polyline ``path`` (k, 2), shape (m,)."""
    a, b = path[:-1][None], path[1:][None]  # (1, k-1, 2)
    p = pts[:, None]  # (m, 1, 2)
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0, 1)
    d = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)
    return np.min(np.where(np.isfinite(d), d, np.inf), axis=1)


def state_error_rel(d: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``error_rel`` of the states of ramps along the magnitude axis, shape (a, m).

    ``d`` and ``ref`` are (a, m, 3) tip (ux, uy, rot) errors and exact values.  The state at
    magnitude m is the end of a ramp from zero, so its yardstick is that ramp's (as for a path
    error, ``reports.verdicts.yardstick``): translations over the tip's largest displacement up to
    m, the rotation over its largest rotation up to m, each floored at ``FLOOR_FRACTION`` of the
    ramp's characteristic motion (its displacement, or displacement / L with L = 1) and at
    round-off (``ROUNDOFF_FRACTION``).
    """
    move = np.fmax.accumulate(np.hypot(ref[..., 0], ref[..., 1]), axis=1)
    turn = np.fmax.accumulate(np.abs(ref[..., 2]), axis=1)
    floor_t = np.fmax(Y.FLOOR_FRACTION * move, Y.ROUNDOFF_FRACTION)  # L = 1
    floor_r = np.fmax(Y.FLOOR_FRACTION * np.fmax(turn, move), Y.ROUNDOFF_FRACTION)
    with np.errstate(invalid="ignore", divide="ignore"):
        trans = np.max(np.abs(d[..., :2]), axis=-1) / np.fmax(move, floor_t)
        rot = np.abs(d[..., 2]) / np.fmax(turn, floor_r)
    return np.maximum(trans, rot)  # NaN (a failed model) stays NaN


def _model_block(
    family: str, name: str, n_mag: int, n_ang: int, dense: np.ndarray
) -> dict[str, object]:
    """One model's atlas arrays against the dense reference (a worker's unit of work)."""
    mags, angles = grid(family, n_mag, n_ang)
    fine = FINE.get(family, 1)
    ref = dense[:, fine - 1 :: fine]
    scenes = [scene_for(family, mags[-1], a, n_mag) for a in angles]

    def solve(scene: object) -> object:  # the solve alone (no shapes): what is timed
        return api.run_model(api.make_model(name, scene), scene, post=False)

    t0 = time.process_time()
    sols = [solve(s) for s in scenes]
    seconds = time.process_time() - t0
    # one ordinary 20-step solve of a single state, for the per-state cost ratio
    t0 = time.process_time()
    solve(scene_for(family, mags[-1], angles[len(angles) // 2], 20))
    single = time.process_time() - t0
    tips = np.stack([_tips(sol, n_mag) for sol in sols])
    d = tips - ref
    rel = state_error_rel(d, ref)
    paths = np.concatenate([np.zeros((len(angles), 1, 2)), dense[:, :, :2]], axis=1)
    defl = np.linalg.norm(ref[:, :, :2], axis=-1)
    locus = np.stack([_locus_distance(tips[i, :, :2], paths[i]) for i in range(len(angles))])
    return {
        "pos": np.hypot(d[..., 0], d[..., 1]),
        "error": rel,
        "locus": locus / np.where(defl > 0, defl, np.nan),
        "status": [s.status for s in sols],
        "message": next((s.message for s in sols if s.status != "converged"), ""),
        "seconds": seconds,
        "single_s": single,
    }


def compute(
    family: str = "force",
    models: Sequence[str] = MODELS,
    n_mag: int = 40,
    n_ang: int = 41,
    workers: int = 1,
    progress: Callable[[str], None] | None = None,
) -> Atlas:
    """The atlas of ``models`` for one family (see module docstring); ``workers`` > 1 spreads
    the models over that many processes."""
    mags, angles = grid(family, n_mag, n_ang)
    # the elastica on a grid FINE times denser: its tip path is the locus the models are
    # measured against (chord error of the polyline ~ 1/FINE^2)
    k = FINE.get(family, 1)
    fine = [scene_for(family, mags[-1], a, k * n_mag) for a in angles]
    exact = (api.run_model(api.make_model("elastica", s), s, post=False) for s in fine)
    dense = np.stack([_tips(sol, k * n_mag) for sol in exact])  # tips only: no shapes
    atlas = Atlas(family, mags, angles, dense[:, k - 1 :: k])
    args = [(family, name, n_mag, n_ang, dense) for name in models]
    if workers > 1 and len(models) > 1:
        import concurrent.futures as cf

        with cf.ProcessPoolExecutor(min(workers, len(models))) as pool:
            blocks = list(pool.map(_model_block, *zip(*args)))
    else:
        blocks = [_model_block(*a) for a in args]
    for name, b in zip(models, blocks):
        keys = ("error", "pos", "locus", "status", "message", "seconds", "single_s")
        for key in keys:
            getattr(atlas, key)[name] = b[key]
        if progress:
            progress(f"{family} atlas: {name} {b['seconds']:.2f} s CPU")
    return atlas


# -- our readings of the published claims on this atlas ----------------------------------------
@dataclass(frozen=True)
class Claim:
    """Our test of a published claim (``reports.verdicts.claims``, linked by ``claim_id``) on an
    atlas:
    where (``region`` of the reference state) and how good (``accuracy`` on ``metric``:
    ``locus``, ``pos`` or ``error``).  The publication's own verdict is the record's
    (``reports.verdicts.claims.evaluate_all``); these are FlexBench's stricter or wider readings."""

    model: str
    family: str
    label: str
    source: str
    accuracy: float
    metric: str
    region: Callable[[Atlas], np.ndarray]
    reading: str = ""
    claim_id: str = ""


def _howell_n0(at: Atlas) -> np.ndarray:
    """Howell's tabulated case n = 0 (transverse load) only."""
    return _howell_region(at) & (np.abs(at.angles - 90.0) < 1e-9)[:, None]


def _howell_region(at: Atlas) -> np.ndarray:
    """-5 < n <= 10 and the PRB angle Theta of the elastica's tip (seen from the
    characteristic pivot at (1 - gamma(n)) L, gamma from Howell's curve fit) at most 64.3 deg
    (the Theta_max of n = 0, applied to every n: our reading, wider than Howell's)."""
    alpha = np.radians(at.angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = -np.cos(alpha) / np.sin(alpha)
    lo, hi = T.HOWELL_N_RANGE
    inside_n = (n > lo) & (n <= hi) & np.isfinite(n)
    gamma = np.array([T.howell_gamma(float(x)) if ok else np.nan for x, ok in zip(n, inside_n)])
    x_rel = 1.0 + at.ref[..., 0] - (1.0 - gamma[:, None])
    theta = np.degrees(np.arctan2(np.abs(at.ref[..., 1]), x_rel))
    return inside_n[:, None] & (theta <= T.HOWELL_N0["Theta_max_deg"])


def _bcm_region(at: Atlas) -> np.ndarray:
    p = at.mags[None] * np.cos(np.radians(at.angles))[:, None]  # axial PL^2/EI, tension +
    return (np.abs(at.ref[..., 1]) <= 0.1) & (p > -(math.pi**2) / 4)


_OURS = "FlexBench validity atlas (reports.verdicts.atlas): our test, not the publication's claim"
_LOCUS = (
    "locus: distance of the prb-1r model's tip (gamma, K_Theta from Howell's curve fits) to "
    "the elastica's tip path of the same load direction, over the deflection"
)
CLAIMS = (
    Claim(
        "prb-1r",
        "force",
        "our test: PRB-1R model tip at n = 0, Theta <= 64.3 deg",
        _OURS,
        5e-3,
        "locus",
        _howell_n0,
        _LOCUS + "; the model's fitted gamma 0.8521, not the table's 0.8517",
        "howell-prb-1r",
    ),
    Claim(
        "prb-1r",
        "force",
        "our test: PRB-1R model tip over -5 < n <= 10 at n = 0's Theta <= 64.3 deg",
        _OURS,
        5e-3,
        "locus",
        _howell_region,
        _LOCUS + "; n = 0's Theta_max 64.3 deg applied to every n (Howell's Theta_max "
        "depends on n)",
        "howell-prb-1r",
    ),
    Claim(
        "prb-3r",
        "force",
        "our test: PRB-3R tip within 1.2 % of L for tip slopes up to 90 deg",
        _OURS,
        1.2e-2,
        "pos",
        lambda at: np.abs(at.ref[..., 2]) <= math.pi / 2,
        "Su's single four-bar figure (1.2 %) carried over to cantilever force states as tip "
        "position error / L: Su claims no such range",
        "su-prb-3r",
    ),
    Claim(
        "bcm",
        "force",
        "our test: BCM tip within 1 % of L for |y| <= 0.1 L, p above -pi^2/4",
        _OURS,
        1e-2,
        "pos",
        _bcm_region,
        "intermediate-deflection range; 'accurate' read as tip position error <= 1 % of L",
        "awtar-bcm",
    ),
    Claim(
        "bcm",
        "force",
        "our test: single BCM tip within 1 % of L for |tan(tip rotation)| <= 0.1",
        _OURS,
        1e-2,
        "pos",
        lambda at: np.abs(np.tan(at.ref[..., 2])) <= 0.1,
        "'within 10 % slope change' read as |tan(rot)| <= 0.1; 'accurately' read as tip "
        "position error <= 1 % of L",
        "das2d-seed-bcm-slope",
    ),
)


def check_claim(claim: Claim, at: Atlas) -> dict[str, object]:
    """Whether ``claim`` holds on ``at``: the worst metric inside its region and where."""
    region = claim.region(at) & np.all(np.isfinite(at.ref), axis=-1)
    metric = getattr(at, claim.metric)[claim.model]
    inside = np.where(region, metric, np.nan)
    fails = region & ~(metric <= claim.accuracy)  # NaN (model failed) counts as a failure
    out: dict[str, object] = {
        "model": claim.model,
        "label": claim.label,
        "source": claim.source,
        "reading": claim.reading,
        "accuracy": claim.accuracy,
        "metric": claim.metric,
        "points": int(region.sum()),
        "failing": int(fails.sum()),
        "holds": bool(region.any() and not fails.any()),
        "verdict": "no points" if not region.any() else "holds" if not fails.any() else "fails",
        "worst": float(np.nanmax(inside)) if np.any(np.isfinite(inside)) else None,
    }
    if fails.any():
        worst = np.where(fails, np.nan_to_num(metric, nan=np.inf), -np.inf)
        i, j = np.unravel_index(np.argmax(worst), metric.shape)
        out["worst_at"] = {"angle_deg": float(at.angles[i]), "magnitude": float(at.mags[j])}
    return out
