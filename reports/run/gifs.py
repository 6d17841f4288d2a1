"""Animated GIFs of moving member shapes, drawn once and blitted per frame.

matplotlib's ``FuncAnimation`` + ``PillowWriter`` draws the whole figure twice per frame
(``draw_idle`` after the update, then ``savefig`` to grab it): axes, spines and title
layout are re-rendered every time although only the lines and the title text move.  Here
the static figure is rendered once at the GIF's dpi, its pixels are kept, and each frame
restores them and draws only the moving artists (``Axes.draw_artist``), then hands the
canvas buffer to Pillow with the same frame mode and timing as ``PillowWriter``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text


def shapes_gif(
    path: str | Path,
    frames: Sequence[tuple[dict[str, np.ndarray], str]],
    *,
    dpi: float,
    fps: int,
    marker: str | None = None,
    ticks: bool = False,
) -> None:
    """Write a GIF of member polylines moving over fixed axes.

    Parameters
    ----------
    path : output ``.gif`` file.
    frames : per frame, (shapes, title): ``shapes`` maps a member name to its (n, 2)
        node coordinates (m; the members of the first frame are drawn), ``title`` is the
        axes title of that frame.
    dpi : pixels per inch of the 5 x 4 in figure.
    fps : frames per second (each frame lasts ``int(1000 / fps)`` ms, as in ``PillowWriter``).
    marker : node marker of the lines (``None``: plain lines).
    ticks : keep the axis ticks (without labels when False there are no ticks at all).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = np.vstack([np.asarray(xy) for sh, _ in frames for xy in sh.values()])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * max(hi - lo) + 1e-12
    fig, ax = plt.subplots(figsize=(5, 4), dpi=dpi)
    try:
        ax.set(xlim=(lo[0] - pad, hi[0] + pad), ylim=(lo[1] - pad, hi[1] + pad), aspect="equal")
        if not ticks:
            ax.set_xticks([])
            ax.set_yticks([])
        style = {"lw": 2} if marker is None else {"lw": 2, "marker": marker, "ms": 3}
        lines = {m: ax.plot([], [], animated=True, **style)[0] for m in frames[0][0]}
        title = ax.set_title("", animated=True)
        _blit_frames(fig, frames, lines, title, path, fps)
    finally:
        plt.close(fig)


def _blit_frames(
    fig: Figure,
    frames: Sequence[tuple[dict[str, np.ndarray], str]],
    lines: dict[str, Line2D],
    title: Text,
    path: str | Path,
    fps: int,
) -> None:
    """Render the static figure once, then per frame restore it, draw the frame's lines
    and title and keep the canvas as one Pillow image: RGB, or RGBA where it has
    transparency, as ``PillowWriter`` keeps it."""
    from PIL import Image

    canvas, ax = fig.canvas, title.axes
    canvas.draw()  # animated artists are skipped: this is the static background
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for shapes, text in frames:
        canvas.restore_region(background)
        for m, line in lines.items():
            xy = np.asarray(shapes[m])
            line.set_data(xy[:, 0], xy[:, 1])
            ax.draw_artist(line)
        title.set_text(text)
        ax.draw_artist(title)
        im = Image.fromarray(np.asarray(canvas.buffer_rgba()).copy(), "RGBA")
        images.append(im if im.getextrema()[3][0] < 255 else im.convert("RGB"))
    images[0].save(
        str(path), save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0
    )
