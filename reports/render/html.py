"""HTML formatting of the report blocks: one page that opens from disk (figures are relative
PNG/GIF files beside it; no script, font or style sheet from the network), a table of
contents in a sticky side bar, folded per-case detail."""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence

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
.figs { display: grid; grid-template-columns: repeat(auto-fill, minmax(480px, 1fr));
        gap: 0.4em 1em; align-items: start; }
.figs img { width: 100%; height: auto; margin: 0; }
.figs a.wide { grid-column: 1 / -1; } .figs a.wide img { width: auto; max-width: 100%; }
table.pick { display: table; width: 100%; table-layout: fixed; }
table.pick th:nth-child(1) { width: 21%; } table.pick th:nth-child(2) { width: 10%; }
table.pick th:nth-child(3) { width: 9%; } table.pick th:nth-child(4) { width: 7%; }
table.pick th:nth-child(5) { width: 10%; }
table.pick td { white-space: nowrap; overflow: hidden; text-overflow: ellipsis; }
td img.thumb { display: inline-block; vertical-align: middle; margin: 0 0.5em 0 0;
               max-height: 20px; }
.scroll { overflow: auto; max-width: 100%; border: 1px solid #ccc;
          margin: 0.5em 0; }
.scroll table { display: table; margin: 0; font-size: 0.72em; }
table.map th { position: sticky; top: 0; z-index: 2; writing-mode: vertical-rl;
               transform: rotate(180deg); white-space: nowrap; padding: 4px 2px; }
table.map th:first-child { writing-mode: horizontal-tb; transform: none; left: 0;
                           z-index: 3; vertical-align: bottom; }
table.map td:first-child { position: sticky; left: 0; z-index: 1; background: #fff;
                           max-width: 16em; overflow: hidden; text-overflow: ellipsis;
                           white-space: nowrap; }
table.map td { padding: 1px 3px; white-space: nowrap; }
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
        if cell.img:
            src = html.escape(cell.img, quote=True)
            body = f'<img class="thumb" src="{src}" alt="">{body}'
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
        return _table(*block[1:])
    if kind == "img":  # a click opens the figure at full size
        src, alt = html.escape(block[1], quote=True), html.escape(block[2], quote=True)
        width = f' width="{int(block[3])}"' if len(block) > 3 and block[3] else ""
        cls = f' class="{html.escape(block[4], quote=True)}"' if len(block) > 4 and block[4] else ""
        return f'<a href="{src}"{cls}><img src="{src}" alt="{alt}"{width}></a>'
    if kind == "grid":
        return '<div class="figs">'
    if kind == "/grid":
        return "</div>"
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


def _table(headers: Sequence, rows: Sequence, opts: Mapping | None = None) -> str:
    """A table; ``opts["cls"]`` its CSS class (``map``: in a frame that scrolls, with the
    header row and the first column sticky)."""
    cls = (opts or {}).get("cls")
    out = [f'<table class="{html.escape(cls, quote=True)}">' if cls else "<table>"]
    if any(text_of(h) for h in headers):
        out.append("<tr>" + "".join(_cell(h, "th") for h in headers) + "</tr>")
    out += ["<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in rows]
    out.append("</table>")
    if cls == "map":
        out = ['<div class="scroll">', *out, "</div>"]
    return "\n".join(out)


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
