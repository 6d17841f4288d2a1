"""Mechanism validity atlases: each reduced model's error against ``fem-auto`` over the driver
range x a second axis, with tolerance contours and the published validity claims drawn over.

The first axis is the case's own path: the load factor of a ``load`` analysis, the driver
coordinate of an ``energy`` or ``distance`` analysis.  The second axis is chosen per case class
(``axis_for``), because the load magnitude of a mechanism *is* its path (scaling it would only
repeat the first axis):

* ``direction`` -- load analyses of compliant guides and flexures (Ex. 2, the 26-DOF guide,
  the parallelogram and double-parallelogram flexures): every applied force turned by phi in
  [-30, 30] deg.  The component along the flexures is what stiffens or softens a parallel guide
  (Awtar's load-stiffening, the axial load p of the BCM's claimed range): it separates the
  member laws with axial-transverse coupling (BCM, FE) from those without (linear, PRB).
* ``slenderness`` -- bistable mechanisms that snap through axial strain (Ex. 3, the bistable
  toggle): the in-plane thickness of every flexible member scaled by s in [0.5, 2] with loads
  and springs scaled by s^3, so that only EA L^2 / EI = 12 (L / t)^2 changes.  Whether a leg
  stretches enough to snap is what decides the models (inextensible PRB and linear chains
  cannot shorten a leg).
* ``length`` -- driver-controlled (energy) mechanisms with a compliant member grounded at one
  end (Ex. 4): that member's length scaled by s in [0.7, 1.4] by moving its ground end along
  its own line.  The driver imposes the member's tip motion (kinematics), so its deflection
  relative to its length, which decides every member law's validity, scales as 1 / s; both
  stable positions and the rocker's unstressed pose are kept.
* no atlas (one line says why): no flexible member (kinetostatic is exact), synthesis,
  kinematics, deploy and sweep analyses.

Batching: per second-axis value one ``fem-auto`` solve along the whole path (its states are the
reference of every model at that value) and per model one path-following solve along the
driver (the case's own continuation), so an a x d atlas of m models is a (1 + m) solves, not
a d (1 + m) separate ones.

Error at a state: on the report's default yardstick (``error_rel``, ``reports.verdicts.yardstick``)
of the reference path along the driver at that axis value: |d ux|, |d uy| over the point's
largest displacement on that path, |d rot| over its largest rotation (floored where an output
barely moves) and, for driver analyses, the driven quantity (driver force / torque of energy
analyses, the load factor of distance analyses) over its largest reference magnitude.

Our tests of the published claims (on the reference's member shapes at each state;
``CLAIMS``, each linked to its record in ``reports.verdicts.claims``, where the publication's own
verdict is made): Awtar's BCM range |y| <= 0.1 L and the seed's "within 10 % slope change" per
BCM segment (``bcm``, ``cbcm-N``: the member split into N equal segments), Howell's PRB-1R
range Theta <= 64.3 deg per member (with the mechanism's average gamma 0.85).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

import cases
from cases.schema import Scene
from reduced_models.base import Solution
from reduced_models.beam import prb_tables as T
from reports import api
from reports.verdicts import yardstick as Y
from reports.verdicts.atlas_mech_axes import NoAtlas, axis_for, driven_key, driver_grid

MODELS = (
    "linear-1",
    "linear-8",
    "bcm",
    "cbcm-2",
    "cbcm-8",
    "prb-1r",
    "prb-3r",
    "prb-fsm-4",
    "prb-fsm-16",
)
CONTOURS = (1e-3, 1e-2, 5e-2)
REFERENCE = "fem-auto"


def path_table(sol: Solution, scene: Scene, grid: np.ndarray) -> dict[str, np.ndarray]:
    """Output key -> (d,) values at the grid's states (NaN where the path did not get).

    Load and energy steps are matched by their factor (the grid value); distance steps by
    their order (their factor is the solved load factor, one step per driver value)."""
    keys = [k for k in scene.output_keys() if k.rsplit(".", 1)[-1] in ("ux", "uy", "rot")]
    extra = driven_key(scene)
    out = {k: np.full(len(grid), np.nan) for k in [*keys, *([extra] if extra else [])]}
    tol = 1e-9 * (1.0 + float(np.max(np.abs(grid))))
    for i, st in enumerate(sol.steps):
        if scene.analysis.kind == "distance":
            j = i if i < len(grid) else -1
        else:
            hit = np.flatnonzero(np.abs(grid - st.factor) <= tol)
            j = int(hit[0]) if hit.size else -1
        if j < 0:
            continue
        for k in out:
            v = st.factor if k == "factor" else st.outputs.get(k)
            out[k][j] = np.nan if v is None else float(v)
    return out


def state_error(
    mod: dict[str, np.ndarray], ref: dict[str, np.ndarray], length: float
) -> np.ndarray:
    """(d,) ``error_rel`` at each state (module docstring); NaN where either path is
    missing.  The divisors are the yardstick of the reference path along the driver."""
    stick = Y.yardstick(ref, length)
    parts = [np.abs(mod[k] - r) / stick.rel(k) for k, r in ref.items()]
    return np.max(np.stack(parts), axis=0)


# -- claims on the reference's member shapes ------------------------------------------------
def _segment_measures(pts: np.ndarray, n: int) -> tuple[float, float, float]:
    """(max |y| / L_seg, max |tan slope|, Theta deg) of a member polyline (k, 2) split into
    ``n`` equal segments (by point count); y and slope of every point inside a segment are
    measured in the frame of the segment's start tangent (an S-shaped guided beam has equal
    end slopes but a large slope inside: the BCM's small-slope assumption is about that)."""
    k = len(pts) - 1
    idx = np.linspace(0, k, n + 1).round().astype(int)
    ys, slopes = [], []
    for a, b in zip(idx[:-1], idx[1:]):
        p = pts[a : b + 1]
        u = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
        rel = p - p[0]
        lseg = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        ys.append(float(np.max(np.abs(u[0] * rel[:, 1] - u[1] * rel[:, 0]))) / lseg)
        t = np.diff(p, axis=0)
        dth = np.arctan2(u[0] * t[:, 1] - u[1] * t[:, 0], t @ u)
        slopes.append(float(np.max(np.abs(np.tan(np.clip(dth, -1.5, 1.5))))))
    # Howell: the tip seen from the characteristic pivot at (1 - gamma) L along end a's tangent
    t0 = (pts[1] - pts[0]) / np.linalg.norm(pts[1] - pts[0])
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    rel = pts[-1] - pts[0]
    x = float(np.dot(rel, t0)) - (1.0 - T.HOWELL_AVERAGE["gamma"]) * length
    y = abs(float(t0[0] * rel[1] - t0[1] * rel[0]))
    return max(ys), max(slopes), math.degrees(math.atan2(y, x))


def member_measures(sol: Solution, scene: Scene, grid: np.ndarray, n: int) -> np.ndarray:
    """(d, 3) worst (|y|/L_seg, |tan dtheta|, Theta deg) over flexible members at each state."""
    flex = [m.id for m in scene.members if m.kind == "flexible"]
    out = np.full((len(grid), 3), np.nan)
    tol = 1e-9 * (1.0 + float(np.max(np.abs(grid))))
    for i, st in enumerate(sol.steps):
        j = i if scene.analysis.kind == "distance" else -1
        if j < 0:
            hit = np.flatnonzero(np.abs(grid - st.factor) <= tol)
            j = int(hit[0]) if hit.size else -1
        if not (0 <= j < len(grid)) or not all(f in st.shapes for f in flex):
            continue
        vals = [_segment_measures(np.asarray(st.shapes[f], float), n) for f in flex]
        out[j] = np.max(np.array(vals), axis=0)
    return out


@dataclass(frozen=True)
class Claim:
    """Our test of a published claim (``reports.verdicts.claims``, linked by ``claim_id``) read on
    mechanisms: in ``region`` (from the member measures of the model's segment count) the
    model's error is at most ``accuracy``.  The publication's own verdict is the record's;
    this is FlexBench's reading, applied to members of a mechanism."""

    label: str
    source: str
    accuracy: float
    applies: Callable[[str], int | None]  # model name -> segments per member (None: no claim)
    region: Callable[[np.ndarray], np.ndarray]  # (a, d, 3) measures -> (a, d) bool
    reading: str
    claim_id: str = ""


def _bcm_segments(name: str) -> int | None:
    if name == "bcm":
        return 1
    fam, _, n = name.rpartition("-")
    return int(n) if fam == "cbcm" and n.isdigit() else None


_OURS = (
    "FlexBench mechanism atlas (reports.verdicts.atlas_mech): our test, not the publication's claim"
)
CLAIMS = (
    Claim(
        "our test (awtar-bcm): |y| <= 0.1 L per segment, error <= 1 %",
        _OURS,
        1e-2,
        _bcm_segments,
        lambda m: m[..., 0] <= 0.1,
        "every BCM segment's end deflection within 0.1 of its length (in its start frame), "
        "'accurate' read as error <= 1 %; the axial-load bound is not checked here",
        "awtar-bcm",
    ),
    Claim(
        "our test (das2d-seed-bcm-slope): within 10 % slope change per segment, error <= 1 %",
        _OURS,
        1e-2,
        _bcm_segments,
        lambda m: m[..., 1] <= 0.1,
        "every segment's |tan(slope change)| <= 0.1; 'accurately' read as error <= 1 %",
        "das2d-seed-bcm-slope",
    ),
    Claim(
        "our test (howell-prb-1r): Theta <= 64.3 deg in every member, error <= 0.5 %",
        _OURS,
        5e-3,
        lambda name: 1 if name == "prb-1r" else None,
        lambda m: m[..., 2] <= T.HOWELL_N0["Theta_max_deg"],
        "Theta of each member's end seen from the pivot at (1 - 0.85) L (the average gamma the "
        "assembler uses) up to n = 0's Theta_max for every member; Howell's 0.5 % is about the "
        "characteristic-radius locus of one cantilever, read here as the mechanism's error",
        "howell-prb-1r",
    ),
)


@dataclass
class MechAtlas:
    """One case's atlas.

    Attributes
    ----------
    case, axis, axis_label, axis_why : the case and its second axis (``axis_for``).
    values : (a,) second-axis values; drive : (d,) first-axis values; drive_label : its name.
    ref_ok : (a,) whether ``fem-auto`` converged at each value; ref_s : its CPU seconds.
    error : model -> (a, d) state errors (NaN: declined, failed, or no reference).
    status : model -> (a,) statuses; message : model -> first non-converged reason.
    seconds : model -> CPU s of its whole atlas; single_s : model -> CPU s of one ordinary
        solve of the case (``cost_ratio``: seconds / (a d) / single_s).
    measures : segments N -> (a, d, 3) reference member measures (claims).
    claims : checked claims (``check_claims``).
    """

    case: str
    axis: str
    axis_label: str
    axis_why: str
    values: np.ndarray
    drive: np.ndarray
    drive_label: str
    ref_ok: np.ndarray
    ref_s: float = 0.0
    error: dict[str, np.ndarray] = field(default_factory=dict)
    status: dict[str, list[str]] = field(default_factory=dict)
    message: dict[str, str] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    single_s: dict[str, float] = field(default_factory=dict)
    measures: dict[int, np.ndarray] = field(default_factory=dict)
    claims: list[dict] = field(default_factory=list)
    wall_s: float = 0.0


def models_for(scene: Scene, models: Sequence[str] = MODELS) -> tuple[str, ...]:
    """``models`` plus ``mixed`` when the case assigns models per member."""
    mixed = any(m.model for m in scene.members if m.kind == "flexible")
    return tuple(models) + (("mixed",) if mixed and "mixed" not in models else ())


def compute(
    case: str | Scene,
    models: Sequence[str] = MODELS,
    n_axis: int = 9,
    progress: Callable[[str], None] | None = None,
) -> MechAtlas:
    """The atlas of ``case`` (module docstring); raises NoAtlas when it has none."""
    t_wall = time.perf_counter()
    scene = cases.load(case) if isinstance(case, str) else case
    ax = axis_for(scene, n_axis)
    grid, glabel = driver_grid(scene)
    length = max(scene.member_length(m.id) for m in scene.members)
    scenes = [ax.apply(scene, float(v)) for v in ax.values]
    t0 = time.process_time()
    refs = [api.solve(s, REFERENCE) for s in scenes]
    at = MechAtlas(
        scene.name,
        ax.name,
        ax.label,
        ax.why,
        ax.values,
        grid,
        glabel,
        np.array([r.ok for r in refs]),
        time.process_time() - t0,
    )
    ref_tabs = [path_table(r, s, grid) if r.ok else None for r, s in zip(refs, scenes)]
    models = models_for(scene, models)
    for n in {_bcm_segments(m) or 1 for m in models}:
        at.measures[n] = np.stack([member_measures(r, s, grid, n) for r, s in zip(refs, scenes)])
    for name in models:
        err = np.full((len(ax.values), len(grid)), np.nan)
        t0 = time.process_time()
        sols = [api.run_model(api.make_model(name, s), s, post=False) for s in scenes]
        at.seconds[name] = time.process_time() - t0
        t0 = time.process_time()
        api.run_model(api.make_model(name, scene), scene, post=False)
        at.single_s[name] = time.process_time() - t0
        for i, (sol, s) in enumerate(zip(sols, scenes)):
            if ref_tabs[i] is not None and sol.steps and sol.status != "not-applicable":
                err[i] = state_error(path_table(sol, s, grid), ref_tabs[i], length)
        at.error[name] = err
        at.status[name] = [s.status for s in sols]
        at.message[name] = next((s.message for s in sols if s.status != "converged"), "")
        if progress:
            progress(f"{scene.name} atlas: {name} {at.seconds[name]:.2f} s CPU")
    at.claims = check_claims(at)
    at.wall_s = time.perf_counter() - t_wall
    return at


def check_claims(at: MechAtlas) -> list[dict]:
    """Every applicable claim on ``at``: region, failing points, verdict, worst error."""
    out = []
    for c in CLAIMS:
        for name, err in at.error.items():
            n = c.applies(name)
            if n is None or n not in at.measures or not np.any(np.isfinite(err)):
                continue  # no claim for this model, or it declined / failed everywhere
            meas = at.measures[n]
            region = c.region(meas) & np.all(np.isfinite(meas), axis=-1)
            fails = region & ~(err <= c.accuracy)
            inside = np.where(region, err, np.nan)
            entry = {
                "model": name,
                "claim_id": c.claim_id,
                "label": c.label,
                "source": c.source,
                "reading": c.reading,
                "accuracy": c.accuracy,
                "points": int(region.sum()),
                "failing": int(fails.sum()),
                "verdict": "no points" if not region.any() else "fails" if fails.any() else "holds",
                "worst": float(np.nanmax(inside)) if np.any(np.isfinite(inside)) else None,
                "region": region,
                "fails": fails,
            }
            if fails.any():
                i, j = np.unravel_index(
                    np.argmax(np.where(fails, np.nan_to_num(err, nan=np.inf), -np.inf)), err.shape
                )
                entry["worst_at"] = {at.axis: float(at.values[i]), "drive": float(at.drive[j])}
            out.append(entry)
    return out


def cost_ratio(at: MechAtlas, name: str) -> float | None:
    """CPU cost of one atlas state as a fraction of one single solve of the case (the
    issue's per-state ratio: about 1 / d when the path-following batch works)."""
    if not at.seconds.get(name) or not at.single_s.get(name):
        return None
    return (at.seconds[name] / at.error[name].size) / at.single_s[name]


def as_json(at: MechAtlas) -> dict:
    """Embeddable atlas (rounded; NaN -> None)."""

    def r(a: np.ndarray, digits: int = 3) -> list:
        arr = np.asarray(a, dtype=float)
        flat = [None if not math.isfinite(v) else float(f"{v:.{digits}g}") for v in arr.ravel()]
        return np.array(flat, dtype=object).reshape(arr.shape).tolist()

    claims = [
        {
            **{k: v for k, v in c.items() if k not in ("region", "fails")},
            "region": c["region"].astype(int).tolist(),
            "fails": c["fails"].astype(int).tolist(),
        }
        for c in at.claims
    ]
    return {
        "case": at.case,
        "axis": at.axis,
        "axis_label": at.axis_label,
        "axis_why": at.axis_why,
        "values": r(at.values, 4),
        "drive": r(at.drive, 4),
        "drive_label": at.drive_label,
        "ref_ok": at.ref_ok.astype(int).tolist(),
        "ref_s": round(at.ref_s, 3),
        "wall_s": round(at.wall_s, 2),
        "models": {
            name: {
                "error": r(err),
                "message": at.message[name],
                "seconds": round(at.seconds[name], 3),
                "single_s": round(at.single_s[name], 4),
                "cost_ratio": cost_ratio(at, name),
            }
            for name, err in at.error.items()
        },
        "claims": claims,
        "contours": list(CONTOURS),
    }


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m reports.verdicts.atlas_mech CASE...``: atlas time, per-state cost ratio,
    claims."""
    import argparse

    from cases.load import CaseError

    parser = argparse.ArgumentParser(
        prog="python -m reports.verdicts.atlas_mech", description=main.__doc__
    )
    parser.add_argument("cases", nargs="+", help="catalog names or TOML paths")
    for name in parser.parse_args(argv).cases:
        try:
            at = compute(name)
        except NoAtlas as exc:
            print(f"{name}: no atlas: {exc}")
            continue
        except CaseError as exc:  # one line, as the CLI does for bad input
            print(f"{name}: {exc}")
            return 2
        a, d = at.error[next(iter(at.error))].shape
        print(
            f"{name}: {a} x {d} states ({at.axis}), {at.wall_s:.2f} s wall, "
            f"reference {at.ref_s:.2f} s CPU"
        )
        for m in at.error:
            ratio = cost_ratio(at, m)
            worst = np.nanmax(at.error[m]) if np.any(np.isfinite(at.error[m])) else math.nan
            txt = "-" if ratio is None else f"{ratio:.3g}"
            print(
                f"  {m:<11} {at.seconds[m]:7.3f} s CPU, single solve {at.single_s[m] * 1e3:.3g} "
                f"ms, per state {txt} x a single solve, worst error {worst:.3g}"
            )
        for c in at.claims:
            n_fail = f"{c['failing']}/{c['points']}"
            print(f"  claim {c['model']}: {c['label']}: {c['verdict']} ({n_fail})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
