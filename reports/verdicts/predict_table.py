"""The predicted-error table: each reduced model's error at the end-load states of one member.

A flexible member in its own frame (clamped at its end a, x along the tangent there, loads at
end b) is loaded by an end force of magnitude P at angle alpha from its axis and an end moment
M.  Nondimensionalised (PL^2/EI, alpha, ML/EI) and mirrored so that the force's transverse
component points to -y (alpha in [0, 180] deg; M > 0 then *opposes* the force's bending, as a
guide's reaction does), this three-parameter state is what decides a member law's error.
The table holds every reduced model's ``error_rel`` (``reports.verdicts.atlas.state_error_rel``, the
atlases' yardstick) at

* ``dead``: dead force plus moment on the polar grid ``PL^2/EI = rho cos beta``,
  ``ML/EI = rho sin beta``, rho in (0, 10] (``N_RHO`` = 20 values), mixing angle beta in
  [-90, 90] deg in 11.25 deg steps (``BETAS``: 0 is the ``force`` atlas, 90 the ``moment``
  atlas, atan(1/2) = 26.6 deg a transversely loaded fixed-guided beam), alpha in ``ANGLES``;
* ``follower``: follower force (alpha from the tip tangent), no moment, rho in (0, 10].

Arrays: ``dead_error`` (models, alpha, beta, rho, 2) and ``follower_error`` (models, alpha,
rho, 2), log10 of the errors (``stored``), the last axis the error of the tip translations and
of the tip rotation, each on its own excursion (a guided end is judged on the first alone);
``dead_ref`` (alpha, beta, rho, 3) and ``follower_ref`` the exact tip (ux, uy, rot), from which
a deformed member's end state is looked up (``reports.verdicts.predict``).

The last angle is 179.9 deg, not 180: an exactly axial compression stays straight in every
model (error 0) while any real column (the catalog's has a 1e-3 imperfection, 0.057 deg) takes
the post-buckled branch; states closer to 180 deg read that row.

Batching as in ``reports.verdicts.atlas``: one proportional ramp of ``N_RHO`` equal steps per
(alpha, beta) for each model and for the exact elastica, so the table is
13 x 16 + 13 ramps per model (beta = +-90 is one ramp: alpha plays no part without a force).

Resolution.  The error surfaces are smooth in alpha (15 deg steps: a cell-centre path reads
within 10 % of a direct solve) and along rho (monotone or slowly varying; the yardstick
divides by the ramp's own excursion, so error_rel tends to a constant as rho -> 0, which is
why states below the first ring read it).  Beta matters more (the end moment can cancel the
force's bending, where the tip rotation crosses zero): 11.25 deg steps.  Measured on 128 paths
through cell centres (8 models x 8 cells x rho up to 5 and 10, the worst place for
interpolation): predicted / direct median 1.00, 81 % within 1.5x, 86 % within 2x (the factor-3
band the effectivity summary judges, ``reports.render.effectivity``).  The misses are paths
on which a model leaves the elastica's branch between two table ramps (prb-3r at alpha 82.5,
beta 28.1 deg: 457 % measured, 42 % predicted, both far above the 1 % warning), and bcm in
compression, whose own error diverges near its buckling load.  ``tests/test_predict.py``
checks a few cell centres (within 1.6x) and regenerates a few ramps against the shipped file.
Regenerate with ``python -m reports.verdicts.predict_table`` (about a minute of CPU time).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import time
from collections.abc import Sequence

import numpy as np

from reduced_models.base import Solution
from reports import api
from reports.verdicts import atlas as A
from reports.verdicts.predict import ANGLES, PATH, RHO_MAX

MODELS = A.MODELS
BETAS = np.linspace(-90.0, 90.0, 17)
N_RHO = 20
RHOS = RHO_MAX * np.arange(1, N_RHO + 1) / N_RHO
REFERENCE = "elastica"
FLOOR = 1e-12  # an error of exactly 0 (an exact model) is stored as this


def ramp_scene(family: str, alpha: float, beta: float) -> object:
    """The atlas cantilever (L = 1, EI = 1, inextensible) ramped to rho = ``RHO_MAX`` at
    (alpha, beta) deg in ``N_RHO`` equal steps."""
    scene = A.scene_for("force", 1.0, 0.0, N_RHO)
    b, a = math.radians(beta), math.radians(alpha)
    p = RHO_MAX * math.cos(b) if abs(beta) < 90 else 0.0
    m = RHO_MAX * math.sin(b)
    (load,) = scene.loads
    load = dataclasses.replace(
        load,
        fx=p * math.cos(a) + 0.0,
        fy=-p * math.sin(a) + 0.0,
        moment=m,
        follower=family == "follower",
    )
    name = f"predict-{family}-{alpha:g}deg-{beta:g}deg"
    return dataclasses.replace(scene, name=name, loads=(load,))


def _tips(name: str, scene: object) -> np.ndarray:
    """(N_RHO, 3) tip ux, uy, rot of model ``name`` on a ramp (NaN beyond a failure)."""
    sol: Solution = api.run_model(api.make_model(name, scene), scene, post=False)
    return A._tips(sol, N_RHO)


def cells(family: str) -> list[tuple[float, float]]:
    """The (alpha, beta) ramps of a family, beta = 90 once (alpha 0)."""
    if family == "follower":
        return [(float(a), 0.0) for a in ANGLES]
    inner = [(float(a), float(b)) for a in ANGLES for b in BETAS if abs(b) < 90]
    return inner + [(0.0, 90.0)]


@functools.lru_cache(maxsize=64)
def reference_ramp(family: str, alpha: float, beta: float) -> np.ndarray:
    """(N_RHO, 3) exact elastica tips of one ramp."""
    return _tips(REFERENCE, ramp_scene(family, alpha, beta))


def ramp_error(family: str, model: str, alpha: float, beta: float) -> np.ndarray:
    """(N_RHO, 2) ``error_rel`` of ``model`` along one ramp, translations and rotation apart
    (NaN where it failed or declined): a guided end or a member inside a mechanism has its
    end rotation set from outside, and is judged on the translations alone."""
    ref = reference_ramp(family, alpha, beta)
    d = _tips(model, ramp_scene(family, alpha, beta)) - ref
    trans, rot = d.copy(), d.copy()
    trans[:, 2] = np.where(np.isnan(d[:, 2]), np.nan, 0.0)
    rot[:, :2] = np.where(np.isnan(d[:, :2]), np.nan, 0.0)
    return np.stack([A.state_error_rel(x[None], ref[None])[0] for x in (trans, rot)], axis=-1)


def _grid(family: str, values: dict[tuple[float, float], np.ndarray]) -> np.ndarray:
    """Ramp values -> (A, B, R, ...) for ``dead`` or (A, R, ...) for ``follower``."""
    if family == "follower":
        return np.stack([values[(float(a), 0.0)] for a in ANGLES])
    moment = values[(0.0, 90.0)]
    rows = [
        [moment if abs(b) == 90 else values[(float(a), float(b))] for b in BETAS] for a in ANGLES
    ]
    return np.array(rows)


def _model_tables(model: str) -> dict[str, np.ndarray]:
    """One model's error arrays of both families (a worker's unit of work)."""
    out = {}
    for family in ("dead", "follower"):
        errs = {c: ramp_error(family, model, *c) for c in cells(family)}
        out[family] = _grid(family, errs)
    return out


def compute(models: Sequence[str] = MODELS, workers: int = 1) -> dict[str, np.ndarray]:
    """Every array of the shipped table (see module docstring)."""
    refs = {
        fam: _grid(fam, {c: reference_ramp(fam, *c) for c in cells(fam)})
        for fam in ("dead", "follower")
    }
    if workers > 1:
        import concurrent.futures as cf

        with cf.ProcessPoolExecutor(workers) as pool:
            blocks = list(pool.map(_model_tables, models))
    else:
        blocks = [_model_tables(m) for m in models]
    return {
        "models": np.array(models),
        "angles": ANGLES,
        "betas": BETAS,
        "rhos": RHOS,
        "dead_ref": refs["dead"].astype(np.float32),
        "follower_ref": refs["follower"].astype(np.float32),
        "dead_error": stored(np.stack([b["dead"] for b in blocks])),
        "follower_error": stored(np.stack([b["follower"] for b in blocks])),
    }


def stored(err: np.ndarray) -> np.ndarray:
    """Errors as shipped: log10 in float16 (0.1 % of a decade: a prediction's third digit),
    exact zeros at ``FLOOR``, NaN kept."""
    return np.log10(np.maximum(err, FLOOR)).astype(np.float16)  # maximum keeps NaN (fmax not)


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate ``PATH`` (``python -m reports.verdicts.predict_table [--workers N]``)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=1, help="processes (one model each)")
    args = ap.parse_args(argv)
    t0 = time.process_time()
    table = compute(workers=args.workers)
    PATH.parent.mkdir(exist_ok=True)
    np.savez_compressed(PATH, **table)
    print(f"{PATH}: {len(table['models'])} models, {time.process_time() - t0:.1f} s CPU")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
