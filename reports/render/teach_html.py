"""The teaching page's HTML: the story first, anchored sections, costs last.

Order: a contents list; "the short answer" (a table of where each model stops at 1 %, from
the atlases); the deformed shapes with the load slider beside them; one section per model
family with a "where <model> stops" part per model (its atlases on axes with ticks and a
colour bar, the published claims, its card folded away); the mechanism atlases; which model
for each catalog case (a summary table, then the recommender's verdict tables per case);
how the errors are measured; what each model costs.  Every heading has a stable id
(``teach_story.slug``) and the contents list links them all.  Declined atlases are named in
one line instead of drawn.  Canvases are drawn by the inline script from the embedded data
(``__DATA__``); the text is written here.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from html import escape
from typing import Any

from reports.render import teach_story
from reports.render.teach_js import JS

STOP_TOL = 0.01  # the short answer's tolerance (the slider re-colours the atlases only)
FAMILY_LOADS = (("force", "tip force"), ("follower", "follower force"), ("moment", "end moment"))


class Page:
    """HTML pieces in order, and the contents list of every heading added."""

    def __init__(self) -> None:
        self.parts: list[str] = []
        self.toc: list[tuple[int, str, str]] = []

    def h(self, level: int, text: str, anchor: str | None = None, toc: bool = True) -> None:
        """A heading with an id (``slug(text)`` unless ``anchor``); in the contents when
        ``toc`` and level 2 or 3."""
        anchor = anchor or teach_story.slug(text)
        self.parts.append(f'<h{level} id="{anchor}">{escape(text)}</h{level}>')
        if toc and level <= 3:
            self.toc.append((level, anchor, text))

    def add(self, html: str) -> None:
        self.parts.append(html)

    def p(self, text: str, cls: str = "") -> None:
        self.parts.append(f"<p{f' class={cls!r}' if cls else ''}>{escape(text)}</p>")

    def contents(self) -> str:
        out, open3 = ['<nav id="contents"><b>Contents</b><ol>'], False
        for level, anchor, text in self.toc:
            link = f'<a href="#{anchor}">{escape(text)}</a>'
            if level == 2:
                out.append(("</ol>" if open3 else "") + f"<li>{link}")
                open3 = False
            else:
                out.append(("" if open3 else "<ol>") + f"<li>{link}</li>")
                open3 = True
        out.append(("</ol>" if open3 else "") + "</ol></nav>")
        return "".join(out)


def table(head: Sequence[str], rows: Sequence[Sequence[str]], raw: int = -1) -> str:
    """An HTML table; cells escaped except column ``raw`` (already HTML)."""
    th = "".join(f"<th>{escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>"
        + "".join(f"<td>{c if k == raw else escape(str(c))}</td>" for k, c in enumerate(r))
        + "</tr>"
        for r in rows
    )
    return f"<table><tr>{th}</tr>{body}</table>"


def _short_answer(pg: Page, data: Mapping, stops: Mapping, cards: Mapping) -> None:
    pg.h(2, "The short answer: where each model stops")
    pg.p(
        f"Largest load at which each model stays within {STOP_TOL:.0%} of the exact elastica "
        "on the default yardstick (error_rel), read from its validity atlases below: for a tip "
        "force transverse to the beam (90°) and, after the semicolon, at its worst load "
        "direction; loads as PL²/EI (force) and ML/EI (end moment). Click a model for its "
        "atlases and the reason it stops."
    )
    rows = []
    for F in data["families"]:
        for m in F["models"]:
            s = stops.get(m, {})
            link = f'<a href="#where-{teach_story.slug(m)}-stops">{escape(m)}</a>'
            why = cards.get(m, {}).get("validity", "")
            rows.append(
                [link, *(teach_story.reach_text(s.get(f), f) for f, _ in FAMILY_LOADS), why]
            )
    head = ["model", "tip force PL²/EI", "follower force PL²/EI", "end moment ML/EI", "claimed"]
    pg.add(table(head, rows, raw=0))
    models = [m for F in data["families"] for m in F["models"]]
    declined = teach_story.declined_lines(data["atlas"], models)
    if declined:
        pg.p("Not drawn below (declined): " + "; ".join(declined) + ".", "small")


def _shapes(pg: Page, data: Mapping) -> None:
    S = data["shapes"]
    pg.h(2, "Watch them bend: every model against the exact shape")
    pg.add(
        '<div class="shapes"><div class="side"><div>Load factor: <input id="load" '
        'type="range" min="0" max="1" step="1" value="0"> <b id="loadv"></b></div>'
        f'<div id="legend"></div><p class="small">Case {escape(S["case"])}: every model\'s '
        f"shape (colours) against the reference {escape(S['reference'])} (thick black), "
        "drawn 1:1; move the slider to load the beam.</p></div>"
        '<canvas id="shape" width="760" height="420"></canvas></div>'
    )


def _atlas_block(fam: str, model: str, A: Mapping) -> str:
    label = dict(FAMILY_LOADS)[fam]
    cv = (
        f'<canvas class="atlas" data-fam="{fam}" data-model="{escape(model)}" width="300" '
        f'height="{84 if fam == "moment" else 250}"></canvas>'
    )
    return f'<figure class="atl"><figcaption>{escape(label)}</figcaption>{cv}</figure>'


def _claims(fam: str, model: str, A: Mapping) -> list[str]:
    out = []
    for r in A.get("published") or []:
        if r["model"] != model:
            continue
        worst = (
            "" if r["worst"] is None else f" (worst {r['worst']:.3%} vs claimed {r['claimed']:.3%})"
        )
        cls = {"holds": "ok", "fails": "bad"}.get(r["verdict"], "")
        out.append(
            f'<li class="{cls}">Published claim {escape(r["id"])}: <b>{escape(r["verdict"])}'
            f"</b>{escape(worst)}. {escape(r['claim'])} Source: {escape(r['source'])}. "
            f"{escape(r['note'])}</li>"
        )
    for cl in A["models"][model]["claims"]:
        cls = "ok" if cl["verdict"] == "holds" else "bad"
        worst = "-" if cl["worst"] is None else f"{cl['worst']:.3%}"
        out.append(
            f'<li class="{cls}">{escape(cl["label"])} ({fam}): <b>{escape(cl["verdict"])}</b> '
            f"(worst {worst} vs {cl['accuracy']:.3%} on {escape(cl['metric'])}; "
            f"{cl['failing']}/{cl['points']} points fail). Reading: {escape(cl['reading'])}</li>"
        )
    return out


def _families(pg: Page, data: Mapping, stops: Mapping, cards: Mapping) -> None:
    atl = data["atlas"]
    for F in data["families"]:
        pg.h(2, F["title"])
        for m in F["models"]:
            pg.h(3, f"Where {m} stops", f"where-{teach_story.slug(m)}-stops")
            card = cards.get(m) or {}
            s = stops.get(m, {})
            reach = "; ".join(
                f"{label}: {teach_story.reach_text(s.get(f), f)}"
                for f, label in FAMILY_LOADS
                if f in atl
            )
            pg.p(f"{card.get('summary', '')} Within {STOP_TOL:.0%}: {reach}.")
            if card.get("validity"):
                pg.p(f"Why it stops (its claimed validity): {card['validity']}", "small")
            shown = [
                f for f in atl if m in atl[f]["models"] and (s.get(f) or {}).get("declined") is None
            ]
            pg.add('<div class="row">' + "".join(_atlas_block(f, m, atl[f]) for f in shown))
            png = atl.get("force", {}).get("models", {}).get(m, {}).get("png")
            if png:
                pg.add(
                    f'<figure class="atl"><figcaption>tip force, log10 error with 0.1/1/5 % '
                    f'contours</figcaption><img src="{png}" width="300" alt="{escape(m)} force '
                    f'atlas with contours"></figure>'
                )
            pg.add("</div>")
            declined = teach_story.declined_lines({f: atl[f] for f in atl}, [m])
            failed = [
                f"{f}: {atl[f]['models'][m]['message']}"
                for f in shown
                if atl[f]["models"][m].get("message")
            ]
            if declined or failed:
                pg.p("Not drawn or partly grey: " + "; ".join(declined + failed) + ".", "small")
            claims = [c for f in atl if m in atl[f]["models"] for c in _claims(f, m, atl[f])]
            if claims:
                pg.add('<ul class="small">' + "".join(claims) + "</ul>")
            if card:
                items = "".join(f"<li>{escape(a)}</li>" for a in card.get("assumptions", []))
                refs = "".join(f"<li>{escape(a)}</li>" for a in card.get("references", []))
                pg.add(
                    f"<details><summary>{escape(card['name'])}: assumptions and references"
                    f"</summary><ul>{items}</ul><b>References</b><ul>{refs}</ul></details>"
                )


def _mechanisms(pg: Page, data: Mapping) -> None:
    MA = data.get("mech_atlas") or {}
    if not MA:
        return
    pg.h(2, "Mechanism validity atlases over the driver range")
    for A in MA.values():
        pg.h(3, f"Mechanism atlas: {A['case']}", f"mech-{teach_story.slug(A['case'])}")
        if "none" in A:
            pg.p(f"No atlas: {A['none']}")
            continue
        pg.p(
            f"x: {A['drive_label']} from {A['drive'][0]} to {A['drive'][-1]}; y: "
            f"{A['axis_label']} from {A['values'][0]} to {A['values'][-1]} (why: "
            f"{A['axis_why']}). {A['wall_s']} s for the atlas."
        )
        drawn, none = [], []
        for m, v in A["models"].items():
            ok = any(e is not None for row in v["error"] for e in row)
            (drawn if ok else none).append((m, v))
        blocks = "".join(
            f'<figure class="atl"><figcaption>{escape(m)}</figcaption><canvas class="matlas" '
            f'data-fam="mech:{escape(A["case"])}" data-model="{escape(m)}" width="300" '
            f'height="190"></canvas></figure>'
            for m, _ in drawn
        )
        pg.add(f'<div class="row">{blocks}</div>')
        if none:
            pg.p(
                "Declined: " + "; ".join(f"{m} ({v['message'] or 'no state'})" for m, v in none),
                "small",
            )
        lines = [
            f"{c['model']}: {c['label']}: {c['verdict']} ({c['failing']}/{c['points']} states fail)"
            for c in A["claims"]
        ]
        if lines:
            pg.add('<ul class="small">' + "".join(f"<li>{escape(x)}</li>" for x in lines) + "</ul>")
        pg.add(f'<img src="{A["png"]}" class="wide" alt="{escape(A["case"])} atlas, log10 error">')


def _advice(pg: Page, data: Mapping) -> None:
    pg.h(2, "Which model for each catalog case")
    pg.p(
        "The recommender's pick per case and tolerance (flexbench recommend's rules over the "
        "models this run solved); open a case for its evidence table and error profile."
    )
    by_case: dict[str, list[Mapping]] = {}
    for a in data["advice"]:
        by_case.setdefault(a["case"], []).append(a)
    tols = sorted({a["tol"] for a in data["advice"]}, key=lambda t: -float(t.rstrip("%")))
    rows = []
    for case, advs in by_case.items():
        link = f'<a href="#advice-{teach_story.slug(case)}">{escape(case)}</a>'
        picks = {a["tol"]: a["recommended"] or "none qualifies" for a in advs}
        rows.append([link, *(picks.get(t, "-") for t in tols)])
    pg.add(table(["case", *(f"pick at {t}" for t in tols)], rows, raw=0))
    for case, advs in by_case.items():
        anchor = f"advice-{teach_story.slug(case)}"
        pg.add(f'<details class="adv" id="{anchor}"><summary>{escape(case)}: ')
        pg.add(escape(", ".join(f"{a['tol']}: {a['recommended'] or 'none'}" for a in advs)))
        pg.add("</summary>")
        for a in advs:
            T = a.get("table")
            pick = a["recommended"] or "no model qualifies"
            pg.add(f"<h4>{escape(case)} at {escape(a['tol'])}: {escape(pick)}</h4>")
            if T:
                how = f" (decided by: {T['decided_by']})" if T.get("decided_by") else ""
                pg.p(f"{T['reason']}{how}")
                if T["judged"]:
                    pg.p("Judged: " + "; ".join(T["judged"]), "small")
                pg.add(table(T["head"], T["rows"]))
                if T["skipped"]:
                    pg.p("Not run (cannot be cheaper): " + ", ".join(T["skipped"]), "small")
            else:
                pg.add(f"<pre>{escape(a.get('text', ''))}</pre>")
            if a.get("profiles"):
                pg.add(
                    f'<canvas class="profile" data-case="{escape(case)}" '
                    f'data-tol="{escape(a["tol"])}" width="640" '
                    f'height="{max(240, 24 + 12 * len(a["profiles"]))}"></canvas>'
                )
        pg.add("</details>")


def _num(x: float | None, k: float) -> str:
    return "-" if x is None else f"{x * k:.3g}"


def _costs(pg: Page, data: Mapping) -> None:
    pg.h(2, "What each model costs")
    pg.add(f'<img src="{teach_story.cost_png(data["cost"])}" alt="CPU time against N">')
    P = data.get("per_state")
    if P:
        pg.h(3, "Atlas cost per load state (CPU, this machine)")
        pg.p(
            "CPU seconds of each model's whole atlas, per load state inside the batch, and a "
            "single 20-step solve's against it (how much cheaper a state is inside the batch).",
            "small",
        )
        rows = []
        for fam, ms in P.items():
            for m, v in ms.items():
                ratio = "-" if v["ratio"] is None else f"{v['ratio']:.3g}x"
                rows.append(
                    [
                        fam,
                        m,
                        _num(v["atlas_cpu_s"], 1),
                        _num(v["per_state_s"], 1e3),
                        _num(v["single_s"], 1e3),
                        ratio,
                    ]
                )
        head = ["family", "model", "atlas CPU s", "per state ms", "single solve ms", "ratio"]
        pg.add(f"<details><summary>{len(rows)} rows</summary>{table(head, rows)}</details>")


HOW = (
    "Errors are on the report's default yardstick (error_rel): the largest deviation of the "
    "tip from the exact elastica on the ramp to that load, translations divided by the tip's "
    "own largest displacement and the rotation by its own largest rotation, so a model 5 % off "
    "in stiffness reads 5 % at any load. Atlas cells are green when the error is within the "
    "tolerance chosen in the bar at the top (darker = closer to the limit), red when not, grey "
    "where the model fails; the colour bar beside each atlas gives the error each colour "
    "stands for at that tolerance. Under each atlas: the published claim's own verdict, judged "
    "in the publication's metric, region and parameter values (flexbench claims). Outlined "
    "cells: the region of our test of that claim on this atlas (a stricter metric or a wider "
    'region, labelled "our test": never the publication\'s failure); black dots: points '
    "inside it where our test's accuracy is not met."
)


def page(data: Mapping[str, Any], cards: Mapping[str, Mapping]) -> str:
    """The whole page for ``data`` (``teaching.build_data``); ``cards``: model -> card."""
    stops = teach_story.stops(data["atlas"], STOP_TOL)
    pg = Page()
    _short_answer(pg, data, stops, cards)
    _shapes(pg, data)
    _families(pg, data, stops, cards)
    _mechanisms(pg, data)
    _advice(pg, data)
    pg.h(2, "How the errors are measured and the atlases read")
    pg.p(HOW)
    _costs(pg, data)
    if data.get("note"):
        pg.add(f'<p id="note" class="small">{escape(data["note"])}</p>')
    payload = json.dumps(data, allow_nan=False, separators=(",", ":")).replace("</", "<\\/")
    return (
        _HEAD
        + pg.contents()
        + "".join(pg.parts)
        + '<pre id="selftest"></pre><script type="application/json" id="data">'
        + payload
        + "</script><script>"
        + JS
        + "</script></body></html>"
    )


_HEAD = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>FlexBench: which model, and where</title>
<style>
body{font-family:system-ui,sans-serif;max-width:1260px;margin:0 auto;padding:0 1em;color:#222}
h2{border-bottom:1px solid #aaa;margin-top:1.6em} h3{margin:1.2em 0 .3em}
h2,h3,details{scroll-margin-top:2.6em}
.ctl{position:sticky;top:0;background:#fff;padding:.4em;border-bottom:1px solid #ddd;z-index:2}
nav ol{columns:2;font-size:.9em} nav ol ol{columns:1}
table{border-collapse:collapse;font-size:.85em;margin:.4em 0}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top}
td a{white-space:nowrap} th{background:#f0f0f0}
.row{display:flex;flex-wrap:wrap;gap:6px;align-items:flex-start}
.atl{margin:0;font-size:.8em} .atl figcaption{font-weight:bold}
.small{font-size:.82em;color:#444} .ok{color:#070} .bad{color:#b00}
.shapes{display:flex;gap:12px;align-items:flex-start} .shapes .side{width:330px}
.shapes canvas{border:1px solid #ccc} #legend span{display:block}
img.wide{max-width:100%} details.adv{margin:.2em 0} details.adv summary{cursor:pointer}
pre{background:#f6f6f6;padding:.5em;overflow-x:auto;font-size:.78em}
</style></head><body>
<div class="ctl">Atlas tolerance: <input id="tol" type="range" min="-4" max="-1" step="0.05"
value="-2"> <b id="tolv"></b> <a href="#contents">contents</a></div>
<h1>Which model should I use, and where does each stop being good enough?</h1>
<p>Every reduced beam model against the exact elastica: first where each one stops being good
enough and why, then the shapes they draw, each model's validity atlases, the pick for each
catalog case, and last what each costs.</p>
"""
