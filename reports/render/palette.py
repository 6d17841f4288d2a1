"""One colour per model name, the same in every figure of a report and on the teaching page.

The catalog's models get fixed colours (``FIXED``: a name keeps its colour whatever else a
run solved, so ``prb-3r`` is the same orange in a case figure, the trend and the teaching
page); any other name (``linear-4``, ``prb-fsm-32``, a custom model) takes the first colour no
fixed name of the same call uses.  ``Palette.get`` never falls back to a shared default: an
unseen name gets its own colour too (a fallback of ``"C0"`` for every unknown model is how two
models came to share one).  Black is left for the reference, grey for the undeformed drawing.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

# 24 colours on white (no black, no greys): tab10 without its grey, then colours that differ
# from those in hue or clearly in lightness (navy vs blue, maroon vs red, dark olive vs olive);
# past about 15, colours alone stop telling lines apart, so the figures add markers
# (``figures.marker_of``) and the most often co-plotted models come first in ``FIXED_ORDER``.
COLOURS = (
    "#1f77b4",  # blue
    "#ff7f0e",  # orange
    "#2ca02c",  # green
    "#d62728",  # red
    "#9467bd",  # purple
    "#8c564b",  # brown
    "#e377c2",  # pink
    "#bcbd22",  # olive
    "#17becf",  # cyan
    "#000080",  # navy
    "#f032e6",  # magenta
    "#800000",  # maroon
    "#ffd700",  # gold
    "#469990",  # teal
    "#4b0082",  # indigo
    "#808000",  # dark olive
    "#fa8072",  # salmon
    "#00e676",  # spring green
    "#a0522d",  # sienna
    "#6495ed",  # cornflower
    "#2f4f4f",  # dark slate
    "#daa520",  # goldenrod
    "#c71585",  # violet red
    "#00ced1",  # turquoise
)

# The catalog's model names in the order they take colours (``api.default_names`` and the
# variants a run or the teaching page draws): reordering this list recolours every figure.
FIXED_ORDER = (
    "linear-1",
    "prb-3r",
    "bcm",
    "prb-1r",
    "prb-fsm-16",
    "cbcm-8",
    "prb-2r",
    "linear-8",
    "kinetostatic",
    "prb-short",
    "replay",
    "cbcm-2",
    "prb-2rpr",
    "fem-auto",
    "prb-fsm-4",
    "mixed",
    "linear-auto",
    "cbcm-auto",
    "prb-fsm-auto",
    "elastica",
    "elastica-bvp",
    "prb-3r-force",
    "prb-3r-moment",
    "thesis-force-method",
)
FIXED = {name: COLOURS[i % len(COLOURS)] for i, name in enumerate(FIXED_ORDER)}


class Palette(dict):
    """model -> colour (hex string); ``get`` gives an unseen name its own colour."""

    def get(self, name: str, default: Any = None) -> str:  # noqa: ARG002 - never shared
        """The name's colour; an unseen name takes the next colour no name here uses."""
        if name not in self:
            self[name] = _free(self.values(), name)
        return self[name]


def _free(used: Iterable[str], name: str) -> str:
    """The first colour of ``COLOURS`` not in ``used`` (cycled by a hash of ``name`` when
    all are taken, so the answer does not depend on call order)."""
    taken = set(used)
    for c in COLOURS:
        if c not in taken:
            return c
    return COLOURS[sum(name.encode()) % len(COLOURS)]


def palette(models: Iterable[str]) -> Palette:
    """Colours for ``models``: fixed names first, the others (sorted) on the free colours."""
    names = sorted(set(models))
    out = Palette({m: FIXED[m] for m in names if m in FIXED})
    for m in names:
        if m not in out:
            out[m] = _free(out.values(), m)
    return out


def colour(model: str) -> str:
    """One model's colour outside any figure's set (its fixed colour, else the first free)."""
    return palette([model])[model]
