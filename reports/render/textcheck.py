"""Overlapping and clipped text in matplotlib figures, measured by the renderer.

``problems(fig)`` draws the figure and compares the window extents (pixels, from
``fig.canvas.get_renderer()``) of every drawn, non-empty ``Text`` artist: titles, axis
labels, the tick labels the axis actually draws, legend entries and titles, annotations,
contour labels, colour-bar labels.  It reports each pair overlapping by more than
``MIN_AREA`` px² and each text reaching outside the figure by more than ``EDGE`` px.
``checking()`` patches ``Figure.savefig`` so that every figure saved inside the block is
checked as it is written (whatever module draws it).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

MIN_AREA = 4.0  # px²: anti-aliasing fringes of touching glyph boxes are not overlaps
EDGE = 1.0  # px a text may reach past the figure's edge


def _shown(t: Text) -> bool:
    """Visible itself and in its axes (a hidden spare panel hides its labels)."""
    return t.get_visible() and (t.axes is None or t.axes.get_visible())


def _tick_labels(fig: Figure) -> tuple[set[int], set[int]]:
    """(ids of tick labels the axes draw, ids of every tick label): a tick outside the view
    keeps a label artist at a stale position that is never drawn."""
    drawn, every = set(), set()
    for ax in fig.axes:
        for axis in ax._axis_map.values():  # x, y (and z)
            for t in axis.get_major_ticks() + axis.get_minor_ticks():
                every.update((id(t.label1), id(t.label2)))
            if not (ax.axison and ax.get_visible()):  # hidden or axis("off"): never drawn
                continue
            for t in axis._update_ticks():
                drawn.update(id(lab) for lab in (t.label1, t.label2) if lab.get_visible())
    return drawn, every


def texts(fig: Figure) -> list[tuple[str, np.ndarray]]:
    """(text, [x0, y0, x1, y1] in px) of every drawn non-empty text of ``fig``."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    drawn, ticks = _tick_labels(fig)
    out = []
    for t in fig.findobj(Text):
        if not t.get_text().strip() or not _shown(t):
            continue
        if id(t) in ticks and id(t) not in drawn:
            continue
        ax = t.axes
        if ax is not None and not ax.axison and t in (ax.xaxis.label, ax.yaxis.label):
            continue
        box = t.get_window_extent(renderer)
        out.append((t.get_text(), np.array([box.x0, box.y0, box.x1, box.y1])))
    return out


def _areas(boxes: np.ndarray) -> np.ndarray:
    """Pairwise overlap areas (px²) of ``[x0, y0, x1, y1]`` boxes."""
    w = np.minimum(boxes[:, None, 2], boxes[None, :, 2]) - np.maximum(
        boxes[:, None, 0], boxes[None, :, 0]
    )
    h = np.minimum(boxes[:, None, 3], boxes[None, :, 3]) - np.maximum(
        boxes[:, None, 1], boxes[None, :, 1]
    )
    return np.clip(w, 0, None) * np.clip(h, 0, None)


def _frame(fig: Figure, tight: bool | Bbox) -> tuple[float, float, float, float]:
    """The saved image's extent in display px: the figure, with ``bbox_inches="tight"`` the
    box around every artist, with a ``Bbox`` (inches) that box: what the saved PNG holds."""
    if tight is False:
        return 0.0, 0.0, fig.bbox.width, fig.bbox.height
    box = fig.get_tightbbox(fig.canvas.get_renderer()) if tight is True else tight
    return box.x0 * fig.dpi, box.y0 * fig.dpi, box.x1 * fig.dpi, box.y1 * fig.dpi


def problems(
    fig: Figure, min_area: float = MIN_AREA, edge: float = EDGE, tight: bool | Bbox = False
) -> list[str]:
    """One line per overlapping pair of texts and per text outside the saved image
    (``tight``: saved with ``bbox_inches="tight"``, or a ``Bbox``: with that box, inches)."""
    found = texts(fig)
    if not found:
        return []
    area = _areas(np.array([b for _, b in found]))
    out = []
    for i, j in zip(*np.nonzero(np.triu(area > min_area, k=1))):
        a, b = found[i][0], found[j][0]
        out.append(f"overlap {area[i, j]:.0f} px²: {a[:40]!r} / {b[:40]!r}")
    X0, Y0, X1, Y1 = _frame(fig, tight)
    for text, (x0, y0, x1, y1) in found:
        if x0 < X0 - edge or y0 < Y0 - edge or x1 > X1 + edge or y1 > Y1 + edge:
            out.append(
                f"outside the figure ({x0:.0f}, {y0:.0f}, {x1:.0f}, {y1:.0f}): {text[:40]!r}"
            )
    return out


def thin_ticks(fig: Figure, most: int = 6) -> None:
    """Fewer ticks on every linear axis whose own tick labels overlap (narrow panels, long
    labels such as ``0.0025``): ``MaxNLocator`` from ``most`` bins down to 2.  Measured without
    drawing, so for figures laid out by ``subplots_adjust`` (no layout engine)."""
    from matplotlib.ticker import MaxNLocator

    renderer = fig.canvas.get_renderer()  # no draw: subplots_adjust layouts are fixed
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        ax.apply_aspect()  # an equal-aspect panel shrinks at draw time: measure it shrunk
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "linear":
                continue
            for n in range(most, 1, -1):
                labels = [t.label1 for t in axis._update_ticks() if t.label1.get_visible()]
                boxes = [lab.get_window_extent(renderer) for lab in labels if lab.get_text()]
                arr = np.array([[b.x0, b.y0, b.x1, b.y1] for b in boxes]).reshape(-1, 4)
                if not (np.triu(_areas(arr), k=1) > 0).any():
                    break
                axis.set_major_locator(MaxNLocator(n))


@contextlib.contextmanager
def checking() -> Iterator[dict[str, list[str]]]:
    """Within the block every ``Figure.savefig`` first records ``problems(fig)`` under the
    file name it writes (``{}`` for a clean figure)."""
    found: dict[str, list[str]] = {}
    original = Figure.savefig

    def savefig(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
        if "dpi" in kwargs:  # measured at the resolution it is written at
            self.set_dpi(kwargs["dpi"])
        key = str(fname) if not hasattr(fname, "write") else f"<buffer {len(found)}>"
        box = kwargs.get("bbox_inches")
        found[key] = problems(self, tight=box if isinstance(box, Bbox) else box == "tight")
        return original(self, fname, *args, **kwargs)

    Figure.savefig = savefig
    try:
        yield found
    finally:
        Figure.savefig = original
