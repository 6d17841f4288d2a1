"""Published validity claims, each judged in the publication's own metric, region and values.

A ``Claim`` record holds what the publication said (source, its words, the metric and region it
states, the parameter values it used) and names the evaluator that checks it exactly so.  Where
FlexBench's own reading is stricter (another metric, a wider region, our fitted parameters), it
is evaluated beside the record as ``ours`` on the validity atlas (``reports.verdicts.atlas.CLAIMS``,
linked by ``claim_id``) and labelled as our test, never as the publication's failure.

Evaluators:

* ``howell_locus`` (``reports.verdicts.claims_howell``) -- Howell's PRB-1R in his own metric: the
  radial distance of the exact elastica's tip from the characteristic-radius circle over the
  deflection, with the TABULATED gamma(n), up to Theta_max(n); figure n = 0, ``rows`` every
  tabulated n.
* ``cannot_check`` -- the publication's metric, threshold or example data are not available
  here; the record says which.

``evaluate_all`` returns plain dicts (the ``flexbench claims --json`` objects of DESIGN.md),
cached on disk per code version (``cache_dir``) so the command answers in well under 10 s.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from reduced_models.beam import prb_tables as T
from reports.verdicts import claims_howell

# force-atlas grid of the ``ours`` readings: the teaching page's default (40 magnitudes in
# (0, 10], 41 directions), so the CLI and the page report the same figures
ATLAS_GRID = (40, 41)
VERDICTS = ("holds", "fails", "cannot-check")


@dataclass(frozen=True)
class Claim:
    """One published validity claim.

    Attributes
    ----------
    id : stable identifier (``howell-prb-1r``, ...).
    model : the FlexBench model the claim is about.
    source : citation (paper, section, table).
    claim : the publication's words (quoted).
    metric, region : what is measured and where, as the publication states it.
    parameters : the parameter values the publication used (its table, not our fit).
    claimed : the stated accuracy as a fraction (0.005 = 0.5 %), or None if none is stated.
    evaluator : ``howell_locus`` | ``cannot_check``.
    why : for ``cannot_check``: which data are missing.
    """

    id: str
    model: str
    source: str
    claim: str
    metric: str
    region: str
    parameters: Mapping[str, Any] = field(default_factory=dict)
    claimed: float | None = None
    evaluator: str = "cannot_check"
    why: str = ""


HOWELL_SOURCE = (
    "Howell & Midha, J. Mech. Des. 117:156-165, 1995, doi 10.1115/1.2826101; "
    "Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.6, Table 5.1"
)

CLAIMS = (
    Claim(
        id="howell-prb-1r",
        model="prb-1r",
        source=HOWELL_SOURCE,
        claim=(
            "'The approximations are accurate to within 0.5% of the closed-form elliptic "
            "integral solutions' (Howell & Midha, abstract of the ASME DETC 1992 paper the "
            "1995 journal paper extends), for pseudo-rigid-body angles up to the tabulated "
            "Theta_max(gamma) of each load ratio n (Howell 2001, Table 5.1)"
        ),
        metric=(
            "Howell's relative tip-locus error: |distance of the exact elastica's tip from the "
            "characteristic pivot ((1 - gamma) L, 0) - gamma L| / tip deflection (distance of "
            "the tip from its undeflected position)"
        ),
        region=(
            "dead tip force P(-n, 1), n > 0 compressive; 0 < Theta <= Theta_max(n), Theta = "
            "angle of the elastica's tip seen from the characteristic pivot; figure: n = 0 "
            "(Theta_max 64.3 deg), ``rows``: every tabulated n"
        ),
        parameters={
            "n": 0.0,
            "gamma": T.HOWELL_N0["gamma"],
            "Theta_max_deg": T.HOWELL_N0["Theta_max_deg"],
            "table_n": T.HOWELL_TABLE_N.tolist(),
            "table_gamma": T.HOWELL_TABLE_GAMMA.tolist(),
        },
        claimed=5e-3,
        evaluator="howell_locus",
    ),
    Claim(
        id="su-prb-3r",
        model="prb-3r",
        source="Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148 (abstract)",
        claim=(
            "'a compliant four-bar linkage is studied and verified by a numerical example. "
            "The result shows a maximum tip deflection error of 1.2% compared with the finite "
            "element analysis model.'"
        ),
        metric="maximum tip-deflection error of the PRB-3R four-bar against Su's FEA model",
        region="that one four-bar example; Su states no range of loads or deflections",
        parameters={"gamma": list(T.SU_GAMMA), "k": list(T.SU_K["average"])},
        claimed=1.2e-2,
        why=(
            "the four-bar's link lengths, beam section and material, its input motion and "
            "Su's FEA tip deflections are in the paper's example section, which this project "
            "does not hold and the public material searched does not give (only the "
            "abstract); a four-bar of our own making would test a different example, and the "
            "1.2 % is not a range claim to be tested over other loads"
        ),
    ),
    Claim(
        id="awtar-bcm",
        model="bcm",
        source=(
            "Awtar, Slocum & Sevincer, J. Mech. Des. 129:625-639, 2007, doi 10.1115/1.2717231; "
            "range as restated by Ma, Chen & Hao, Mech. Sci. 9:71-79, 2018"
        ),
        claim=(
            "'simple yet accurate approximations that capture the effects of load-stiffening "
            "and elastokinematic non-linearities in beams' (Awtar et al.); 'developed for ... "
            "accurately ... modeling nonlinear behaviors of a planar beam flexure over an "
            "intermediate range of transverse deflections (10 % of the beam length)' (Ma et al.)"
        ),
        metric="not stated: 'accurate', validated against FEA without an error bound",
        region="transverse deflection |y| <= 0.1 L; axial load inside the BCM's stable range",
        why=(
            "the publication gives no accuracy figure or error metric for the BCM itself, so "
            "there is no threshold to judge against; our test (tip position error <= 1 % of L "
            "in that range) is shown beside it"
        ),
    ),
    Claim(
        id="das2d-seed-bcm-slope",
        model="bcm",
        source="DAS-2D seed 000_265bc60728766176.txt, 'BCM' slide",
        claim=(
            "'Deflections within 10 % slope change of the beam length can be accurately "
            "captured by a single BCM beam.'"
        ),
        metric="not stated: 'accurately', no error measure",
        region="slope change within 10 % (read as |tan(tip rotation)| <= 0.1)",
        why=(
            "the slide states no accuracy figure or error metric, so there is no threshold "
            "to judge against; our test (tip position error <= 1 % of L in that range) is "
            "shown beside it"
        ),
    ),
)


def by_id(claim_id: str) -> Claim:
    """The registered claim ``claim_id`` (KeyError if none)."""
    for c in CLAIMS:
        if c.id == claim_id:
            return c
    raise KeyError(claim_id)


def cannot_check(claim: Claim) -> dict[str, Any]:
    """A claim whose metric, threshold or example data are not available here."""
    return {"worst": None, "at": {}, "verdict": "cannot-check", "note": claim.why}


EVALUATORS: dict[str, Callable[[Claim], dict[str, Any]]] = {
    "howell_locus": claims_howell.howell_locus,
    "cannot_check": cannot_check,
}


# -- our readings, beside the records --------------------------------------------------------
_METRICS = {
    "locus": "distance of the model's tip to the exact elastica's tip path / tip deflection",
    "pos": "tip position error of the model against the exact elastica / L",
    "error": "largest of |d ux| / L, |d uy| / L, |d rot| (rad) against the exact elastica",
}


def _atlas_test(test: Any, at: Any) -> dict[str, Any]:
    """One of our atlas tests (``reports.verdicts.atlas.Claim``) on ``at``: worst inside its region,
    where, and its verdict (a state where the model failed counts as failing)."""
    region = test.region(at) & np.all(np.isfinite(at.ref), axis=-1)
    metric = getattr(at, test.metric)[test.model]
    fails = region & ~(metric <= test.accuracy)
    score = np.where(region, np.nan_to_num(metric, nan=np.inf), -np.inf)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    angle = float(at.angles[i])
    n = -1.0 / math.tan(math.radians(angle)) if 0.0 < angle < 180.0 else None
    return {
        "worst": float(score[i, j]) if region.any() else None,
        "at": {"load_angle_deg": angle, "n": n, "PL2_EI": float(at.mags[j])}
        if region.any()
        else {},
        "verdict": "holds" if region.any() and not fails.any() else "fails",
        "points": int(region.sum()),
        "failing": int(fails.sum()),
    }


def ours(claim: Claim, at: Any) -> dict[str, Any] | None:
    """Our stricter reading of ``claim`` on the force atlas ``at``: the widest of its atlas
    tests (listed last in ``reports.verdicts.atlas.CLAIMS``); the narrower ones go into the note."""
    from reports.verdicts import atlas

    tests = [t for t in atlas.CLAIMS if t.claim_id == claim.id and t.model in at.error]
    if not tests:
        return None
    main = tests[-1]
    res = _atlas_test(main, at)
    extra = []
    for t in tests[:-1]:
        r = _atlas_test(t, at)
        extra.append(f"{t.label}: {r['verdict']}, worst {_pct(r['worst'])}")
    note = f"{main.reading}; {res['failing']} of {res['points']} atlas states fail"
    return {
        "id": f"{claim.id}/ours",
        "model": main.model,
        "source": main.source,
        "claim": main.label,
        "metric": f"{main.metric}: {_METRICS[main.metric]}",
        "region": main.label.removeprefix("our test: "),
        "parameters": {"atlas_grid": [len(at.mags), len(at.angles)], "family": at.family},
        "claimed": main.accuracy,
        "worst": res["worst"],
        "at": res["at"],
        "verdict": res["verdict"],
        "note": "; ".join([note, *extra]),
    }


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x * 100:.3g} %"


def evaluate(claim: Claim, at: Any = None) -> dict[str, Any]:
    """The ``flexbench claims`` object of ``claim``; ``at``: the force atlas for ``ours``."""
    res = EVALUATORS[claim.evaluator](claim)
    assert res["verdict"] in VERDICTS
    return {
        "id": claim.id,
        "model": claim.model,
        "source": claim.source,
        "claim": claim.claim,
        "metric": claim.metric,
        "region": claim.region,
        "parameters": dict(claim.parameters),
        "claimed": claim.claimed,
        **res,
        "ours": None if at is None else ours(claim, at),
    }


def force_atlas(grid: tuple[int, int]) -> Any:
    """The force atlas of the models the claims are about (our readings are read on it)."""
    from reports.verdicts import atlas

    models = tuple(dict.fromkeys(c.model for c in CLAIMS))
    return atlas.compute("force", models, *grid)


def cache_dir() -> Path:
    """``$FLEXBENCH_CACHE``, else ``$XDG_CACHE_HOME/flexbench``, else ``~/.cache/flexbench``."""
    env = os.environ.get("FLEXBENCH_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "flexbench"


def _cache_key(grid: tuple[int, int]) -> str:
    """Code version of everything the records depend on: solver packages, atlas, this file."""
    from reports.run.tables import code_hash

    h = hashlib.sha1(f"{code_hash()}|{grid}".encode())
    here = Path(__file__).resolve().parent
    for path in (here / "claims.py", here / "claims_howell.py", here / "atlas.py"):
        h.update(path.read_bytes())
    h.update((here.parent / "api.py").read_bytes())
    return h.hexdigest()[:12]


def evaluate_all(at: Any = None, grid: tuple[int, int] | None = None) -> list[dict[str, Any]]:
    """Every registered claim (``evaluate``).  ``at``: a force atlas already computed (the
    teaching page's); without it the atlas of ``grid`` (default ``ATLAS_GRID``) is computed,
    and the whole answer is cached per code version under ``cache_dir()`` (an unwritable
    cache is only slower)."""
    if at is not None:
        return [evaluate(c, at) for c in CLAIMS]
    grid = grid or ATLAS_GRID
    path = cache_dir() / f"claims-{grid[0]}x{grid[1]}-{_cache_key(grid)}.json"
    try:
        return json.loads(path.read_text(encoding="utf-8"))["claims"]
    except (OSError, ValueError, KeyError):
        pass
    out = _finite(evaluate_all(force_atlas(grid)))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        for stale in path.parent.glob(f"claims-{grid[0]}x{grid[1]}-*.json"):
            stale.unlink(missing_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"claims": out}, allow_nan=False), encoding="utf-8")
        tmp.replace(path)
    except OSError:
        pass
    return out


def _finite(x: Any) -> Any:
    """``x`` with numpy scalars as Python numbers and NaN/inf as None (JSON has neither)."""
    if isinstance(x, Mapping):
        return {str(k): _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, float, np.integer, np.floating)):
        v = float(x) if not isinstance(x, (int, np.integer)) else int(x)
        return v if math.isfinite(v) else None
    return x


def as_json(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The ``flexbench claims --json`` object of DESIGN.md."""
    return {"claims": _finite(records)}


def format_table(records: list[dict[str, Any]]) -> str:
    """A readable table: one line per claim (and per our reading), then the notes."""
    head = f"{'claim':<28} {'model':<8} {'verdict':<13} {'claimed':>8} {'worst':>9}  where"
    lines = [head, "-" * len(head)]
    notes = []
    for r in records:
        rows = [(r["id"], r)] + ([("  our test", r["ours"])] if r.get("ours") else [])
        for name, x in rows:
            where = ", ".join(
                f"{k} {v:.4g}" for k, v in x.get("at", {}).items() if isinstance(v, float)
            )
            lines.append(
                f"{name:<28} {x['model']:<8} {x['verdict']:<13} {_pct(x['claimed']):>8} "
                f"{_pct(x['worst']):>9}  {where}"
            )
        notes.append(f"{r['id']} ({r['source']}): {r['claim']}\n  metric: {r['metric']}")
        notes.append(f"  region: {r['region']}\n  {r['note']}")
        for row in r.get("rows", ()):
            notes.append(
                f"    n = {row['n']:<5g} gamma {row['gamma']:.4f}  Theta_max "
                f"{row['Theta_max_deg']:6.2f} deg  worst {_pct(row['worst']):>9} at Theta "
                f"{row['at']['Theta_deg']:6.2f}  {row['verdict']}"
            )
        if r.get("ours"):
            notes.append(f"  {r['ours']['claim']} -- {r['ours']['note']}")
    return "\n".join(lines + [""] + notes)
