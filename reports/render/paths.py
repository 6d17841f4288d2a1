"""Figures along the path: load factor against outputs (zoomed to the reference), error
against load factor per model, and the replay's time histories as labelled panels.

Zoom rule: each panel's range is the reference's own range plus a margin (from the data, not
symmetric about zero nor a fixed fraction of L); a model's point
outside it is drawn on the edge with a hollow marker (so a linear blow-up to -6 L cannot
rescale a plot whose reference spans 0..-0.8 L).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from reports.render.figures import (
    QUANTITIES,
    _save,
    _series,
    marker_of,
    plt,
    reference_error_bars,
)
from reports.render.frontpage import ROUNDOFF, TOLERANCE
from reports.run.tables import unit_names

MARGIN = 0.12  # of the reference's range, each side
DATA_FLOOR = 1e-6  # path panels: smallest margin, of L (below it an output is round-off)


def zoom_range(values: np.ndarray, scale: float, floor: float = 0.05) -> tuple[float, float]:
    """Axis range around finite ``values`` with a margin (at least ``floor`` x ``scale``:
    a scene's frame keeps room around a straight member; a path panel passes a tiny floor so
    that a parasitic output 1e-3 of L fills its panel instead of looking flat)."""
    v = values[np.isfinite(values)]
    lo, hi = (float(v.min()), float(v.max())) if v.size else (-scale, scale)
    pad = max(MARGIN * (hi - lo), floor * scale)
    return lo - pad, hi + pad


def clip_mark(ax: Any, x: np.ndarray, y: np.ndarray, xr: tuple, yr: tuple, colour: Any) -> int:
    """Clip (x, y) into the ranges; hollow markers where a point was moved to the edge.
    Returns how many points were outside."""
    cx, cy = np.clip(x, *xr), np.clip(y, *yr)
    out = np.isfinite(x) & np.isfinite(y) & ((cx != x) | (cy != y))
    if out.any():
        ax.plot(cx[out], cy[out], "o", mfc="none", mec=colour, ms=5, mew=1.0)
    return int(out.sum())


def driver_xlabel(meta: Mapping) -> str:
    """x label of the driver figure: the driver coordinate of an energy analysis (Step.factor:
    degrees for a rotation, case length otherwise), else the load factor."""
    a = meta.get("analysis") or {}
    driver = a.get("driver") or {}
    if a.get("kind") != "energy" or not driver:
        return "load factor [–]"
    dunit = (
        "deg"
        if driver.get("kind") == "rotation"
        else (unit_names(meta.get("units", ""))["length"] or "–")
    )
    what = driver.get("node") or driver.get("member") or ""
    words = [driver.get("kind") or "", what, driver.get("direction") or ""]
    return f"driver: {' '.join(w for w in words if w)} [{dunit}]"


def _unit(meta: Mapping, q: str) -> str:
    return "rad" if q == "rot" else (unit_names(meta.get("units", ""))["length"] or "–")


def path_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Load factor against ux, uy, rot of the primary output: every model + the reference
    (black, with its error bars when it has an estimate), zoomed to the reference's range."""
    out = meta.get("primary_output")
    recs = [r for r in records if r["steps"]]
    ref_rec = next((r for r in recs if r["model"] == ref), None)
    if not out or not recs:
        return None
    length = float(meta.get("length_scale") or 1.0)
    fig, axes = plt.subplots(1, 3, figsize=(11.0, 3.3))
    outside: dict[str, int] = {}
    for ax, q in zip(axes, QUANTITIES):
        key = f"{out}.{q}"
        if all(roundoff(_series(r, key)) for r in recs):
            _roundoff_panel(ax, f"{key} [{_unit(meta, q)}]")
            continue
        basis = ref_rec or recs[0]
        xr = zoom_range(_series(basis, key), length if q != "rot" else 1.0, DATA_FLOOR)
        yr = zoom_range(_series(basis, "factor"), 1.0, DATA_FLOOR)
        for r in sorted(recs, key=lambda r: r["model"] == ref):
            x, y = _series(r, key), _series(r, "factor")
            if not np.any(np.isfinite(x)):
                continue
            if r["model"] == ref:
                ax.plot(x, y, "k-", lw=2.4, alpha=0.5, label=f"{r['model']} (reference)")
                reference_error_bars(ax, r, key, x, y)
                continue
            colour = cmap.get(r["model"], "C0")
            ok = r["status"] == "converged"
            cx, cy = np.clip(x, *xr), np.clip(y, *yr)
            lab = r["model"] + ("" if ok else " (failed)")
            mk = marker_of(r["model"], cmap)
            ax.plot(cx, cy, "-" if ok else ":", marker=mk, ms=2.5, lw=1, color=colour, label=lab)
            n = clip_mark(ax, x, y, xr, yr, colour)
            outside[r["model"]] = outside.get(r["model"], 0) + n
        ax.set_xlim(*xr)
        ax.set_ylim(*yr)
        ax.set_xlabel(f"{key} [{_unit(meta, q)}]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(driver_xlabel(meta), fontsize=7)
    handles, labels = max((ax.get_legend_handles_labels() for ax in axes), key=lambda h: len(h[0]))
    labels = [f"{lab} ({outside[lab]} off-scale)" if outside.get(lab) else lab for lab in labels]
    fig.legend(
        handles,
        labels,
        loc="center left",
        bbox_to_anchor=(0.80, 0.5),
        fontsize=7,
        frameon=False,
        title="hollow: outside the\nreference's range",
        title_fontsize=6,
    )
    fig.subplots_adjust(left=0.06, right=0.79, bottom=0.16, top=0.95, wspace=0.3)
    return _save(fig, path)


def roundoff(v: np.ndarray) -> bool:
    """All finite values below ``ROUNDOFF`` in magnitude (noise, not data)."""
    f = v[np.isfinite(v)]
    return bool(f.size == 0 or np.max(np.abs(f)) < ROUNDOFF)


def _roundoff_panel(ax: Any, label: str) -> None:
    ax.text(
        0.5,
        0.5,
        "0 (< 1e-12) on every path",
        ha="center",
        va="center",
        fontsize=8,
        transform=ax.transAxes,
    )
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_xlabel(label, fontsize=8)


def step_errors(rec: Mapping, ref_rec: Mapping, out: str, scale: Mapping[str, float]) -> tuple:
    """(factors, ``error_rel`` per step): the largest of |d ux|, |d uy|, |d rot| against the
    reference at the same factor (interpolated on a monotonic reference factor), each over
    its divisor in ``scale`` (the reference path's yardstick, ``reports.verdicts.yardstick``)."""
    f_r, f_m = _series(ref_rec, "factor"), _series(rec, "factor")
    errs = np.zeros_like(f_m)
    mono = f_r.size >= 2 and np.all(np.diff(f_r) > 0)
    for q in QUANTITIES:
        key = f"{out}.{q}"
        r, m = _series(ref_rec, key), _series(rec, key)
        if mono:
            refv = np.interp(f_m, f_r, r, left=np.nan, right=np.nan)
        else:
            idx = [np.flatnonzero(np.isclose(f_r, f, rtol=1e-9)) for f in f_m]
            refv = np.array([r[i[0]] if i.size else np.nan for i in idx])
        errs = np.fmax(errs, np.abs(m - refv) / scale.get(key, 1.0))
    errs[~np.isfinite(_series(rec, f"{out}.ux"))] = np.nan
    return f_m, errs


def error_factor_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Error against load factor, one line per model on a log axis, the tolerance line, and
    where each model first leaves it (marker; the legend says at which factor).  Round-off
    errors sit on a ``0 (< 1e-12)`` row."""
    from reports.render.figures import _decade_ticks

    out = meta.get("primary_output")
    ref_rec = next((r for r in records if r["model"] == ref and r["steps"]), None)
    recs = [r for r in records if r["steps"] and r["model"] != ref and r["status"] != "failed"]
    if not out or ref_rec is None or not recs:
        return None
    from reports.verdicts.errors import reference_yardstick

    scale = reference_yardstick(meta, ref_rec["steps"]).scale
    series = [(r, *step_errors(r, ref_rec, out, scale)) for r in recs]
    series = [s for s in series if np.any(np.isfinite(s[2]))]
    if not series:
        return None
    finite = np.concatenate([e[np.isfinite(e) & (e >= ROUNDOFF)] for _, _, e in series] + [[]])
    hi = max(float(finite.max()) * 2 if finite.size else 1.0, 3 * TOLERANCE)
    lo = min(float(finite.min()) / 2 if finite.size else 1e-6, TOLERANCE / 10)
    zero = lo / 3
    fig, ax = plt.subplots(figsize=(7.6, 3.6))
    for r, f, e in sorted(series, key=lambda s: s[0]["model"]):
        colour = cmap.get(r["model"], "C0")
        shown = np.where(e < ROUNDOFF, zero, e)
        over = np.flatnonzero(np.isfinite(e) & (e > TOLERANCE))
        note = f"leaves {TOLERANCE:g} at {f[over[0]]:.3g}" if over.size else "within"
        ax.plot(
            f,
            shown,
            "-",
            color=colour,
            lw=1,
            marker=marker_of(r["model"], cmap),
            ms=3,
            label=f"{r['model']}: {note}",
        )
        if over.size:
            ax.plot(f[over[0]], shown[over[0]], "o", mfc="none", mec="r", ms=8)
    ax.axhline(TOLERANCE, color="r", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_ylim(zero / 2, hi)
    _decade_ticks(ax, "y", zero / 2, hi, zero)
    ax.set_xlabel(driver_xlabel(meta), fontsize=7)
    ax.set_ylabel(f"error_rel of {out} (own scale)", fontsize=7)
    ax.set_title(
        f"error along the path against {ref} (red dashed: tolerance {TOLERANCE:g}; "
        "red circle: first step outside)",
        fontsize=8,
    )
    ax.tick_params(labelsize=6)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, frameon=False, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.subplots_adjust(left=0.1, right=0.66, bottom=0.13, top=0.92)
    return _save(fig, path)


def _history_groups(hist: Mapping, meta: Mapping) -> list[tuple[str, list[str]]]:
    """Panels of a replay history: (y label with unit, keys)."""
    u = unit_names(meta.get("units", ""))
    energy = [k for k in ("kinetic", "strain", "dissipated", "external_work") if k in hist]
    groups = [("load factor [–]", [k for k in ("factor",) if k in hist])]
    groups.append((f"energy [{u['energy'] or '–'}]", energy))
    groups.append(
        (f"displacement [{u['length'] or '–'}]", [k for k in hist if k.endswith((".ux", ".uy"))])
    )
    groups.append(("rotation [rad]", [k for k in hist if k.endswith(".rot")]))
    rest = [k for k in hist if k != "t" and not any(k in g for _, g in groups)]
    rest = [k for k in rest if not k.endswith((".x", ".y"))]  # positions repeat ux, uy
    groups.append(("other", rest))
    return [(lab, keys) for lab, keys in groups if keys]


def _hist_values(hist: Mapping, key: str) -> np.ndarray:
    return np.asarray([np.nan if x is None else x for x in hist[key]], dtype=float)


def history_figure(meta: Mapping, records: Sequence[Mapping], path: Path) -> Path | None:
    """The replay's time history as stacked panels sharing the time axis: load factor,
    energies, displacements, rotations (units from the case)."""
    recs = [r for r in records if isinstance((r.get("extras") or {}).get("history"), Mapping)]
    if not recs:
        return None
    hist = recs[0]["extras"]["history"]
    t = np.asarray(hist.get("t", []), dtype=float)
    groups = [
        (lab, [k for k in keys if len(hist[k]) == t.size])
        for lab, keys in _history_groups(hist, meta)
    ]
    zero = [k for _, keys in groups for k in keys if roundoff(_hist_values(hist, k))]
    groups = [(lab, [k for k in keys if k not in zero]) for lab, keys in groups]
    groups = [g for g in groups if g[1]]
    if not groups or t.size == 0:
        return None
    fig, axes = plt.subplots(
        len(groups), 1, figsize=(7.5, 1.5 * len(groups) + 0.6), sharex=True, squeeze=False
    )
    for ax, (label, keys) in zip(axes[:, 0], groups):
        for k in keys:
            ax.plot(t, _hist_values(hist, k), lw=1, label=k)
        ax.set_ylabel(label, fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, frameon=False, loc="center left", bbox_to_anchor=(1.0, 0.5))
    time_unit = "s" if "-" in (meta.get("units") or "") else "–"
    note = f"; {', '.join(zero)} = 0 (< 1e-12) throughout" if zero else ""
    axes[-1, 0].set_xlabel(f"time [{time_unit}] ({recs[0]['model']}{note})", fontsize=7)
    fig.subplots_adjust(left=0.12, right=0.8, bottom=0.1, top=0.97, hspace=0.15)
    return _save(fig, path)
