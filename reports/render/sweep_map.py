"""A sweep's stability map as a thumbnail for its row on the front page.

One small cell per point, coloured by the reference's stability verdict at the end of the
deployment (``stability_maps.verdict``: blue stable, red unstable, grey undecided, black
failed or missing); the points are laid out as blocks, one block per value of the third
swept parameter, each block the first parameter across and the second down.  The full maps
(every method, labelled axes) are in the deploy section; the thumbnail shows at a glance
whether the sweep holds one verdict or crosses a boundary.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from reports.render.stability_maps import REFERENCE, verdict  # noqa: E402

COLOURS = {  # RGB of the verdicts (the deploy section's map colours)
    "stable": (0.12, 0.47, 0.71),
    "unstable": (0.84, 0.15, 0.16),
    "undecided": (0.6, 0.6, 0.6),
}
MISSING = (0.0, 0.0, 0.0)
CELL_PX = 6  # a point's square; 1 px of white between the blocks
HEIGHT_PX = 20  # the thumbnail's height cap: one line of the pick table


def layout(points: Sequence[Mapping[str, float]]) -> tuple[np.ndarray, tuple[int, int, int]]:
    """(block index, column, row) of each point and the grid shape (blocks, columns, rows):
    the swept parameters' sorted values, in the order the sweep names them (up to three;
    a missing axis has one value)."""
    keys = list(points[0])[:3]
    axes = [sorted({p[k] for p in points}) for k in keys] + [[0.0]] * (3 - len(keys))
    idx = np.array(
        [[axes[j].index(p[keys[j]]) if j < len(keys) else 0 for j in (2, 0, 1)] for p in points]
    )
    return idx, (len(axes[2]), len(axes[0]), len(axes[1]))


def image(points: Sequence[Mapping[str, float]], verdicts: Sequence[str]) -> np.ndarray:
    """RGB array (rows, columns, 3) of the thumbnail, one pixel per point (white gaps)."""
    idx, (nb, nc, nr) = layout(points)
    img = np.ones((nr, nb * (nc + 1) - 1, 3))
    for (b, c, r), v in zip(idx, verdicts):
        img[nr - 1 - r, b * (nc + 1) + c] = COLOURS.get(v, MISSING)
    return img


def thumbnail(
    names: Sequence[str], cases: Mapping, by_case: Mapping[str, Mapping], path: Path
) -> Path:
    """Write the sweep's thumbnail PNG (``names``: its point cases; ``by_case``: case ->
    model -> record) and return its path."""
    pts = [cases[n]["sweep"]["point"] for n in names]
    img = image(pts, [verdict(by_case.get(n, {}).get(REFERENCE)) for n in names])
    scale = max(1, min(CELL_PX, HEIGHT_PX // img.shape[0]))
    big = np.kron(img, np.ones((scale, scale, 1)))
    path.parent.mkdir(parents=True, exist_ok=True)
    plt.imsave(path, big)
    return path


def summary(names: Sequence[str], by_case: Mapping[str, Mapping]) -> str:
    """``"125 points: 98 stable, 27 unstable (kinetostatic)"`` (the thumbnail's hover text)."""
    vs = [verdict(by_case.get(n, {}).get(REFERENCE)) for n in names]
    counts = ", ".join(f"{vs.count(v)} {v}" for v in dict.fromkeys(vs))
    return f"{len(names)} points: {counts} ({REFERENCE})"
