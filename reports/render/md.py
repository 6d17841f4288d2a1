"""Markdown formatting of the report blocks (GitHub-flavoured tables, HTML anchors and
``<details>`` where Markdown has none)."""

from __future__ import annotations

from collections.abc import Sequence

from reports.render.cells import Cell, text_of


def _esc(text: object) -> str:
    return text_of(text).replace("|", "\\|").replace("\n", " ")


def _cell(cell: object) -> str:
    if isinstance(cell, Cell) and cell.href:
        return f"[{_esc(cell.text)}]({cell.href})"
    return _esc(cell)


def to_markdown(blocks: Sequence[tuple]) -> str:
    """The blocks of ``reports.render.build_document`` as Markdown."""
    out: list[str] = []
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            if len(block) > 2:
                out.append(f'<a id="{block[2]}"></a>')
            out += ["#" * int(kind[1]) + " " + block[1], ""]
        elif kind == "p":
            out += [block[1], ""]
        elif kind == "toc":
            out += [" · ".join(f"[{_esc(t)}](#{a})" for t, a in block[1]), ""]
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
            out += [f"![{_esc(block[2])}]({block[1]})", ""]
        elif kind == "links":
            items = " · ".join(f"[{_esc(text)}]({href})" for text, href in block[2])
            out += [f"{_esc(block[1])}: {items}", ""]
        elif kind == "ul":
            out += [f"- {_esc(i)}" for i in block[1]] + [""]
        elif kind == "details":
            out += [f"<details><summary>{_esc(block[1])}</summary>", ""]
        elif kind == "/details":
            out += ["</details>", ""]
    return "\n".join(out)
