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

import itertools
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DPI = 90
ERROR_FLOOR = 1e-16  # log axes cannot show an exact 0
QUANTITIES = ("ux", "uy", "rot")


def colours(models: Sequence[str]) -> dict[str, Any]:
    """One stable colour per model name across every figure of a report."""
    cmap = plt.get_cmap("tab10" if len(models) <= 10 else "tab20")
    return {m: cmap(i % cmap.N) for i, m in enumerate(sorted(models))}


def _series(rec: Mapping, key: str) -> np.ndarray:
    if key == "factor":
        return np.array([np.nan if s["factor"] is None else s["factor"] for s in rec["steps"]])
    vals = [s["outputs"].get(key) for s in rec["steps"]]
    return np.array([np.nan if v is None else v for v in vals], dtype=float)


def _save(fig: Any, path: Path) -> Path:
    fig.savefig(path, dpi=DPI)
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


def path_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Load factor against ux, uy, rot of the case's primary output, every model + reference."""
    out = meta.get("primary_output")
    recs = [r for r in records if r["steps"]]
    if not out or not recs:
        return None
    fig, axes = plt.subplots(1, 3, figsize=(10.0, 2.8))
    for ax, q in zip(axes, QUANTITIES):
        key = f"{out}.{q}"
        for r in sorted(recs, key=lambda r: r["model"] == ref):
            x, y = _series(r, key), _series(r, "factor")
            if not np.any(np.isfinite(x)):
                continue
            if r["model"] == ref:
                ax.plot(x, y, "k-", lw=2.2, alpha=0.55, label=f"{r['model']} (reference)")
                reference_error_bars(ax, r, key, x, y)
            else:
                style = "-" if r["status"] == "converged" else ":"
                ax.plot(
                    x,
                    y,
                    style,
                    marker=".",
                    ms=3,
                    lw=1,
                    color=cmap[r["model"]],
                    label=r["model"] + ("" if r["status"] == "converged" else " (failed)"),
                )
        unit = "rad" if q == "rot" else meta.get("units", "").split("-")[0]
        ax.set_xlabel(f"{key} [{unit}]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("load factor", fontsize=8)
    handles, labels = axes[0].get_legend_handles_labels()
    if not handles:
        handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="center left", bbox_to_anchor=(0.835, 0.5), fontsize=7, frameon=False
    )
    fig.subplots_adjust(left=0.06, right=0.83, bottom=0.17, top=0.95, wspace=0.28)
    return _save(fig, path)


def shapes_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Deformed shapes at the last step over the undeformed drawing (grey, dashed)."""
    recs = [r for r in records if r.get("shapes")]
    if not recs:
        return None
    fig, ax = plt.subplots(figsize=(5.0, 3.8))
    for pts in (meta.get("undeformed") or {}).values():
        p = np.asarray(pts, dtype=float)
        ax.plot(p[:, 0], p[:, 1], "--", color="0.6", lw=1)
    for r in sorted(recs, key=lambda r: r["model"] == ref):
        first = True
        for pts in r["shapes"].values():
            p = np.asarray([[np.nan if v is None else v for v in q] for q in pts], dtype=float)
            if p.size == 0:
                continue
            lab = r["model"] if first else None
            if r["model"] == ref:
                lab = f"{lab} (reference)" if lab else None
                ax.plot(p[:, 0], p[:, 1], "k-", lw=3, alpha=0.45, label=lab)
            else:
                ax.plot(p[:, 0], p[:, 1], "-", lw=1.2, color=cmap[r["model"]], label=lab)
            first = False
    ax.set_aspect("equal", adjustable="datalim")
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ax.set_title("deformed shapes, last step", fontsize=9)
    ax.legend(fontsize=6, frameon=False, loc="best")
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.1, top=0.92)
    return _save(fig, path)


def _log_axes(ax: Any) -> None:
    """Log-log axes with plain ``1e-03`` labels (mathtext tick labels cost ~10 ms each)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis in (ax.xaxis, ax.yaxis):
        lo, hi = axis.get_data_interval()
        if hi < 30 * lo:  # less than ~1.5 decades: label 1-2-5 steps, not just powers of 10
            axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0e}"))
        axis.set_minor_formatter(NullFormatter())


def pareto_front(points: Sequence[tuple[float, float]]) -> list[int]:
    """Indices of the non-dominated points (less time and less error is better), by time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def pareto_figure(
    points: Sequence[Mapping],
    path: Path,
    title: str,
    cmap: Mapping,
    ref_time: float | None = None,
    floor: float | None = None,
    xlabel: str = "wall time per solve [s]",
) -> Path | None:
    """Scatter of ``{"model", "time", "error", "tmin", "tmax", "ok"}`` with the front marked.

    ``ref_time``: the reference's wall time (vertical line); ``floor``: the reference's own
    error estimate (horizontal band: errors below it are not resolved).
    """
    pts = [p for p in points if p["time"] and p["error"] is not None and p["time"] > 0]
    if not pts:
        return None
    fig, ax = plt.subplots(figsize=(5.0, 3.8))
    xy = [(p["time"], max(p["error"], ERROR_FLOOR)) for p in pts]
    front = [i for i in pareto_front(xy) if pts[i]["ok"]]
    offsets = itertools.cycle([(3, 3), (3, -8), (-12, 5), (3, 9)])  # crowded labels fan out
    for p, (x, y) in zip(pts, xy):
        lo, hi = p.get("tmin") or x, p.get("tmax") or x
        ax.errorbar(
            x,
            y,
            xerr=[[x - lo], [hi - x]],
            fmt="o" if p["ok"] else "x",
            color=cmap.get(p["model"], "C0"),
            ms=5,
            capsize=2,
            lw=0.8,
        )
        ax.annotate(
            p["model"], (x, y), fontsize=6, xytext=next(offsets), textcoords="offset points"
        )
    if front:
        fx, fy = zip(*(xy[i] for i in front))
        ax.step(fx, fy, where="post", color="k", lw=1, alpha=0.7, label="Pareto front")
    if ref_time:
        ax.axvline(ref_time, color="k", ls=":", lw=1, label="reference time")
    if floor:
        lo = min(min(y for _, y in xy), floor) / 3  # the band must not stretch the axis
        ax.axhspan(lo, floor, color="0.85", alpha=0.6, label="ref. error estimate")
    _log_axes(ax)
    ax.margins(x=0.18, y=0.12)  # room for the labels of the extreme points
    ax.set_xlabel(xlabel, fontsize=8)
    ax.set_ylabel("summary error (max over path, /L or rad)", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    if front or ref_time or floor:
        ax.legend(fontsize=6, frameon=False, loc="best")
    fig.subplots_adjust(left=0.14, right=0.96, bottom=0.12, top=0.92)
    return _save(fig, path)


def history_figure(meta: Mapping, records: Sequence[Mapping], path: Path) -> Path | None:
    """Hook for the dynamics replay: time histories in ``extras["history"]``.

    ``history`` maps ``"t"`` and output keys to equally long lists; plotted when present.
    """
    recs = [r for r in records if isinstance((r.get("extras") or {}).get("history"), Mapping)]
    if not recs:
        return None
    fig, ax = plt.subplots(figsize=(6.0, 3.0))
    for r in recs:
        hist = r["extras"]["history"]
        t = np.asarray(hist.get("t", []), dtype=float)
        for key, vals in hist.items():
            if key == "t" or len(vals) != t.size:
                continue
            v = np.asarray([np.nan if x is None else x for x in vals], dtype=float)
            ax.plot(t, v, lw=1, label=f"{r['model']}: {key}")
    ax.set_xlabel("time", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, frameon=False)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.15, top=0.95)
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


def pyvista_figure(meta: Mapping, ref_record: Mapping | None, path: Path) -> Path | None:
    """Former hook name: ``render_figure`` with the automatic backend."""
    return render_figure(meta, ref_record, path)
