"""HTML formatting of the report blocks: one page that opens from disk (figures are relative
PNG/GIF files beside it; no script, font or style sheet from the network), a table of
contents in a sticky side bar, folded per-case detail."""

from __future__ import annotations

import html
from collections.abc import Sequence

from reports.render.cells import Cell, text_of

_CSS = """
body { font-family: system-ui, sans-serif; margin: 0; color: #222; }
.layout { display: grid; grid-template-columns: 15em minmax(0, 1fr); }
nav { position: sticky; top: 0; height: 100vh; overflow-y: auto; background: #f6f6f6;
      border-right: 1px solid #ddd; font-size: 0.8em; padding: 0.6em 0.8em;
      box-sizing: border-box; }
nav ul { list-style: none; padding: 0; margin: 0; } nav li { margin: 0.15em 0; }
nav a { color: #124; text-decoration: none; } nav a:hover { text-decoration: underline; }
main { padding: 0 1.5em 3em; max-width: 1250px; }
h1 { border-bottom: 2px solid #444; margin-top: 0.4em; }
h2 { border-bottom: 1px solid #aaa; margin-top: 1.6em; }
table { border-collapse: collapse; font-size: 0.8em; margin: 0.5em 0; display: block;
        overflow-x: auto; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } tr:nth-child(even) td { background: #fafafa; }
td.good { background: #d9f2d9 !important; } td.warn { background: #fbeccb !important; }
td.bad, td.fail { background: #f7d4d4 !important; } td.fail { font-weight: bold; }
td.na { color: #999; } td.ref { background: #dde6f5 !important; }
img { max-width: 100%; display: block; margin: 0.5em 0; }
details { margin: 0.6em 0; } summary { cursor: pointer; color: #124; }
p { max-width: 62em; }
"""


def _cell(cell: object, tag: str = "td") -> str:
    attrs = ""
    if isinstance(cell, Cell):
        if cell.cls and tag == "td":
            attrs += f' class="{html.escape(cell.cls, quote=True)}"'
        if cell.title:
            attrs += f' title="{html.escape(cell.title, quote=True)}"'
        body = html.escape(cell.text)
        if cell.href:
            body = f'<a href="{html.escape(cell.href, quote=True)}">{body}</a>'
        return f"<{tag}{attrs}>{body}</{tag}>"
    text = text_of(cell)
    if tag == "td" and (text.startswith("FAIL") or text == "failed"):
        attrs = ' class="fail"'
    return f"<{tag}{attrs}>{html.escape(text)}</{tag}>"


def _block(block: tuple) -> str:
    kind = block[0]
    if kind == "h2" and len(block) > 2:
        return f'<h2 id="{html.escape(block[2], quote=True)}">{html.escape(block[1])}</h2>'
    if kind in ("h1", "h2", "h3", "p"):
        return f"<{kind}>{html.escape(block[1])}</{kind}>"
    if kind == "table":
        headers, rows = block[1], block[2]
        out = ["<table>"]
        if any(text_of(h) for h in headers):
            out.append("<tr>" + "".join(_cell(h, "th") for h in headers) + "</tr>")
        out += ["<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in rows]
        return "\n".join(out + ["</table>"])
    if kind == "img":
        src, alt = html.escape(block[1], quote=True), html.escape(block[2], quote=True)
        width = f' width="{int(block[3])}"' if len(block) > 3 and block[3] else ""
        return f'<img src="{src}" alt="{alt}"{width}>'
    if kind == "links":
        items = " · ".join(
            f'<a href="{html.escape(href, quote=True)}">{html.escape(text)}</a>'
            for text, href in block[2]
        )
        return f"<p>{html.escape(block[1])}: {items}</p>"
    if kind == "ul":
        return "<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in block[1]) + "</ul>"
    if kind == "details":
        return f"<details><summary>{html.escape(block[1])}</summary>"
    if kind == "/details":
        return "</details>"
    return ""


def _toc(items: Sequence[tuple[str, str]]) -> str:
    links = "".join(
        f'<li><a href="#{html.escape(a, quote=True)}">{html.escape(t)}</a></li>' for t, a in items
    )
    return f'<nav aria-label="contents"><strong>Contents</strong><ul>{links}</ul></nav>'


def to_html(blocks: Sequence[tuple], title: str) -> str:
    """The blocks of ``reports.render.build_document`` as an HTML page."""
    toc = [b[1] for b in blocks if b[0] == "toc"]
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<link rel="icon" href="data:,">',  # no favicon request
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        '<div class="layout">' if toc else "<div>",
    ]
    if toc:
        out.append(_toc(toc[0]))
    out.append("<main>")
    out += [_block(b) for b in blocks if b[0] != "toc"]
    out.append("</main></div></body></html>")
    return "\n".join(out) + "\n"
