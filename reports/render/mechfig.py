"""Figures of whole scenes and driven mechanisms.

``shapes_figure``: one small panel per model with its deformed scene at several steps along
the path (light to dark) over the reference's (grey) and the undeformed drawing (dashed);
rigid links drawn as straight links with joint circles, PRB models as their rigid segments
with a dot at every pivot (whatever ``Step.shapes`` holds is drawn, nothing is re-derived);
axes zoomed to the reference, points outside marked hollow on the edge.  Where the
reference's deflections are small against the scene (``SMALL``) every shape is drawn with its
displacements magnified by one 1-2-5 factor, printed in the title ("deflection x 20").

``driver_figure``: energy, force along the driver and mechanical advantage against the
driver coordinate (or load factor), every model over the reference, equilibria marked
stable (filled) / unstable (red cross) from ``Step.stable``.

Both write the drawn end points / points beside the PNG as JSON (read from the artists; the
shapes' with the ``magnification`` they were drawn at) so tests can hold them against the
records.
"""

from __future__ import annotations

import json
import math
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.ticker import MaxNLocator

from reports.render.figures import _save, _series, plt
from reports.render.paths import clip_mark, driver_xlabel, zoom_range
from reports.run.tables import unit_names

SAME_AS_REF = 1e-3  # a model this close to the reference looks identical: named, not drawn
SMALL = 0.05  # reference deflections below this fraction of the scene's size are magnified
SHOWN = 0.2  # ... so that the largest is drawn at about this fraction of it
PIVOT_MAX_POINTS = 16  # a member drawn with this few points is a chain of rigid segments


def _values(rec: Mapping, key: str) -> np.ndarray:
    """``factor``, ``energy`` or an output along a record's steps (NaN where missing)."""
    if key == "energy":
        return np.array([np.nan if s.get("energy") is None else s["energy"] for s in rec["steps"]])
    return _series(rec, key)


def _pts(raw: Sequence) -> np.ndarray:
    p = np.asarray([[np.nan if c is None else c for c in q] for q in raw], dtype=float)
    return p.reshape(-1, 2)


def _steps_of(rec: Mapping) -> dict[int, dict[str, np.ndarray]]:
    """Step index -> member -> points (``shape_steps``, else the last step's ``shapes``)."""
    st = rec.get("shape_steps") or {}
    if st:
        return {int(i): {m: _pts(p) for m, p in sh.items()} for i, sh in st.items()}
    if rec.get("shapes") and rec.get("steps"):
        return {len(rec["steps"]) - 1: {m: _pts(p) for m, p in rec["shapes"].items()}}
    return {}


def _draw_scene(
    ax: Any,
    shapes: Mapping,
    kinds: Mapping,
    colour: Any,
    alpha: float,
    pivots: bool,
    lw: float = 1.3,
) -> dict[str, list]:
    """One deformed scene as a few artists (a line collection per member kind, one marker
    line for joints and one for pivots: a line per member and step made the scene figures
    a quarter of the report's drawing time); returns member -> drawn last point."""
    flex: dict[str, np.ndarray] = {}
    rigid: dict[str, np.ndarray] = {}
    for member, p in shapes.items():
        if len(p):
            (rigid if kinds.get(member) == "rigid" else flex)[member] = p
    ends: dict[str, Any] = {}
    if rigid:
        segs = [p[[0, -1]] for p in rigid.values()]
        drawn = _collection(ax, rigid, segs, colour, alpha, lw + 1.6, capstyle="round")
        ends.update(drawn)
        joints = np.vstack(segs)
        ax.plot(joints[:, 0], joints[:, 1], "o", mfc="w", mec=colour, ms=3.5, alpha=alpha)
    if flex:
        ends.update(_collection(ax, flex, list(flex.values()), colour, alpha, lw))
        if pivots:
            pts = [p[1:-1] for p in flex.values() if len(p) <= PIVOT_MAX_POINTS]
            if pts:
                pv = np.vstack(pts)
                ax.plot(pv[:, 0], pv[:, 1], "o", color=colour, ms=3.2, alpha=alpha)
                ends["_pivots"] = len(pv)
    return ends


def _collection(
    ax: Any, members: Mapping, segs: list, colour: Any, alpha: float, lw: float, **kw: Any
) -> dict[str, list]:
    """Add ``segs`` (one polyline per member) as one line collection above the dashed
    undeformed drawing; member -> last point, read back from the artist."""
    from matplotlib.collections import LineCollection

    lc = LineCollection(segs, colors=[colour], linewidths=lw, alpha=alpha, zorder=2, **kw)
    ax.add_collection(lc, autolim=False)
    return {m: [float(v) for v in seg[-1]] for m, seg in zip(members, lc.get_segments())}


def _rest(p: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Undeformed positions of a member's drawn points: along its straight chord ``ends``
    at the deformed polyline's arc-length fractions (length is kept by the beams and links
    drawn here, so arc length is the material coordinate)."""
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    s = s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(p))
    return ends[0] + s[:, None] * (ends[1] - ends[0])


def magnification(meta: Mapping, ref_steps: Mapping) -> float:
    """Factor the deflections are drawn at: 1, or a 1-2-5 number bringing the reference's
    largest displacement to about ``SHOWN`` of the scene's size when it is below ``SMALL``
    (a parallel guide's 1.25 mm on 50 mm leaves is invisible at 1:1)."""
    und = {m: np.asarray(v, dtype=float) for m, v in (meta.get("undeformed") or {}).items()}
    if not und or not ref_steps:
        return 1.0
    allu = np.vstack(list(und.values()))
    size = float(np.ptp(allu, axis=0).max()) or float(meta.get("length_scale") or 1.0)
    disp = [
        np.abs(p - _rest(p, und[m])).max()
        for sh in ref_steps.values()
        for m, p in sh.items()
        if m in und and len(p) >= 2 and np.isfinite(p).all()
    ]
    d = max(disp, default=0.0)
    if not d or d >= SMALL * size:
        return 1.0
    raw = SHOWN * size / d
    decade = 10.0 ** math.floor(math.log10(raw))
    return float(max(m * decade for m in (1, 2, 5) if m * decade <= raw))


def magnify(shapes: Mapping, meta: Mapping, k: float) -> dict[str, np.ndarray]:
    """``shapes`` (member -> points) with displacements from the undeformed drawing x ``k``."""
    und = meta.get("undeformed") or {}
    if k == 1.0:
        return dict(shapes)
    out = {}
    for m, p in shapes.items():
        if m in und and len(p) >= 2:
            rest = _rest(p, np.asarray(und[m], dtype=float))
            p = rest + k * (p - rest)
        out[m] = p
    return out


def _frame(meta: Mapping, ref_steps: Mapping) -> tuple[tuple, tuple]:
    pts = [np.asarray(v, dtype=float) for v in (meta.get("undeformed") or {}).values()]
    pts += [p for sh in ref_steps.values() for p in sh.values() if len(p)]
    allp = np.vstack(pts) if pts else np.zeros((1, 2))
    scale = float(meta.get("length_scale") or 1.0)
    return zoom_range(allp[:, 0], scale), zoom_range(allp[:, 1], scale)


def shapes_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Per-model panels of the deformed scene along the path (see module docstring)."""
    recs = [r for r in records if _steps_of(r)]
    close = sorted(
        r["model"]
        for r in recs
        if r["model"] != ref
        and r["status"] == "converged"
        and (r.get("error_rel") is not None and r["error_rel"] < SAME_AS_REF)
    )
    recs = [r for r in recs if r["model"] not in close]
    if not recs:
        return None
    recs.sort(key=lambda r: (r["model"] != ref, r["model"]))
    ref_rec = next((r for r in recs if r["model"] == ref), None)
    kinds = meta.get("member_kinds") or {}
    mag = magnification(meta, _steps_of(ref_rec or recs[0]))

    def steps_of(r: Mapping) -> dict[int, dict[str, np.ndarray]]:
        return {i: magnify(sh, meta, mag) for i, sh in _steps_of(r).items()}

    ref_steps = steps_of(ref_rec) if ref_rec else {}
    xr, yr = _frame(meta, ref_steps or steps_of(recs[0]))
    ncol = min(5, len(recs))
    nrow = math.ceil(len(recs) / ncol)
    aspect = (yr[1] - yr[0]) / max(xr[1] - xr[0], 1e-300)
    h = min(max(2.6 * aspect, 1.4), 3.2)
    width = {1: 6.0, 2: 3.6, 3: 2.9}.get(ncol, 2.4)  # inches per panel: few panels, larger
    h *= width / 2.7
    fig, axes = plt.subplots(nrow, ncol, figsize=(width * ncol, h * nrow + 0.6), squeeze=False)
    drawn: dict[str, dict] = {}
    for ax, r in zip(axes.flat, recs):
        for p in (meta.get("undeformed") or {}).values():
            p = np.asarray(p, dtype=float)
            ax.plot(p[:, 0], p[:, 1], "--", color="0.65", lw=0.8)
        if ref_steps and r is not ref_rec:
            _draw_scene(ax, ref_steps[max(ref_steps)], kinds, "0.55", 0.5, False, lw=2.4)
        steps = steps_of(r)
        colour = "k" if r is ref_rec else cmap.get(r["model"], "C0")
        pivots = r["model"].startswith("prb")
        drawn[r["model"]] = {"pivots": 0}
        for j, i in enumerate(sorted(steps)):
            alpha = 0.25 + 0.75 * (j + 1) / len(steps)
            shapes = {m: p for m, p in steps[i].items()}
            clipped = {
                m: np.column_stack([np.clip(p[:, 0], *xr), np.clip(p[:, 1], *yr)])
                for m, p in shapes.items()
                if len(p)
            }
            ends = _draw_scene(ax, clipped, kinds, colour, alpha, pivots)
            drawn[r["model"]]["pivots"] += ends.pop("_pivots", 0)
            for p in shapes.values():
                if len(p):
                    clip_mark(ax, p[:, 0], p[:, 1], xr, yr, colour)
            drawn[r["model"]][str(i)] = ends
        for s in meta.get("supports") or []:
            ax.plot(*s["xy"], "^" if s["type"] != "clamp" else "s", color="0.3", ms=5)
        label = f"{r['model']} (reference)" if r is ref_rec else r["model"]
        ax.set_title(
            label + ("" if r["status"] == "converged" else f" [{r['status']}]"), fontsize=7
        )
        ax.set_xlim(*xr)
        ax.set_ylim(*yr)
        ax.set_aspect("equal", adjustable="box")
        ax.tick_params(labelsize=6)
    for k, ax in enumerate(axes.flat[: len(recs)]):  # tick labels on the outer panels only
        row, col = divmod(k, ncol)
        if row < nrow - 1 and k + ncol < len(recs):
            ax.set_xticks([])
        else:
            ax.xaxis.set_major_locator(MaxNLocator(4))
        if col:
            ax.set_yticks([])
        else:
            ax.yaxis.set_major_locator(MaxNLocator(4))
    for ax in axes.flat[len(recs) :]:
        ax.set_visible(False)
    unit = unit_names(meta.get("units", ""))["length"] or "–"
    skipped = f"not drawn (within {SAME_AS_REF:g} of the reference): {', '.join(close)}"
    skipped = "\n" + textwrap.fill(skipped, int(16 * width * ncol), break_on_hyphens=False)
    scale = f"deflection x {mag:g} (magnified about the undeformed drawing); " if mag > 1 else ""
    title = (
        f"{scale}deformed scene along the path [{unit}]: light = early steps, dark = last; "
        "grey = reference at its last step; dots = PRB pivots; hollow = off-scale"
    )
    chars = int(16 * width * ncol)  # ~16 characters per inch at 7 pt
    title = textwrap.fill(title, chars, break_on_hyphens=False)  # never "prb-" / "3r"
    fig.suptitle(title + (skipped if close else ""), fontsize=7)
    fig.subplots_adjust(
        left=0.05,
        right=0.98,
        bottom=0.06,
        top=1 - 0.75 / (h * nrow + 0.6),
        wspace=0.25,
        hspace=0.35,
    )
    path.with_suffix(".json").write_text(
        json.dumps({"ends": drawn, "magnification": mag}, indent=1)
    )
    return _save(fig, path)


def _dot(unit: str) -> str:
    """A product unit as printed on an axis (``N mm`` -> ``N·mm``; none -> ``–``)."""
    return unit.replace(" ", "·") if unit else "–"


def _driver_panels(meta: Mapping, recs: Sequence[Mapping]) -> list[tuple[str, str]]:
    """(value key, y label) of the panels worth drawing for these records."""
    u = unit_names(meta.get("units", ""))
    keys = {k for r in recs for s in r["steps"][:1] for k in s["outputs"]}
    panels = []
    if any(np.any(np.isfinite(_values(r, "energy"))) for r in recs if r.get("steps")):
        vals = [e for r in recs for e in _values(r, "energy") if np.isfinite(e)]
        if vals and max(abs(v) for v in vals) > 0:
            panels.append(("energy", f"strain energy [{_dot(u['energy'])}]"))
    for k in sorted(keys):
        if k.startswith("driver.") and k != "driver.coordinate":
            what = k.split(".", 1)[1]
            # a torque is a force times a length: the energy unit's product (N mm)
            unit = {"force": u["force"], "torque": u["energy"]}.get(what, "")
            panels.append((k, f"{k} [{_dot(unit)}]"))
    panels += [(k, f"{k} [–]") for k in sorted(keys) if k == "ma" or k.endswith(".ma")]
    return panels


def driver_figure(
    meta: Mapping, records: Sequence[Mapping], ref: str | None, cmap: Mapping, path: Path
) -> Path | None:
    """Energy / driver force / MA against the driver coordinate with stability marked.

    Drawn for energy and distance analyses, and for any case where some model reports an
    unstable equilibrium (snap-through, bistable)."""
    recs = [r for r in records if r.get("steps")]
    kind = (meta.get("analysis") or {}).get("kind")
    unstable = any(s.get("stable") is False for r in recs for s in r["steps"])
    if not recs or (kind not in ("energy", "distance") and not unstable):
        return None
    panels = _driver_panels(meta, recs)
    if not panels:
        return None
    recs.sort(key=lambda r: r["model"] == ref)
    ref_rec = next((r for r in recs if r["model"] == ref), None)
    fig, axes = plt.subplots(1, len(panels), figsize=(10.0, 3.2), squeeze=False)
    drawn: dict[str, dict] = {}
    xlabel = driver_xlabel(meta)
    for ax, (key, ylabel) in zip(axes[0], panels):
        basis = _values(ref_rec or recs[0], key)
        size = float(np.nanmax(np.abs(basis), initial=0.0)) if np.isfinite(basis).any() else 1.0
        yr = zoom_range(basis, size or 1.0, 0.02)  # from the data: a 1e-3 swing is not flat
        for r in recs:
            x, y = _values(r, "factor"), _values(r, key)
            if not np.any(np.isfinite(y)):
                continue
            is_ref = r is ref_rec
            colour = "k" if is_ref else cmap.get(r["model"], "C0")
            lab = f"{r['model']} (reference)" if is_ref else r["model"]
            cy = np.clip(y, *yr)
            ax.plot(
                x,
                cy,
                "-",
                color=colour,
                lw=2.4 if is_ref else 1.0,
                alpha=0.5 if is_ref else 0.9,
                label=lab,
            )
            clip_mark(ax, x, y, (-np.inf, np.inf), yr, colour)
            st = [s.get("stable") for s in r["steps"]]
            good = np.array([v is True for v in st])
            bad = np.array([v is False for v in st])
            ax.plot(x[good], cy[good], "o", color=colour, ms=3)
            ax.plot(x[bad], cy[bad], "x", color="r", ms=6, mew=1.5)
            drawn.setdefault(r["model"], {})[key] = {"x": x.tolist(), "y": y.tolist(), "stable": st}
        ax.set_ylim(*yr)
        ax.set_xlabel(xlabel, fontsize=7)
        ax.set_ylabel(ylabel, fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    handles += [
        plt.Line2D([], [], ls="", marker="o", color="0.3", ms=3),
        plt.Line2D([], [], ls="", marker="x", color="r", ms=6),
    ]
    labels += ["stable equilibrium", "unstable equilibrium"]
    fig.legend(
        handles, labels, loc="center left", bbox_to_anchor=(0.80, 0.5), fontsize=6.5, frameon=False
    )
    fig.subplots_adjust(left=0.08, right=0.78, bottom=0.17, top=0.95, wspace=0.4)
    path.with_suffix(".json").write_text(json.dumps({"curves": drawn}))
    return _save(fig, path)
