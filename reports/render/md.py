"""Markdown formatting of the report blocks (GitHub-flavoured tables)."""

from __future__ import annotations

from collections.abc import Sequence


def _esc(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def to_markdown(blocks: Sequence[tuple]) -> str:
    """The blocks of ``reports.render.build_document`` as Markdown."""
    out: list[str] = []
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            out += ["#" * int(kind[1]) + " " + block[1], ""]
        elif kind == "p":
            out += [block[1], ""]
        elif kind == "table":
            headers, rows = block[1], block[2]
            width = max([len(headers)] + [len(r) for r in rows])
            head = list(headers) + [""] * (width - len(headers))
            out.append("| " + " | ".join(_esc(h) for h in head) + " |")
            out.append("|" + "---|" * width)
            for row in rows:
                cells = list(row) + [""] * (width - len(row))
                out.append("| " + " | ".join(_esc(c) for c in cells) + " |")
            out.append("")
        elif kind == "img":
            out += [f"![{_esc(block[2])}]({block[1]})", ""]
        elif kind == "links":
            items = " · ".join(f"[{_esc(text)}]({href})" for text, href in block[2])
            out += [f"{_esc(block[1])}: {items}", ""]
        elif kind == "ul":
            out += [f"- {_esc(i)}" for i in block[1]] + [""]
    return "\n".join(out)
