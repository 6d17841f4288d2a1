"""DAS-2D's PRB accuracy indicator against the error measured on the reference (issue 21).

A PRB model run with the option ``das2d = true`` (``reduced_models/beam/prb_das2d.py``) states
``extras["das2d_indicator"]``: the largest gap, over its path, between its tip and the tip of
the Euler beam solved under the end loads recovered from its springs, over the member length.
DAS-2D offers that gap as the indicator of the PRB's accuracy "for the current problem".
This section sets it beside what the run measured: the largest distance between the pair's
points and the reference's over the common load steps, over the same member length, and
their ratio (1: the indicator is the error; < 1: it understates it).

In a statically determinate cantilever the recovered loads are the applied ones, so the Euler
beam is the exact answer and the indicator is the PRB's own tip error against the elastica;
where they part (a guided end whose reaction the PRB recovers, an FE reference that stretches)
the table shows by how much.

``python -m reports.render.das2d_note OUT/results.json`` prints the table.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence

from reports.run.tables import results_from_argv

TITLE = "DAS-2D's PRB accuracy indicator against the measured error"
ANCHOR = "das2d-indicator"
HEADERS = ("case", "model", "indicator (tip gap / L)", "measured (tip error / L)", "ratio")


def _tip_error(rec: Mapping, ref: Mapping | None, length: float) -> float | None:
    """Largest distance, over the common load steps and the point outputs, between the pair's
    points and the reference's, over ``length`` (None without a reference path)."""
    if ref is None:
        return None
    at = {round(s["factor"], 12): s["outputs"] for s in ref.get("steps") or []}
    worst = None
    for s in rec.get("steps") or []:
        o, r = s["outputs"], at.get(round(s["factor"], 12))
        if r is None:
            continue
        for key in (k for k in o if k.endswith(".x") and k[:-2] + ".y" in o and k in r):
            p = key[:-2]
            d = math.hypot(o[key] - r[key], o[p + ".y"] - r[p + ".y"]) / length
            worst = d if worst is None else max(worst, d)
    return worst


def rows(payload: Mapping) -> list[tuple[str, str, float, float | None]]:
    """(case, model, indicator, measured) of every converged pair stating the indicator."""
    refs = {r["case"]: r for r in payload.get("results") or [] if r.get("is_reference")}
    out = []
    for r in payload.get("results") or []:
        ind = (r.get("extras") or {}).get("das2d_indicator")
        if r.get("status") != "converged" or not isinstance(ind, Mapping):
            continue
        meas = _tip_error(r, refs.get(r["case"]), float(ind["length"]))
        out.append((r["case"], r["model"], float(ind["max_tip_gap"]), meas))
    return sorted(out)


def _g(v: float | None) -> str:
    return "–" if v is None else f"{v:.3g}"


def table(rs: Sequence[tuple[str, str, float, float | None]]) -> list[tuple[str, ...]]:
    """The table's cells (strings)."""
    return [(c, m, _g(ind), _g(meas), _g(ind / meas) if meas else "–") for c, m, ind, meas in rs]


def blocks(payload: Mapping) -> list[tuple]:
    """The report's section (nothing when no pair ran with the option)."""
    rs = rows(payload)
    if not rs:
        return []
    text = (
        "PRB models run with the option das2d = true: DAS-2D's indicator (the largest gap "
        "between the PRB's tip and the Euler beam's tip under the end loads recovered from "
        "the PRB's springs, over the member length) beside the largest distance of its points "
        "from the case's reference path (over the same length)."
    )
    return [("h2", TITLE, ANCHOR), ("p", text), ("table", HEADERS, table(rs))]


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table of a run's ``results.json``."""
    payload = results_from_argv(
        list(sys.argv[1:] if argv is None else argv), "reports.render.das2d_note"
    )
    if payload is None:
        return 2
    print(" | ".join(HEADERS))
    for row in table(rows(payload)):
        print(" | ".join(row))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
