"""Markdown formatting of the report blocks (GitHub-flavoured tables, HTML anchors and
``<details>`` where Markdown has none).

Every block's text is plain text (case titles, tags, model names and messages come from
users' files): HTML is escaped as entities and Markdown's link/code syntax with backslashes,
so a title cannot inject markup into a rendered report.md.  Link targets are percent-encoded.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from urllib.parse import quote

from reports.render.cells import Cell, text_of

_MD_SPECIAL = re.compile(r"([\\`\[\]|])")


def _esc(text: object) -> str:
    """Plain text -> Markdown text that renders as exactly that text, on one line."""
    text = text_of(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return _MD_SPECIAL.sub(r"\\\1", " ".join(text.splitlines()))


def _href(path: str) -> str:
    return quote(str(path), safe="/#._-~%")


def _cell(cell: object) -> str:
    if isinstance(cell, Cell) and cell.href:
        return f"[{_esc(cell.text)}]({_href(cell.href)})"
    return _esc(cell)


def to_markdown(blocks: Sequence[tuple]) -> str:
    """The blocks of ``reports.render.build_document`` as Markdown."""
    out: list[str] = []
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            if len(block) > 2:
                out.append(f'<a id="{html.escape(block[2], quote=True)}"></a>')
            out += ["#" * int(kind[1]) + " " + _esc(block[1]), ""]
        elif kind == "p":
            out += [_esc(block[1]), ""]
        elif kind == "toc":
            out += [" · ".join(f"[{_esc(t)}](#{_href(a)})" for t, a in block[1]), ""]
        elif kind == "table":
            headers, rows = block[1], block[2]
            width = max([len(headers)] + [len(r) for r in rows])
            head = list(headers) + [""] * (width - len(headers))
            out.append("| " + " | ".join(_esc(h) for h in head) + " |")
            out.append("|" + "---|" * width)
            for row in rows:
                cells = list(row) + [""] * (width - len(row))
                out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
            out.append("")
        elif kind == "img":
            out += [f"![{_esc(block[2])}]({_href(block[1])})", ""]
        elif kind == "links":
            items = " · ".join(f"[{_esc(text)}]({_href(href)})" for text, href in block[2])
            out += [f"{_esc(block[1])}: {items}", ""]
        elif kind == "ul":
            out += [f"- {_esc(i)}" for i in block[1]] + [""]
        elif kind == "details":
            out += [f"<details><summary>{_esc(block[1])}</summary>", ""]
        elif kind == "/details":
            out += ["</details>", ""]
    return "\n".join(out)
