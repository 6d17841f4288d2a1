"""The teaching page: one self-contained HTML file (no network, no side files).

This module gathers what the page shows (``build_data``): model cards, validity atlases (each
published claim's own verdict, ``reports.verdicts.claims``, and our test of it), the measured
cost scaling (CPU time vs N on one case), a worked "which model should I use" per catalog case
from ``reports.verdicts.recommend`` (with its verdict table, ``teach_story.verdict_table``) and
every model's deformed shapes along one case's load.  ``write_page`` lays it out
(``reports.render.teach_html``: the story first, anchored sections, costs last) with the data
embedded as JSON for the inline script (``reports.render.teach_js``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

import cases
from reports import api
from reports.render import mech_atlas
from reports.render.teach_story import verdict_table
from reports.verdicts import atlas
from reports.verdicts import claims as published
from reports.verdicts.recommend import recommend
from reports.verdicts.recommendation import format_text

FAMILIES = {
    "linear": ("Linear beam, single and chained", ("linear-1", "linear-8"), "linear-N"),
    "bcm": ("Beam constraint model, single and chained", ("bcm", "cbcm-2", "cbcm-8"), "cbcm-N"),
    "prb": (
        "Pseudo-rigid-body models",
        ("prb-short", "prb-1r", "prb-2r", "prb-3r", "prb-2rpr", "prb-fsm-4", "prb-fsm-16"),
        "prb-fsm-N",
    ),
}
COST_N = (1, 2, 4, 8, 16, 32, 64)
SHAPE_MODELS = ("linear-1", "linear-8", "bcm", "cbcm-8", "prb-1r", "prb-3r", "prb-fsm-16")


def _r(a: Any, digits: int = 4) -> Any:
    """Numbers rounded for embedding; NaN/inf -> None."""
    arr = np.asarray(a, dtype=float)
    out = np.where(np.isfinite(arr), np.round(arr, 6), np.nan)
    flat = [None if not math.isfinite(v) else float(f"{v:.{digits}g}") for v in out.ravel()]
    return np.array(flat, dtype=object).reshape(arr.shape).tolist()


def cost_scaling(case: str = "cantilever-tip-load", ns: Sequence[int] = COST_N) -> dict:
    """CPU seconds of a solve vs N for each parametrised family: the cost estimates
    ``flexbench recommend`` ranks by (``reports.verdicts.recommend.measured``, cached)."""
    from reports.verdicts.recommend import measured

    scene = cases.load(case)
    out = {}
    for fam in ("linear", "cbcm", "prb-fsm"):
        ms = []
        for n in ns:
            name = f"{fam}-{n}"
            opts = scene.model_options(name)
            _, est = measured(api.make_model(name, scene, opts), scene, name, opts)
            ms.append(est.cpu_s * 1e3)
        out[fam] = {"N": list(ns), "ms": _r(ms)}
    return {"case": case, "families": out}


def shapes(case: str, models: Sequence[str] = SHAPE_MODELS) -> dict:
    """Deformed shapes of every step of ``case``: model -> [step][point][x, y]."""
    scene = cases.load(case)
    ref = scene.reference_model or "elastica"
    data: dict[str, Any] = {"case": case, "reference": ref, "models": {}}
    for name in (ref, *models):
        sol = api.solve(scene, name)
        if not sol.steps or not sol.steps[-1].shapes:
            continue
        data["models"][name] = [
            _r(np.concatenate(list(s.shapes.values())), 5) if s.shapes else [] for s in sol.steps
        ]
        data.setdefault("factors", _r([s.factor for s in sol.steps]))
    return data


def atlas_png(at: atlas.Atlas, model: str) -> str:
    """A matplotlib map of one model's atlas with the 0.1/1/5 % contours (dotted, solid,
    dashed) and its claims' regions (red/orange dashed) and failing points (x), as a base64 PNG
    data URI."""
    import base64
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    err = np.asarray(at.error[model], dtype=float)
    fig, ax = plt.subplots(figsize=(3.6, 3.0), dpi=90)
    X, Y = np.meshgrid(at.mags, at.angles)
    pcm = ax.pcolormesh(X, Y, np.log10(np.clip(err, 1e-6, None)), vmin=-4, vmax=0, cmap="viridis")
    fig.colorbar(pcm, ax=ax, label="log10 error")
    if np.isfinite(err).sum() > 3 and len(at.angles) > 1:
        ax.contour(
            X,
            Y,
            err,
            levels=list(atlas.CONTOURS),
            colors="w",
            linewidths=0.8,
            linestyles=mech_atlas.CONTOUR_STYLES[: len(atlas.CONTOURS)],
        )  # 0.1 % dotted, 1 % solid, 5 % dashed (the caption says so)
    for k, c in enumerate(c for c in atlas.CLAIMS if c.model == model and c.family == at.family):
        region = c.region(at).astype(float)
        if region.any() and len(at.angles) > 1:
            ax.contour(X, Y, region, levels=[0.5], colors=["r", "orange"][k % 2], linestyles="--")
        bad = c.region(at) & ~(getattr(at, c.metric)[model] <= c.accuracy)
        ax.plot(X[bad], Y[bad], "x", color=["r", "orange"][k % 2], ms=3)
    ax.set_xlabel("load PL²/EI" if at.family != "moment" else "end moment ML/EI", fontsize=8)
    ax.set_ylabel("load angle [deg]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.set_title(f"{model}: {at.family}", fontsize=9)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def atlas_data(at: atlas.Atlas) -> dict:
    """Embeddable atlas: grid, each model's error and our tests of the published claims on
    it; the force atlas also carries the claims' own records (``reports.verdicts.claims``: the
    publication's verdict, in its own metric, with our reading of this atlas beside it)."""
    claims = [c for c in atlas.CLAIMS if c.family == at.family]
    out: dict[str, Any] = {"mags": _r(at.mags), "angles": _r(at.angles), "models": {}}
    if at.family == "force":
        out["published"] = published.as_json(published.evaluate_all(at))["claims"]
    for name, err in at.error.items():
        entry: dict[str, Any] = {"error": _r(err, 3), "claims": [], "message": at.message[name]}
        if at.family == "force":
            entry["png"] = atlas_png(at, name)
        for c in (c for c in claims if c.model == name):
            res = atlas.check_claim(c, at)
            metric = getattr(at, c.metric)[name]
            region = c.region(at)
            entry["claims"].append(
                {
                    **{k: v for k, v in res.items() if k != "worst_at"},
                    "region": region.astype(int).tolist(),
                    "fails": (region & ~(metric <= c.accuracy)).astype(int).tolist(),
                }
            )
        out["models"][name] = entry
    return out


def family_cards() -> list[dict]:
    """Per model family: title, its models and their cards (assumptions, validity, refs)."""
    families = []
    for key, (title, names, param) in FAMILIES.items():
        cards = []
        for name in (*names, param):
            card = api.card_of(name)
            if card is not None and all(c["name"] != card.name for c in cards):
                cards.append(
                    {
                        "name": card.name,
                        "summary": card.summary,
                        "assumptions": list(card.assumptions),
                        "validity": card.validity,
                        "references": list(card.references),
                    }
                )
        families.append({"key": key, "title": title, "models": list(names), "cards": cards})
    return families


def build_data(
    cases_for_advice: Sequence[str],
    tolerances: Sequence[str] = ("1%", "0.1%"),
    shape_case: str = "cantilever-tip-load",
    n_mag: int = 40,
    n_ang: int = 41,
    workers: int = 2,
    progress: Callable[[str], None] | None = None,
    cost_ns: Sequence[int] = COST_N,
    mech_cases: Sequence[str] = mech_atlas.TEACH_CASES,
    mech_n_axis: int = 5,
) -> dict:
    """Everything the page shows (cards, atlases, costs, recommendations, shapes)."""
    t0 = time.perf_counter()
    models = tuple(m for _, ms, _ in FAMILIES.values() for m in ms)
    atlases, timing = {}, {}
    for fam in atlas.FAMILIES:
        t = time.perf_counter()
        at = atlas.compute(fam, models, n_mag, n_ang, workers=workers, progress=progress)
        timing[fam] = round(time.perf_counter() - t, 2)
        atlases[fam] = atlas_data(at)
    advice = []
    for case in cases_for_advice:
        for tol in tolerances:
            rec = recommend(case, tol)
            curves = {c.model: _r(c.profile, 3) for c in rec.candidates if c.profile}
            advice.append(
                {
                    "case": case,
                    "tol": tol,
                    "recommended": rec.recommended,
                    "text": format_text(rec),
                    "table": verdict_table(rec),
                    "profiles": curves,
                }
            )
            if progress:
                progress(f"recommend {case} {tol}: {rec.recommended}")
    return {
        "families": family_cards(),
        "atlas": atlases,
        "atlas_seconds": timing,
        "contours": list(atlas.CONTOURS),
        "cost": cost_scaling(ns=cost_ns),
        "advice": advice,
        "shapes": shapes(shape_case),
        "mech_atlas": mech_atlas.teaching_data(mech_cases, mech_n_axis, progress),
        "seconds": round(time.perf_counter() - t0, 1),
    }


def model_cards(families: Sequence[Mapping]) -> dict[str, dict]:
    """model -> its card (of ``family_cards``): ``linear-8`` shares ``linear-N``'s."""
    out = {}
    for F in families:
        for m in F["models"]:
            card = api.card_of(m)
            found = [c for c in F["cards"] if card is not None and c["name"] == card.name]
            if found:
                out[m] = found[0]
    return out


def write_page(data: dict, path: str | Path) -> Path:
    """Write the self-contained teaching page for ``data`` (see ``build_data``)."""
    from reports.render import teach_html
    from reports.render.palette import palette

    path = Path(path)
    names = {m for F in data["families"] for m in F["models"]} | set(data["shapes"]["models"])
    names |= {m for a in data["advice"] for m in a.get("profiles", {})}
    data = {**data, "colours": palette(names)}
    page = teach_html.page(data, model_cards(data["families"]))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page, encoding="utf-8")
    mech_atlas.save(data.get("mech_atlas"), path.parent)  # the report shows them too
    return path
