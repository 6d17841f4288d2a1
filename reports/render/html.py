"""HTML formatting of the report blocks (one page; figures are linked PNG/GIF files)."""

from __future__ import annotations

import html
from collections.abc import Sequence

_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em;
       color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { border-bottom: 1px solid #aaa; margin-top: 2em; }
table { border-collapse: collapse; font-size: 0.82em; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } tr:nth-child(even) td { background: #fafafa; }
td.fail { color: #b00; font-weight: bold; } td.pass { color: #070; }
img { max-width: 100%; display: block; margin: 0.5em 0; }
p { max-width: 60em; }
"""


def _cell(text: str, tag: str = "td") -> str:
    cls = ""
    if tag == "td" and (text.startswith("FAIL") or text == "failed"):
        cls = ' class="fail"'
    elif tag == "td" and text.startswith("pass"):
        cls = ' class="pass"'
    return f"<{tag}{cls}>{html.escape(str(text))}</{tag}>"


def to_html(blocks: Sequence[tuple], title: str) -> str:
    """The blocks of ``reports.render.build_document`` as an HTML page."""
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
    ]
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3", "p"):
            out.append(f"<{kind}>{html.escape(block[1])}</{kind}>")
        elif kind == "table":
            headers, rows = block[1], block[2]
            out.append("<table>")
            if any(headers):
                out.append("<tr>" + "".join(_cell(h, "th") for h in headers) + "</tr>")
            for row in rows:
                out.append("<tr>" + "".join(_cell(c) for c in row) + "</tr>")
            out.append("</table>")
        elif kind == "img":
            src, alt = html.escape(block[1], quote=True), html.escape(block[2], quote=True)
            width = f' width="{int(block[3])}"' if len(block) > 3 and block[3] else ""
            out.append(f'<img src="{src}" alt="{alt}"{width} loading="lazy">')
        elif kind == "links":
            items = " · ".join(
                f'<a href="{html.escape(href, quote=True)}">{html.escape(text)}</a>'
                for text, href in block[2]
            )
            out.append(f"<p>{html.escape(block[1])}: {items}</p>")
        elif kind == "ul":
            out.append("<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in block[1]) + "</ul>")
    out.append("</body></html>")
    return "\n".join(out) + "\n"
