"""Table cells with a CSS class, a link or a hover title (plain strings are cells too)."""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Cell:
    """One table cell: ``text``; ``cls`` (CSS class: good, warn, bad, na, fail, ref);
    ``href`` (a link, e.g. ``#case-x``); ``title`` (hover text in HTML); ``img`` (a small
    picture before the text in HTML, a relative path; Markdown shows the text only)."""

    text: str
    cls: str | None = None
    href: str | None = None
    title: str | None = None
    img: str | None = None

    def __str__(self) -> str:
        return self.text


def text_of(cell: object) -> str:
    """Plain text of a cell (a ``Cell`` or anything ``str()`` gives)."""
    return cell.text if isinstance(cell, Cell) else str(cell)
