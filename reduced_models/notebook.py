"""A ``Solution`` in a notebook: a tidy pandas frame, two matplotlib plots, an HTML summary.

The ``Solution`` methods ``to_frame``, ``plot_path``, ``plot_shapes`` and ``_repr_html_``
call these functions; pandas and matplotlib are imported only when one is used, so a solve
never pays for them.

Units come from the case's unit system (``"m-N-Pa"``, ``"mm-N-MPa"``, ``"nondim"``), which
``reports.solve`` stores in ``extras["units"]``; an output's unit follows from its key's last
part (``tip.uy`` a length, ``tip.rot`` radians, ``boom.length`` a length, ``*.torque`` force
x length, ``*.force`` a force, ``*.ma`` a mechanical advantage, dimensionless).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from reduced_models.base import Solution

# (length, force, stress) per unit system of cases.schema.UNITS
_SYSTEMS = {
    "m-N-Pa": ("m", "N", "Pa"),
    "mm-N-MPa": ("mm", "N", "MPa"),
    "nondim": ("L", "F", "F/L^2"),  # dimensionless scene: in its own length and force scales
}
_LENGTH_PARTS = ("x", "y", "ux", "uy", "length")
_SUMMARY_KEYS = 6  # outputs shown by _repr_html_


def unit_table(keys: Sequence[str], system: str | None) -> dict[str, str]:
    """Unit of each column of ``to_frame`` for a unit system (None: unknown, ``"length"``
    etc. named generically).

    Parameters
    ----------
    keys : output keys (``tip.uy``, ``tip.rot``, ``boom.length``).
    system : ``"m-N-Pa"`` | ``"mm-N-MPa"`` | ``"nondim"`` | None.

    Returns
    -------
    column -> unit string (``"-"`` for the load factor, iteration counts and flags).
    """
    length, force, stress = _SYSTEMS.get(system or "", ("length", "force", "stress"))
    units = {"step": "-", "factor": "-", "energy": f"{force} {length}", "iterations": "-"}
    units |= {"stable": "-", "max_stress": stress}
    by_part = {"rot": "rad", "torque": f"{force} {length}", "force": force, "ma": "-"}
    for key in keys:
        part = key.rsplit(".", 1)[-1]
        units[key] = length if part in _LENGTH_PARTS else by_part.get(part, "?")
    return units


def output_keys(sol: Solution) -> list[str]:
    """Every output key of the solution's steps, in first-seen order."""
    return list(dict.fromkeys(k for s in sol.steps for k in s.outputs))


def to_frame(sol: Solution, units: str | None = None) -> Any:
    """One row per step: ``step``, ``factor``, every output, ``energy``, ``iterations``,
    ``stable``, ``max_stress`` (see ``Solution.to_frame``)."""
    import pandas as pd

    keys = output_keys(sol)
    rows = [
        {
            "step": i,
            "factor": s.factor,
            **{k: s.outputs.get(k, math.nan) for k in keys},
            "energy": s.energy,
            "iterations": s.iterations,
            "stable": s.stable,
            "max_stress": math.nan if s.max_stress is None else s.max_stress,
        }
        for i, s in enumerate(sol.steps)
    ]
    columns = ["step", "factor", *keys, "energy", "iterations", "stable", "max_stress"]
    df = pd.DataFrame(rows, columns=columns)
    system = units or sol.extras.get("units")
    df.attrs["units"] = unit_table(keys, system)
    df.attrs.update(case=sol.case, model=sol.model, status=sol.status, message=sol.message)
    df.attrs["unit_system"] = system
    return df


def _label(key: str, units: dict[str, str]) -> str:
    unit = units.get(key, "?")
    return key if unit == "-" else f"{key} ({unit})"


def _axes(ax: Any) -> Any:
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=(5, 3.6), layout="constrained")[1]


def plot_path(
    sol: Solution, y: str = "factor", x: str | None = None, ax: Any = None, **kwargs: Any
) -> Any:
    """Draw one output against another over the steps (see ``Solution.plot_path``)."""
    keys = output_keys(sol)
    if x is None:
        x = next((k for k in keys if k.endswith(".uy")), keys[0] if keys else "energy")
    for key in (x, y):
        if key not in ("factor", "energy") and key not in keys:
            raise KeyError(f"{sol.case} / {sol.model}: no output {key!r} (outputs: {keys})")
    units = unit_table(keys, sol.extras.get("units"))
    ax = _axes(ax)
    kwargs.setdefault("label", sol.model)
    kwargs.setdefault("marker", ".")
    ax.plot(sol.path(x), sol.path(y), **kwargs)
    ax.set_xlabel(_label(x, units))
    ax.set_ylabel(_label(y, units))
    ax.set_title(f"{sol.case}: {sol.model}", fontsize="medium")
    return ax


def plot_shapes(
    sol: Solution, steps: Sequence[int] | None = None, ax: Any = None, **kwargs: Any
) -> Any:
    """Draw the deformed members of some steps (see ``Solution.plot_shapes``)."""
    with_shapes = [i for i, s in enumerate(sol.steps) if s.shapes]
    if not with_shapes:
        raise ValueError(
            f"{sol.case} / {sol.model}: no shapes stored (reports.solve adds them; a "
            f"'{sol.status}' solution may have none)"
        )
    if steps is None:  # about five evenly spaced steps, the last one always
        picks = np.linspace(0, len(with_shapes) - 1, min(5, len(with_shapes)))
        steps = [with_shapes[i] for i in np.unique(picks.round().astype(int))]
    ax = _axes(ax)
    import matplotlib as mpl

    colours = mpl.colormaps["viridis"](np.linspace(0.0, 0.85, len(steps)))
    for colour, i in zip(colours, steps):
        step = sol.steps[i]
        for j, xy in enumerate(step.shapes.values()):
            xy = np.asarray(xy, dtype=float)
            label = f"factor {step.factor:.3g}" if j == 0 else None
            ax.plot(xy[:, 0], xy[:, 1], color=colour, label=label, **kwargs)
    length = _SYSTEMS.get(sol.extras.get("units") or "", ("length",))[0]
    ax.set(aspect="equal", xlabel=f"x ({length})", ylabel=f"y ({length})")
    ax.set_title(f"{sol.case}: {sol.model}", fontsize="medium")
    ax.legend(fontsize="small")
    return ax


def repr_html(sol: Solution) -> str:
    """Short HTML table: model, case, status, steps, final outputs, warnings."""
    e = html.escape
    rows = [("model", sol.model), ("case", sol.case), ("status", sol.status)]
    rows.append(("steps", str(len(sol.steps))))
    if sol.message:
        rows.append(("message", sol.message))
    if sol.steps:
        last = sol.steps[-1]
        units = unit_table(output_keys(sol), sol.extras.get("units"))
        rows.append(("final load factor", f"{last.factor:.6g}"))
        for key in output_keys(sol)[:_SUMMARY_KEYS]:
            rows.append((_label(key, units), f"{last.outputs.get(key, math.nan):.6g}"))
    for key in ("validity_warning", "postprocess_error"):
        if sol.extras.get(key):
            rows.append(("warning", str(sol.extras[key])))
    cell = "<tr><th style='text-align:left'>{}</th><td>{}</td></tr>"
    body = "".join(cell.format(e(k), e(v)) for k, v in rows)
    return f"<table class='flexbench-solution'>{body}</table>"
