"""PNG figures of a run (matplotlib, Agg backend, small: dpi 90, a few per case).

Per case: ``path`` (load factor against the primary output's ux, uy, rot for every model,
the reference in black with its error bars when it has an estimate), ``shapes`` (deformed
shapes at the last step over the undeformed drawing) and ``pareto`` (wall time against summary
error, Pareto front marked).  Overall: ``pareto`` of per-model aggregates.

Hooks: ``reference_error_bars`` (fem-auto's ``extras["error_estimate"]``),
``history_figure`` (replay time histories in ``extras["history"]``) and ``render_figure``
(the reference's final shape through ``fem_reference.export.render_png``: pyvista when it
can render here, else matplotlib).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DPI = 90
PAD = 0.05  # in of margin around the tight box of a saved figure
QUANTITIES = ("ux", "uy", "rot")


def colours(models: Sequence[str]) -> dict[str, Any]:
    """One distinct colour per model name across every figure of a report
    (``reports.render.palette``: catalog models keep theirs from run to run)."""
    from reports.render.palette import palette

    return palette(models)


def _series(rec: Mapping, key: str) -> np.ndarray:
    if key == "factor":
        return np.array([np.nan if s["factor"] is None else s["factor"] for s in rec["steps"]])
    vals = [s["outputs"].get(key) for s in rec["steps"]]
    return np.array([np.nan if v is None else v for v in vals], dtype=float)


def _save(fig: Any, path: Path) -> Path:
    """Write ``fig``: fewer ticks where tick labels collide, the image cropped or grown to
    hold every label (the tight box padded by ``PAD`` in: a long legend entry or a y label is
    never cut off), then closed.

    A figure laid out by ``subplots_adjust`` (no layout engine) is measured for its tight box
    without the layout draw ``bbox_inches="tight"`` makes first (``thin_ticks`` has applied
    the panels' aspect): the same box, one draw instead of two (the 183 per-case PNGs of the
    default run byte for byte the same, ~10 % less CPU)."""
    from reports.render.textcheck import thin_ticks

    fig.set_dpi(DPI)
    thin_ticks(fig)
    if fig.get_layout_engine() is None:
        box = fig.get_tightbbox(fig.canvas.get_renderer()).padded(PAD)
        fig.savefig(path, dpi=DPI, bbox_inches=box)
    else:
        fig.savefig(path, dpi=DPI, bbox_inches="tight", pad_inches=PAD)
    plt.close(fig)
    return path


def reference_error_bars(ax: Any, rec: Mapping, key: str, x: np.ndarray, y: np.ndarray) -> None:
    """Hook: horizontal error bars from ``extras["error_estimate"][key]`` of the reference.

    fem-auto gives ``error_estimate_steps`` (a list per step) and ``error_estimate`` (last
    step); either is used, the per-step one first.
    """
    extras = rec.get("extras") or {}
    est = extras.get("error_estimate_steps")
    if not isinstance(est, Mapping) or est.get(key) is None:
        est = extras.get("error_estimate")
    if not isinstance(est, Mapping) or key not in est or est[key] is None:
        return
    e = np.atleast_1d(np.asarray(est[key], dtype=float))
    if e.size == x.size:
        ax.errorbar(x, y, xerr=e, fmt="none", ecolor="k", elinewidth=0.8, capsize=2)
    elif x.size:
        ax.errorbar(x[-1:], y[-1:], xerr=e[-1:], fmt="none", ecolor="k", capsize=3)


def pareto_front(points: Sequence[tuple[float, float]]) -> list[int]:
    """Indices of the non-dominated points (less time and less error is better), by time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


MARKERS = "osD^v<>pPhX8d"
ROUNDOFF = 1e-12  # errors below this are round-off: drawn on a "0 (< 1e-12)" row


def marker_of(model: str, cmap: Mapping) -> str:
    """A marker per model (with the colour it tells 12+ models apart)."""
    names = list(cmap)
    return MARKERS[names.index(model) % len(MARKERS)] if model in cmap else "o"


def log_limits(values: Sequence[float], pad: float = 1.6) -> tuple[float, float]:
    """Log-axis limits around positive ``values`` (at least one decade wide)."""
    v = [x for x in values if x and x > 0 and math.isfinite(x)]
    lo, hi = (min(v), max(v)) if v else (1e-3, 1.0)
    lo, hi = lo / pad, hi * pad
    if hi < 10 * lo:
        mid = math.sqrt(lo * hi)
        lo, hi = mid / math.sqrt(10), mid * math.sqrt(10)
    return lo, hi


def _decade_ticks(ax: Any, axis: str, lo: float, hi: float, zero: float | None) -> None:
    """Major ticks at powers of ten (1-2-5 inside one decade) labelled ``1e-03``; ``zero``
    (the round-off row) labelled ``0 (< 1e-12)``."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter, NullLocator

    e0, e1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    subs = (1.0, 2.0, 5.0) if e1 - e0 <= 2 else (1.0,)
    step = max(1, (e1 - e0) // 8)
    ticks = [m * 10.0**e for e in range(e0, e1 + 1, step) for m in subs]
    ticks = [t for t in ticks if lo <= t <= hi and (zero is None or t > 3 * zero)]
    if zero is not None:
        ticks = [zero, *ticks]
    ax_ = ax.yaxis if axis == "y" else ax.xaxis

    def label(v: float, _: object) -> str:
        return "0 (< 1e-12)" if zero is not None and abs(v - zero) < 1e-3 * zero else f"{v:.0e}"

    ax_.set_major_locator(FixedLocator(ticks))
    ax_.set_major_formatter(FuncFormatter(label))
    ax_.set_minor_locator(NullLocator())
    ax_.set_minor_formatter(NullFormatter())


def pareto_figure(
    points: Sequence[Mapping],
    path: Path,
    title: str,
    cmap: Mapping,
    ref_time: float | None = None,
    floor: float | None = None,
    xlabel: str = "wall time per solve [s]",
) -> Path | None:
    """Speed against error: one marker per model (legend, no free-floating labels), the
    reference (``kind = "reference"``: black star at its own error estimate, or on the
    round-off row) and the exact model (``kind = "exact"``: diamond) included.

    ``points``: ``{"model", "time", "error", "tmin", "tmax", "ok", "kind"}``.  Errors below
    ``ROUNDOFF`` sit on a ``0 (< 1e-12)`` row under the data.  ``floor``: the reference's
    error estimate (grey band: differences below it are not resolved).  Axes are log, their
    limits from the data.  The plotted points are written beside the PNG as JSON (same name,
    ``.json``), read back from the drawn artists, so a test can hold them against
    ``results.json``.
    """
    pts = [p for p in points if p.get("time") and p["time"] > 0 and p.get("error") is not None]
    if not any(p.get("kind") != "reference" for p in pts):
        return None  # nothing to compare with the reference
    resolved = [p["error"] for p in pts if p["error"] >= ROUNDOFF]
    if floor and floor >= ROUNDOFF:
        resolved.append(floor)
    ylo, yhi = log_limits(resolved, pad=2.0)
    zero = None
    if any(p["error"] < ROUNDOFF for p in pts):
        zero = ylo / 3
        ylo = zero / 2
    fig, ax = plt.subplots(figsize=(7.6, 4.0))
    drawn = []
    xy = []
    for p in sorted(pts, key=lambda p: (p.get("kind") == "reference", p["model"])):
        kind = p.get("kind", "model")
        x, e = p["time"], p["error"]
        y = zero if e < ROUNDOFF else e
        lo, hi = p.get("tmin") or x, p.get("tmax") or x
        if kind == "reference":
            style = {"fmt": "*", "color": "k", "ms": 12}
            how = "exact" if p.get("exact") else "at its own error estimate"
            label = f"{p['model']} (reference, {how})"
        else:
            mk = "D" if kind == "exact" else (marker_of(p["model"], cmap) if p["ok"] else "x")
            style = {"fmt": mk, "color": cmap.get(p["model"], "C0"), "ms": 6}
            label = p["model"] + (" (exact)" if kind == "exact" else "")
            label += "" if p["ok"] else " (failed)"
        cont = ax.errorbar(
            x,
            y,
            xerr=[[x - lo], [hi - x]],
            capsize=2,
            lw=0.8,
            label=label,
            mec="k" if kind == "exact" else None,
            **style,
        )
        line = cont.lines[0]
        dx, dy = float(line.get_xdata()[0]), float(line.get_ydata()[0])
        drawn.append(
            {
                "model": p["model"],
                "kind": kind,
                "time": x,
                "error": e,
                "x": dx,
                "y": dy,
                "roundoff": e < ROUNDOFF,
            }
        )
        if p["ok"] and kind != "reference":
            xy.append((dx, dy))
    front = pareto_front(xy)
    if len(front) > 1:
        fx, fy = zip(*(xy[i] for i in front))
        ax.step(fx, fy, where="post", color="k", lw=1, alpha=0.5, label="Pareto front")
    if ref_time:
        ax.axvline(ref_time, color="k", ls=":", lw=1, label="reference time")
    if floor:
        ax.axhspan(ylo, floor, color="0.85", alpha=0.6, label="below ref. error estimate")
    if zero is not None:
        ax.axhline(zero * 1.7, color="0.5", lw=0.6, ls="--")
    ax.set_xscale("log")
    ax.set_yscale("log")
    xlo, xhi = log_limits(
        [v for p in pts for v in (p["time"], p.get("tmin"), p.get("tmax"))]
        + ([ref_time] if ref_time else [])
    )
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(ylo, yhi)
    _decade_ticks(ax, "x", xlo, xhi, None)
    _decade_ticks(ax, "y", ylo, yhi, zero)
    ax.set_xlabel(xlabel, fontsize=8)
    ax.set_ylabel("error_rel (max over path, own scale)", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ncol = 2 if len(pts) > 14 else 1
    ax.legend(
        fontsize=6.5,
        frameon=False,
        loc="center left",
        bbox_to_anchor=(1.01, 0.5),
        ncol=ncol,
        handletextpad=0.3,
        columnspacing=0.8,
    )
    fig.subplots_adjust(left=0.1, right=0.62 if ncol == 2 else 0.74, bottom=0.12, top=0.92)
    path.with_suffix(".json").write_text(json.dumps({"title": title, "points": drawn}, indent=1))
    return _save(fig, path)


def render_figure(
    meta: Mapping, ref_record: Mapping | None, path: Path, backend: str = "auto"
) -> Path | None:
    """Rendered final deformed scene of the reference model over the undeformed scene (grey).

    Drawn by ``fem_reference.export.render_png(path, shapes, reference_shapes, title)``:
    pyvista off-screen when its cached child-process probe says VTK can render here
    (``backend="auto"``), else matplotlib.  The other models are not overlaid: ``render_png``
    has one grey overlay, used for the undeformed scene (the ``shapes`` figure overlays all
    models).  None when there are no shapes or ``fem_reference.export`` is unavailable.
    """
    if ref_record is None or not ref_record.get("shapes"):
        return None
    try:
        from fem_reference.export import render_png
    except ImportError:
        return None
    shapes = {}
    for k, v in ref_record["shapes"].items():
        p = np.asarray([[np.nan if c is None else c for c in q] for q in v], dtype=float)
        if p.ndim == 2 and len(p) >= 2 and np.isfinite(p).all():
            shapes[k] = p
    if not shapes:
        return None
    undeformed = {k: np.asarray(v, dtype=float) for k, v in (meta.get("undeformed") or {}).items()}
    title = f"{meta.get('name', '')}: {ref_record['model']} (reference), last step"
    return Path(render_png(path, shapes, undeformed or None, title, backend=backend))
