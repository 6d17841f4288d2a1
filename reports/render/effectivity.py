"""Effectivity of the reduced models' predicted errors: predicted against measured, catalog-wide.

A pair (case, model) counts when the model converged, states ``extras["predicted_error"]``
(``reports.verdicts.predict``) and has a measured ``error_rel`` against the case's reference (the
reference itself excluded; a failed solve is its own verdict).  Effectivity = predicted /
measured (1: exact; > 1: cautious).  Pairs are split into single beams (case tag
``single-beam``) and mechanisms: a mechanism's prediction is its members' deflection error,
while its measured error also holds outputs no single member decides (a parallel guide's
parasitic rotation, a bistable driver's force), so for mechanisms the effectivity against the
judged point translations alone is given too.

Summary (``summary``): the median effectivity and its spread (the 10th-90th percentile, a
factor either way), the fraction of pairs whose prediction is within a factor 3 of the
measured error and the fraction that is not *optimistic* by more than 3 (predicted >=
measured / 3: fem-auto's estimate, ~3x cautious, is held to the same band); and, what a
designer acts on, the 1 % warning: of the pairs measured above 1 %, the fraction whose
prediction also exceeds 1 % (warned), and of those measured below, the fraction not warned.

``python -m reports.render.effectivity OUT/results.json`` prints the summary and the pairs.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from reports.run.tables import results_from_argv

KINDS = ("single beam", "mechanism")
BAND = 3.0  # the factor a prediction is judged within
LEVEL = 0.01  # the warning threshold (reports.verdicts.predict.THRESHOLD)
FLOOR = 1e-9  # errors below this are round-off; not a ratio anyone can read


def _translations(rec: Mapping) -> float | None:
    """Largest judged point-translation error_rel of a pair (None without one)."""
    err = rec.get("errors") or {}
    per = err.get("per_output") or {}
    vals = [
        per[k]
        for k in err.get("judged") or per
        if k.rsplit(".", 1)[-1] in ("ux", "uy", "x", "y") and per.get(k) is not None
    ]
    return max(vals) if vals else None


def pairs(payload: Mapping) -> list[dict[str, Any]]:
    """(case, model, kind, predicted, measured, effectivity, measured_translations) of every
    converged pair that has both errors."""
    cases = payload.get("cases") or {}
    out = []
    for r in payload.get("results") or []:
        pred = (r.get("extras") or {}).get("predicted_error")
        meas = r.get("error_rel")
        if r.get("is_reference") or r.get("status") != "converged":
            continue
        if pred is None or meas is None or meas < FLOOR:
            continue
        pred = max(float(pred), FLOOR)
        tags = (cases.get(r["case"]) or {}).get("tags") or ()
        out.append(
            {
                "case": r["case"],
                "model": r["model"],
                "kind": "single beam" if "single-beam" in tags else "mechanism",
                "predicted": pred,
                "measured": float(meas),
                "effectivity": pred / float(meas),
                "measured_translations": _translations(r),
            }
        )
    return out


def summary(ps: Sequence[Mapping]) -> dict[str, Any]:
    """Catalog-wide effectivity figures (module docstring), with the same per kind under
    ``by_kind`` and, for mechanisms, ``translations`` (against the judged translations);
    empty dict without pairs."""
    if not ps:
        return {}
    out = _figures(ps)
    out["by_kind"] = {k: _figures([p for p in ps if p["kind"] == k]) for k in KINDS}
    mech = [
        {**p, "measured": p["measured_translations"]}
        for p in ps
        if p["kind"] == "mechanism" and (p["measured_translations"] or 0) > FLOOR
    ]
    out["translations"] = _figures(
        [{**p, "effectivity": p["predicted"] / p["measured"]} for p in mech]
    )
    return out


def _figures(ps: Sequence[Mapping]) -> dict[str, Any]:
    """The summary figures of one set of pairs (empty dict without pairs)."""
    if not ps:
        return {}
    eff = np.array([p["effectivity"] for p in ps])
    meas = np.array([p["measured"] for p in ps])
    pred = np.array([p["predicted"] for p in ps])
    lo, hi = np.percentile(eff, [10, 90])
    over, under = meas > LEVEL, meas <= LEVEL
    return {
        "pairs": len(ps),
        "median": float(np.median(eff)),
        "p10": float(lo),
        "p90": float(hi),
        "within_band": float(np.mean((eff >= 1 / BAND) & (eff <= BAND))),
        "not_optimistic": float(np.mean(eff >= 1 / BAND)),
        "warned_when_over": float(np.mean(pred[over] > LEVEL)) if over.any() else None,
        "quiet_when_under": float(np.mean(pred[under] <= LEVEL)) if under.any() else None,
        "n_over": int(over.sum()),
        "n_under": int(under.sum()),
    }


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{x:.0%}"


def _line(s: Mapping) -> str:
    return (
        f"median effectivity (predicted / measured) {s['median']:.2g}, 10-90 % of pairs "
        f"between {s['p10']:.2g} and {s['p90']:.2g}; {_pct(s['within_band'])} within a factor "
        f"{BAND:g}, {_pct(s['not_optimistic'])} not optimistic by more than {BAND:g}; "
        f"{_pct(s['warned_when_over'])} of the {s['n_over']} measured above 1 % warned, "
        f"{_pct(s['quiet_when_under'])} of the {s['n_under']} below quiet"
    )


def summary_text(s: Mapping) -> str:
    """One paragraph of the summary."""
    if not s:
        return "No converged reduced-model pair has both a predicted and a measured error."
    text = (
        f"{s['pairs']} converged pairs (case, reduced model) with a predicted error (the "
        f"validity atlas at each flexible member's load state) and a measured error_rel: "
        f"{_line(s)}."
    )
    for kind, k in s["by_kind"].items():
        if k:
            text += f" {kind.capitalize()}s ({k['pairs']} pairs): {_line(k)}."
    if s["translations"]:
        text += (
            " Mechanisms against their judged point translations alone (what a member's "
            f"deflection error decides): {_line(s['translations'])}."
        )
    return text


def figure(ps: Sequence[Mapping], path: Path) -> Path | None:
    """Log-log scatter of predicted against measured error with y = x, the factor-3 band
    and the 1 % lines; None without pairs."""
    if not ps:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reports.render.palette import palette

    meas = np.array([p["measured"] for p in ps])
    pred = np.array([p["predicted"] for p in ps])
    lo = min(meas.min(), pred.min()) / 2
    hi = max(meas.max(), pred.max()) * 2
    fig, ax = plt.subplots(figsize=(6.0, 5.2))
    line = np.array([lo, hi])
    ax.plot(line, line, "k-", lw=1, label="predicted = measured")
    ax.plot(line, line * BAND, "k:", lw=0.8, label=f"factor {BAND:g}")
    ax.plot(line, line / BAND, "k:", lw=0.8)
    ax.axvline(LEVEL, color="tab:red", lw=0.8, ls="--", label="1 %")
    ax.axhline(LEVEL, color="tab:red", lw=0.8, ls="--")
    models = sorted({p["model"] for p in ps})
    cmap = palette(models)
    for m in models:
        for kind, marker in zip(KINDS, ("o", "^")):
            sel = [p for p in ps if p["model"] == m and p["kind"] == kind]
            ax.scatter(
                [p["measured"] for p in sel],
                [p["predicted"] for p in sel],
                s=18,
                marker=marker,
                color=cmap[m],
                label=m if kind == KINDS[0] else None,
                edgecolors="none",
            )
    ax.set(
        xscale="log",
        yscale="log",
        xlim=(lo, hi),
        ylim=(lo, hi),
        xlabel="measured error_rel (against the case's reference)",
        ylabel="predicted error_rel (validity atlas)",
    )
    ax.set_title("Predicted against measured error (o single beams, ^ mechanisms)", fontsize=10)
    ax.legend(fontsize=6, ncol=2, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def blocks(payload: Mapping, out_dir: Path) -> list[tuple]:
    """The report's section: the figure and the summary paragraph."""
    ps = pairs(payload)
    head = [("h2", "Predicted against measured error", "effectivity")]
    png = figure(ps, Path(out_dir) / "figures" / "effectivity.png")
    if png is not None:
        rel = png.relative_to(out_dir).as_posix()
        head.append(("img", rel, "predicted against measured error"))
    return head + [("p", summary_text(summary(ps)))]


def main(argv: Sequence[str] | None = None) -> int:
    """Print the summary and the pairs of a run's ``results.json``."""
    payload = results_from_argv(
        list(sys.argv[1:] if argv is None else argv), "reports.render.effectivity"
    )
    if payload is None:
        return 2
    ps = pairs(payload)
    for p in sorted(ps, key=lambda p: (p["case"], p["model"])):
        print(
            f"{p['case']:36s} {p['model']:12s} predicted {p['predicted']:9.3g} "
            f"measured {p['measured']:9.3g} effectivity {p['effectivity']:8.3g}"
        )
    print(summary_text(summary(ps)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
