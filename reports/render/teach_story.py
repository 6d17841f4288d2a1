"""What the teaching page says before it shows: where each model stops, the recommender's
verdicts as table rows, and the cost-scaling figure.

* ``stops(atlas_data, tol)``: per model and load family, the largest load up to which the
  model stays within ``tol`` (transverse direction and worst direction), read from the
  validity atlases' errors (``reports.render.teaching.atlas_data``);
* ``verdict_table(rec)``: a ``Recommendation`` as a header, a judged-outputs list, the pick
  with its reason and one row per candidate (what ``format_text`` prints, as data for an
  HTML table);
* ``cost_png(cost)``: CPU time against N of each parametrised family on labelled log axes,
  as a PNG data URI.
"""

from __future__ import annotations

import base64
import io
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from reports.verdicts import recommendation as R

LOAD_NAMES = {"force": "PL²/EI", "follower": "PL²/EI", "moment": "ML/EI"}


def slug(text: str) -> str:
    """A stable anchor id: lower case, runs of other characters as one ``-``
    (``"Where PRB-1R stops"`` -> ``where-prb-1r-stops``)."""
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _reach(errors: np.ndarray, mags: np.ndarray, tol: float) -> float | None:
    """Largest magnitude up to which every error is finite and within ``tol`` (0 when the
    first one is not; None when the model declines the whole direction)."""
    if not np.isfinite(errors).any():
        return None
    bad = np.flatnonzero(~(errors <= tol))  # NaN (declined or failed) counts as a stop
    return float(mags[-1]) if not bad.size else (float(mags[bad[0] - 1]) if bad[0] else 0.0)


def stops(atlas_data: Mapping[str, Mapping], tol: float = 0.01) -> dict[str, dict[str, Any]]:
    """model -> family -> ``{"within": fraction of solved states within ``tol``,
    "transverse": reach at the direction nearest 90 deg, "worst":
    smallest reach over the directions it accepts, "worst_deg": that direction, "max": the
    atlas's largest load}``, or ``{"declined": message}`` when the model solved no state."""
    out: dict[str, dict[str, Any]] = {}
    for fam, A in atlas_data.items():
        if fam not in LOAD_NAMES:
            continue
        mags = np.asarray(A["mags"], dtype=float)
        angles = np.asarray(A["angles"], dtype=float)
        side = int(np.argmin(np.abs(angles - 90.0)))
        for model, M in A["models"].items():
            err = np.array(
                [[np.nan if v is None else v for v in row] for row in M["error"]], dtype=float
            )
            if not np.isfinite(err).any():
                out.setdefault(model, {})[fam] = {"declined": M.get("message") or "no state"}
                continue
            reach = [_reach(row, mags, tol) for row in err]
            ok = [(r, a) for r, a in zip(reach, angles) if r is not None]
            worst, worst_deg = min(ok)
            out.setdefault(model, {})[fam] = {
                "within": float(np.mean(err[np.isfinite(err)] <= tol)),
                "transverse": reach[side],
                "worst": worst,
                "worst_deg": float(worst_deg) if len(angles) > 1 else None,
                "max": float(mags[-1]),
            }
    return out


def reach_text(s: Mapping[str, Any] | None, fam: str) -> str:
    """One table cell: ``up to 2.5`` / ``whole range (10)`` / ``declines`` / ``-``."""
    if not s:
        return "-"
    if "declined" in s:
        return "declines"

    def one(v: float | None) -> str:
        if v is None:
            return "declines"
        if v >= s["max"]:
            return f"whole range (≤ {s['max']:.3g})"
        if v == 0:
            return f"not at small loads (within on {s['within']:.0%} of its atlas)"
        return f"up to {v:.3g}"

    if fam == "moment" or s.get("worst_deg") is None:
        return one(s["worst"])
    text = one(s["transverse"])
    if s["worst"] != s["transverse"]:
        text += f"; {one(s['worst'])} at {s['worst_deg']:.0f}°"
    return text


def verdict_table(rec: Any) -> dict[str, Any]:
    """The recommender's verdict as data for an HTML table (same content and order as
    ``reports.verdicts.recommendation.format_text``)."""
    rows = []
    for c in R.ordered(rec):
        verdict = R.verdict_word(c, rec.recommended)
        rows.append(
            [
                c.model,
                c.status,
                "-" if c.worst_error is None else c.error_text(),
                c.worst_output or "-",
                "-" if c.at_factor is None else f"{c.at_factor:.3g}",
                "-" if c.cpu_s is None else f"{c.cpu_s * 1e3:.3g}",
                "-" if c.ratio_to_reference is None else f"{c.ratio_to_reference:.3g}",
                verdict,
            ]
        )
    return {
        "head": [
            "model",
            "status",
            "worst error",
            "output",
            "at factor",
            "CPU ms",
            "x reference",
            "verdict",
        ],
        "rows": rows,
        "judged": [f"{k}: {why}" for k, why in rec.tolerance.why.items() if why != "user"],
        "reason": rec.reason,
        "decided_by": rec.decided_by,
        "reference": rec.reference,
        "skipped": list(rec.skipped),
    }


def cost_png(cost: Mapping[str, Any]) -> str:
    """CPU ms against N of each family (log-log, labelled axes, legend outside the data),
    as a PNG data URI."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from reports.render.palette import COLOURS

    fig, ax = plt.subplots(figsize=(6.0, 3.2), dpi=90)
    for k, (fam, C) in enumerate(cost["families"].items()):
        ms = [np.nan if v is None else v for v in C["ms"]]
        ax.plot(C["N"], ms, "o-", color=COLOURS[k], lw=1.2, ms=4, label=f"{fam}-N")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xticks(cost["families"][next(iter(cost["families"]))]["N"])
    ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.set_xlabel("N (elements or segments per member)", fontsize=8)
    ax.set_ylabel("CPU per solve [ms]", fontsize=8)
    ax.set_title(f"Cost against N on {cost['case']} (median CPU)", fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def declined_lines(atlas_data: Mapping[str, Mapping], models: Sequence[str]) -> list[str]:
    """One line per (family, reason) naming the models that declined every state of it."""
    by: dict[tuple[str, str], list[str]] = {}
    for fam, A in atlas_data.items():
        for m in models:
            M = A["models"].get(m)
            if M is None or any(v is not None for row in M["error"] for v in row):
                continue
            by.setdefault((fam, M.get("message") or "no state solved"), []).append(m)
    return [f"{fam} atlas: {', '.join(ms)} decline ({why})" for (fam, why), ms in by.items()]
