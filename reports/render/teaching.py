"""The teaching page: one self-contained HTML file (no network, no side files).

Sections: how errors are measured; one section per model family with each model's card, its
validity atlas (drawn on a canvas from embedded numbers, re-coloured by a tolerance slider,
with each published claim's own verdict (``reports.verdicts.claims``) and our test of it outlined,
its failing points marked), the measured cost scaling (CPU time vs N on one case) and a worked
"which model should I use" per catalog case from ``reports.verdicts.recommend``; a load slider that
moves every model's deformed shape against the reference for a chosen case.  All data are
embedded as JSON; inline JS draws.

``#selftest`` in the page's URL makes the script move both sliders and write a JSON verdict
(drawings changed, errors caught) into ``<pre id="selftest">`` -- what the browser test reads.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

import cases
from reports import api
from reports.render import mech_atlas
from reports.verdicts import atlas
from reports.verdicts import claims as published
from reports.verdicts.recommend import recommend
from reports.verdicts.recommendation import format_text

FAMILIES = {
    "linear": ("Linear beam, single and chained", ("linear-1", "linear-8"), "linear-N"),
    "bcm": ("Beam constraint model, single and chained", ("bcm", "cbcm-2", "cbcm-8"), "cbcm-N"),
    "prb": (
        "Pseudo-rigid-body models",
        ("prb-short", "prb-1r", "prb-2r", "prb-3r", "prb-2rpr", "prb-fsm-4", "prb-fsm-16"),
        "prb-fsm-N",
    ),
}
COST_N = (1, 2, 4, 8, 16, 32, 64)
SHAPE_MODELS = ("linear-1", "linear-8", "bcm", "cbcm-8", "prb-1r", "prb-3r", "prb-fsm-16")


def _r(a: Any, digits: int = 4) -> Any:
    """Numbers rounded for embedding; NaN/inf -> None."""
    arr = np.asarray(a, dtype=float)
    out = np.where(np.isfinite(arr), np.round(arr, 6), np.nan)
    flat = [None if not math.isfinite(v) else float(f"{v:.{digits}g}") for v in out.ravel()]
    return np.array(flat, dtype=object).reshape(arr.shape).tolist()


def cost_scaling(case: str = "cantilever-tip-load", ns: Sequence[int] = COST_N) -> dict:
    """CPU seconds of a solve vs N for each parametrised family: the cost estimates
    ``flexbench recommend`` ranks by (``reports.verdicts.recommend.measured``, cached)."""
    from reports.verdicts.recommend import measured

    scene = cases.load(case)
    out = {}
    for fam in ("linear", "cbcm", "prb-fsm"):
        ms = []
        for n in ns:
            name = f"{fam}-{n}"
            opts = scene.model_options(name)
            _, est = measured(api.make_model(name, scene, opts), scene, name, opts)
            ms.append(est.cpu_s * 1e3)
        out[fam] = {"N": list(ns), "ms": _r(ms)}
    return {"case": case, "families": out}


def shapes(case: str, models: Sequence[str] = SHAPE_MODELS) -> dict:
    """Deformed shapes of every step of ``case``: model -> [step][point][x, y]."""
    scene = cases.load(case)
    ref = scene.reference_model or "elastica"
    data: dict[str, Any] = {"case": case, "reference": ref, "models": {}}
    for name in (ref, *models):
        sol = api.solve(scene, name)
        if not sol.steps or not sol.steps[-1].shapes:
            continue
        data["models"][name] = [
            _r(np.concatenate(list(s.shapes.values())), 5) if s.shapes else [] for s in sol.steps
        ]
        data.setdefault("factors", _r([s.factor for s in sol.steps]))
    return data


def atlas_png(at: atlas.Atlas, model: str) -> str:
    """A matplotlib map of one model's atlas with the 0.1/1/5 % contours and its claims'
    regions (dashed) and failing points (x), as a base64 PNG data URI."""
    import base64
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    err = np.asarray(at.error[model], dtype=float)
    fig, ax = plt.subplots(figsize=(3.6, 3.0), dpi=90)
    X, Y = np.meshgrid(at.mags, at.angles)
    pcm = ax.pcolormesh(X, Y, np.log10(np.clip(err, 1e-6, None)), vmin=-4, vmax=0, cmap="viridis")
    fig.colorbar(pcm, ax=ax, label="log10 error")
    if np.isfinite(err).sum() > 3 and len(at.angles) > 1:
        cs = ax.contour(X, Y, err, levels=list(atlas.CONTOURS), colors="w", linewidths=0.8)
        ax.clabel(cs, fmt={v: f"{v * 100:g}%" for v in atlas.CONTOURS}, fontsize=6)
    for k, c in enumerate(c for c in atlas.CLAIMS if c.model == model and c.family == at.family):
        region = c.region(at).astype(float)
        if region.any() and len(at.angles) > 1:
            ax.contour(X, Y, region, levels=[0.5], colors=["r", "orange"][k % 2], linestyles="--")
        bad = c.region(at) & ~(getattr(at, c.metric)[model] <= c.accuracy)
        ax.plot(X[bad], Y[bad], "x", color=["r", "orange"][k % 2], ms=3)
    ax.set_xlabel("PL^2/EI" if at.family != "moment" else "ML/EI")
    ax.set_ylabel("load angle (deg)")
    ax.set_title(f"{model}: {at.family}", fontsize=9)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def atlas_data(at: atlas.Atlas) -> dict:
    """Embeddable atlas: grid, each model's error and our tests of the published claims on
    it; the force atlas also carries the claims' own records (``reports.verdicts.claims``: the
    publication's verdict, in its own metric, with our reading of this atlas beside it)."""
    claims = [c for c in atlas.CLAIMS if c.family == at.family]
    out: dict[str, Any] = {"mags": _r(at.mags), "angles": _r(at.angles), "models": {}}
    if at.family == "force":
        out["published"] = published.as_json(published.evaluate_all(at))["claims"]
    for name, err in at.error.items():
        entry: dict[str, Any] = {"error": _r(err, 3), "claims": [], "message": at.message[name]}
        if at.family == "force":
            entry["png"] = atlas_png(at, name)
        for c in (c for c in claims if c.model == name):
            res = atlas.check_claim(c, at)
            metric = getattr(at, c.metric)[name]
            region = c.region(at)
            entry["claims"].append(
                {
                    **{k: v for k, v in res.items() if k != "worst_at"},
                    "region": region.astype(int).tolist(),
                    "fails": (region & ~(metric <= c.accuracy)).astype(int).tolist(),
                }
            )
        out["models"][name] = entry
    return out


def family_cards() -> list[dict]:
    """Per model family: title, its models and their cards (assumptions, validity, refs)."""
    families = []
    for key, (title, names, param) in FAMILIES.items():
        cards = []
        for name in (*names, param):
            card = api.card_of(name)
            if card is not None and all(c["name"] != card.name for c in cards):
                cards.append(
                    {
                        "name": card.name,
                        "summary": card.summary,
                        "assumptions": list(card.assumptions),
                        "validity": card.validity,
                        "references": list(card.references),
                    }
                )
        families.append({"key": key, "title": title, "models": list(names), "cards": cards})
    return families


def build_data(
    cases_for_advice: Sequence[str],
    tolerances: Sequence[str] = ("1%", "0.1%"),
    shape_case: str = "cantilever-tip-load",
    n_mag: int = 40,
    n_ang: int = 41,
    workers: int = 2,
    progress: Callable[[str], None] | None = None,
    cost_ns: Sequence[int] = COST_N,
    mech_cases: Sequence[str] = mech_atlas.TEACH_CASES,
    mech_n_axis: int = 5,
) -> dict:
    """Everything the page shows (cards, atlases, costs, recommendations, shapes)."""
    t0 = time.perf_counter()
    models = tuple(m for _, ms, _ in FAMILIES.values() for m in ms)
    atlases, timing = {}, {}
    for fam in atlas.FAMILIES:
        t = time.perf_counter()
        at = atlas.compute(fam, models, n_mag, n_ang, workers=workers, progress=progress)
        timing[fam] = round(time.perf_counter() - t, 2)
        atlases[fam] = atlas_data(at)
    advice = []
    for case in cases_for_advice:
        for tol in tolerances:
            rec = recommend(case, tol)
            curves = {c.model: _r(c.profile, 3) for c in rec.candidates if c.profile}
            advice.append(
                {
                    "case": case,
                    "tol": tol,
                    "recommended": rec.recommended,
                    "text": format_text(rec),
                    "profiles": curves,
                }
            )
            if progress:
                progress(f"recommend {case} {tol}: {rec.recommended}")
    return {
        "families": family_cards(),
        "atlas": atlases,
        "atlas_seconds": timing,
        "contours": list(atlas.CONTOURS),
        "cost": cost_scaling(ns=cost_ns),
        "advice": advice,
        "shapes": shapes(shape_case),
        "mech_atlas": mech_atlas.teaching_data(mech_cases, mech_n_axis, progress),
        "seconds": round(time.perf_counter() - t0, 1),
    }


def write_page(data: dict, path: str | Path) -> Path:
    """Write the self-contained teaching page for ``data`` (see ``build_data``)."""
    path = Path(path)
    payload = json.dumps(data, allow_nan=False, separators=(",", ":")).replace("</", "<\\/")
    page = _TEMPLATE.replace("__DATA__", payload).replace("__JS__", _JS)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page, encoding="utf-8")
    mech_atlas.save(data.get("mech_atlas"), path.parent)  # the report shows them too
    return path


_TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>FlexBench: which model, and where</title>
<style>
body{font-family:system-ui,sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;color:#222}
h2{border-bottom:1px solid #aaa;margin-top:2em} canvas{border:1px solid #ccc;margin:4px}
.atl{display:inline-block;vertical-align:top;margin:4px;font-size:.8em;max-width:270px}
pre{background:#f6f6f6;padding:.5em;overflow-x:auto;font-size:.78em}
.ctl{position:sticky;top:0;background:#fff;padding:.4em;border-bottom:1px solid #ddd;z-index:2}
.card{font-size:.85em} .ok{color:#070} .bad{color:#b00}
</style></head><body>
<div class="ctl">Tolerance: <input id="tol" type="range" min="-4" max="-1" step="0.05" value="-2">
<b id="tolv"></b> &nbsp; Load factor: <input id="load" type="range" min="0" max="1" step="1"
value="0"> <b id="loadv"></b></div>
<h1>Which model should I use, and where does each stop being good enough?</h1>
<p>Errors are on the report's default yardstick (error_rel): the largest deviation of the
tip from the exact elastica on the ramp to that load, translations divided by the tip's own
largest displacement and the rotation by its own largest rotation, so a model 5 % off in
stiffness reads 5 % at any load. Atlas cells are green
when the error is within the tolerance chosen above (darker = closer to the limit), red when not,
grey where the model declines or fails. Under each atlas: the published claim's own verdict,
judged in the publication's metric, region and parameter values (<code>flexbench claims</code>).
Outlined cells: the region of our test of that claim on this atlas (a stricter metric or a wider
region, labelled "our test": never the publication's failure); black dots: points inside it
where our test's accuracy is not met.</p>
<div id="root"></div>
<h2>Deformed shapes</h2><p id="shapecap"></p><canvas id="shape" width="560" height="420">
</canvas><div id="legend"></div>
<pre id="selftest"></pre>
<script type="application/json" id="data">__DATA__</script>
<script>__JS__</script>
</body></html>
"""

_JS = r"""
"use strict";
const D = JSON.parse(document.getElementById("data").textContent);
const errs = [];
window.addEventListener("error", e => errs.push(String(e.message)));
const COLORS = ["#1f77b4","#ff7f0e","#2ca02c","#d62728","#9467bd","#8c564b","#e377c2",
  "#17becf","#bcbd22","#7f7f7f","#393b79","#e7969c","#637939","#8c6d31","#d6616b","#7b4173"];
const el = (tag, attrs, text) => { const e = document.createElement(tag);
  Object.assign(e, attrs || {}); if (text !== undefined) e.textContent = text; return e; };
const pct = x => (x * 100).toPrecision(3) + " %";
function line(ctx, pts) {
  ctx.beginPath(); pts.forEach((p, j) => j ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1]));
  ctx.stroke();
}
function tol() { return Math.pow(10, +document.getElementById("tol").value); }

function drawAtlas(cv, fam, model) {
  const A = D.atlas[fam], M = A.models[model], ctx = cv.getContext("2d"), t = tol();
  const na = A.angles.length, nm = A.mags.length, w = cv.width / nm, h = cv.height / na;
  ctx.clearRect(0, 0, cv.width, cv.height);
  for (let i = 0; i < na; i++) for (let j = 0; j < nm; j++) {
    const e = M.error[i][j]; let c = "#bbb";
    if (e !== null) c = e <= t ? `hsl(120,60%,${30 + 50 * (1 - Math.min(1, e / t))}%)`
                              : `hsl(0,70%,${Math.max(35, 70 - 10 * Math.log10(e / t))}%)`;
    ctx.fillStyle = c; ctx.fillRect(j * w, (na - 1 - i) * h, w + 0.5, h + 0.5);
  }
  M.claims.forEach((cl, k) => {
    ctx.strokeStyle = k ? "#0050ff" : "#000"; ctx.lineWidth = 1.5;
    for (let i = 0; i < na; i++) for (let j = 0; j < nm; j++) {
      if (!cl.region[i][j]) continue;
      const x = j * w, y = (na - 1 - i) * h, r = cl.region;
      const edge = (a, b) => !(a >= 0 && a < na && b >= 0 && b < nm && r[a][b]);
      ctx.beginPath();
      if (edge(i, j - 1)) { ctx.moveTo(x, y); ctx.lineTo(x, y + h); }
      if (edge(i, j + 1)) { ctx.moveTo(x + w, y); ctx.lineTo(x + w, y + h); }
      if (edge(i + 1, j)) { ctx.moveTo(x, y); ctx.lineTo(x + w, y); }
      if (edge(i - 1, j)) { ctx.moveTo(x, y + h); ctx.lineTo(x + w, y + h); }
      ctx.stroke();
      if (cl.fails[i][j]) { ctx.fillStyle = "#000";
        ctx.fillRect(x + w / 2 - 1, y + h / 2 - 1, 2, 2); }
    }
  });
}

function atlasBlock(fam, model) {
  const A = D.atlas[fam]; if (!A || !A.models[model]) return null;
  const div = el("div", {className: "atl"});
  const cv = el("canvas", {width: 240, height: fam === "moment" ? 24 : 240});
  cv.dataset.fam = fam; cv.dataset.model = model; cv.className = "atlas";
  div.append(el("b", {}, `${model}: ${fam}`), el("br"), cv);
  if (A.models[model].png) div.append(el("br"), el("img", {src: A.models[model].png,
    alt: `${model} atlas with 0.1/1/5 % contours`, width: 260}));
  const ax = fam === "moment" ? "end moment ML/EI 0 to 2 pi (left to right)" :
    `x: load magnitude 0 to 10 (PL^2/EI); y: angle 0 (tension, bottom) to 180 deg (compression)`;
  div.append(el("div", {}, ax));
  (A.published || []).filter(r => r.model === model).forEach(r => div.append(el("div",
    {className: {holds: "ok", fails: "bad"}[r.verdict] || ""},
    `Published claim ${r.id}: ${r.verdict}` + (r.worst === null ? "" :
    ` (worst ${pct(r.worst)} vs claimed ${pct(r.claimed)}, in the publication's own metric)`) +
    `. ${r.claim} Source: ${r.source}. ${r.note}`)));
  A.models[model].claims.forEach(cl => div.append(el("div",
    {className: cl.verdict === "holds" ? "ok" : "bad"},
    `${cl.label}: ${cl.verdict} (worst ${cl.worst === null ? "-" : pct(cl.worst)} vs ` +
    `${pct(cl.accuracy)} on ${cl.metric}; ${cl.failing}/${cl.points} points fail). ` +
    `Reading: ${cl.reading}`)));
  if (A.models[model].message) div.append(el("div", {}, "declines/fails: " +
    A.models[model].message));
  return div;
}

function costChart(fam) {
  const C = D.cost.families[fam]; if (!C) return null;
  const cv = el("canvas", {width: 300, height: 160}), ctx = cv.getContext("2d");
  const lx = C.N.map(Math.log2), ly = C.ms.map(v => Math.log10(v || 1e-3));
  const x0 = Math.min(...lx), x1 = Math.max(...lx), y0 = Math.min(...ly), y1 = Math.max(...ly);
  const X = v => 30 + 260 * (v - x0) / (x1 - x0 || 1);
  const Y = v => 140 - 120 * (v - y0) / (y1 - y0 || 1);
  line(ctx, lx.map((v, k) => [X(v), Y(ly[k])])); ctx.font = "10px sans-serif";
  C.N.forEach((n, k) => ctx.fillText(`N=${n}: ${C.ms[k]} ms`, X(lx[k]) - 20, Y(ly[k]) - 4));
  return cv;
}

function profileChart(a) {
  // error / tolerance of every candidate along the load factor or driver (log scale)
  const names = Object.keys(a.profiles || {}); if (!names.length) return null;
  const div = el("div"), cv = el("canvas", {width: 560, height: 220}), ctx = cv.getContext("2d");
  const all = names.flatMap(n => a.profiles[n]);
  const f0 = Math.min(...all.map(p => p[0])), f1 = Math.max(...all.map(p => p[0]));
  const X = f => 40 + 500 * (f - f0) / (f1 - f0 || 1);
  const Y = r => 200 - 180 * (Math.log10(Math.max(r, 1e-3)) + 3) / 6;  // 1e-3 .. 1e3
  ctx.strokeStyle = "#b00"; line(ctx, [[40, Y(1)], [540, Y(1)]]);
  ctx.font = "10px sans-serif"; ctx.fillText("error = tolerance", 44, Y(1) - 3);
  names.forEach((n, k) => { ctx.strokeStyle = COLORS[k % COLORS.length];
    line(ctx, a.profiles[n].map(p => [X(p[0]), Y(p[1] || 1e-3)])); });
  div.append(el("div", {}, "Error / tolerance along the path (log scale, 1e-3 to 1e3; " +
    "x: load factor or driver coordinate)"), cv);
  names.forEach((n, k) => div.append(el("span",
    {style: `color:${COLORS[k % COLORS.length]};margin-right:.8em`}, n)));
  return div;
}

function perStateTable() {
  // CPU cost of a state inside an atlas batch against one ordinary 20-step solve
  const P = D.per_state; if (!P) return null;
  const t = el("table"), head = el("tr");
  ["family", "model", "atlas CPU s", "per state ms", "single solve ms", "ratio"].forEach(
    h => head.append(el("th", {}, h)));
  t.append(head);
  Object.entries(P).forEach(([fam, ms]) => Object.entries(ms).forEach(([m, v]) => {
    const tr = el("tr"), f = (x, k) => x === null ? "-" : (x * k).toPrecision(3);
    [fam, m, f(v.atlas_cpu_s, 1), f(v.per_state_s, 1e3), f(v.single_s, 1e3),
     v.ratio === null ? "-" : v.ratio.toPrecision(3) + "x"].forEach(
      c => tr.append(el("td", {}, c)));
    t.append(tr);
  }));
  return t;
}

function mechAtlases(root) {
  // mechanism atlases (reports.verdicts.atlas_mech): drawn by drawAtlas, re-coloured by the
  // tolerance
  const MA = Object.values(D.mech_atlas || {}); if (!MA.length) return;
  root.append(el("h2", {}, "Mechanism validity atlases over the driver range"));
  MA.forEach(A => {
    root.append(el("h3", {}, A.case));
    if (A.none) { root.append(el("p", {}, "No atlas: " + A.none)); return; }
    const key = "mech:" + A.case, models = {};
    Object.entries(A.models).forEach(([m, v]) => { models[m] = {error: v.error,
      message: v.message, claims: A.claims.filter(c => c.model === m)}; });
    D.atlas[key] = {angles: A.values, mags: A.drive, models: models};
    root.append(el("p", {}, `x: ${A.drive_label} from ${A.drive[0]} to ` +
      `${A.drive[A.drive.length - 1]}; y: ${A.axis_label} from ${A.values[0]} (bottom) to ` +
      `${A.values[A.values.length - 1]} (why: ${A.axis_why}). ${A.wall_s} s for the atlas.`));
    Object.keys(models).forEach(m => {
      const div = el("div", {className: "atl"});
      const cv = el("canvas", {width: 240, height: 140, className: "matlas"});
      cv.dataset.fam = key; cv.dataset.model = m; div.append(el("b", {}, m), el("br"), cv);
      models[m].claims.forEach(cl => div.append(el("div", {className: cl.verdict === "holds" ?
        "ok" : "bad"}, `${cl.label}: ${cl.verdict} (${cl.failing}/${cl.points} states fail)`)));
      if (models[m].message) div.append(el("div", {}, "declines/fails: " + models[m].message));
      root.append(div);
    });
    root.append(el("img", {src: A.png, alt: `${A.case} atlas, 0.1/1/5 % contours`}));
  });
}

function build() {
  const root = document.getElementById("root");
  if (D.note) root.append(el("p", {id: "note"}, D.note));
  const pst = perStateTable();
  if (pst) root.append(el("h2", {}, "Atlas cost per load state (CPU, this machine)"), pst);
  D.families.forEach(F => {
    root.append(el("h2", {}, F.title));
    F.cards.forEach(c => {
      const d = el("div", {className: "card"});
      d.append(el("h3", {}, `${c.name}: ${c.summary}`),
               el("p", {}, "Validity claimed: " + c.validity));
      const ul = el("ul"); c.assumptions.forEach(a => ul.append(el("li", {}, a)));
      const rl = el("ul"); c.references.forEach(a => rl.append(el("li", {}, a)));
      d.append(el("b", {}, "Assumptions"), ul, el("b", {}, "References"), rl); root.append(d);
    });
    root.append(el("h3", {}, "Validity atlases"));
    ["force", "follower", "moment"].forEach(fam => F.models.forEach(m => {
      const b = atlasBlock(fam, m); if (b) root.append(b); }));
    const fam = {linear: "linear", bcm: "cbcm", prb: "prb-fsm"}[F.key];
    root.append(el("h3", {}, `Cost scaling of ${fam}-N (${D.cost.case}, median CPU ms)`));
    const cc = costChart(fam); if (cc) root.append(cc);
  });
  mechAtlases(root);
  root.append(el("h2", {}, "Which model should I use? (flexbench recommend, per catalog case)"));
  D.advice.forEach(a => {
    const verdict = a.recommended || "no model qualifies";
    root.append(el("h3", {}, `${a.case} at ${a.tol}: ${verdict}`));
    const pc = profileChart(a); if (pc) root.append(pc);
    root.append(el("pre", {}, a.text));
  });
  const load = document.getElementById("load");
  load.max = D.shapes.factors.length - 1; load.value = load.max;
  document.getElementById("shapecap").textContent = `Case ${D.shapes.case}: every model's ` +
    `shape (colours) against the reference ${D.shapes.reference} (thick black).`;
  const lg = document.getElementById("legend");
  Object.keys(D.shapes.models).forEach((m, k) => lg.append(el("span",
    {style: `color:${k ? COLORS[(k - 1) % COLORS.length] : "#000"};margin-right:1em`}, m)));
}

function drawShapes() {
  const S = D.shapes, k = +document.getElementById("load").value;
  const cv = document.getElementById("shape"), ctx = cv.getContext("2d");
  ctx.clearRect(0, 0, cv.width, cv.height);
  const all = Object.values(S.models).flatMap(st => st.flat().length ? st.flat() : []);
  const xs = all.map(p => p[0]), ys = all.map(p => p[1]);
  const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
  const s = 0.9 * Math.min(cv.width / (x1 - x0 || 1), cv.height / (y1 - y0 || 1));
  const X = x => 20 + s * (x - x0), Y = y => cv.height - 20 - s * (y - y0);
  Object.entries(S.models).forEach(([m, st], i) => {
    const pts = st[Math.min(k, st.length - 1)]; if (!pts || !pts.length) return;
    ctx.strokeStyle = i ? COLORS[(i - 1) % COLORS.length] : "#000"; ctx.lineWidth = i ? 1.5 : 4;
    line(ctx, pts.map(p => [X(p[0]), Y(p[1])]));
  });
  document.getElementById("loadv").textContent = "factor " + S.factors[k];
}

function redrawAtlases() {
  document.getElementById("tolv").textContent = pct(tol());
  document.querySelectorAll("canvas.atlas, canvas.matlas").forEach(
    cv => drawAtlas(cv, cv.dataset.fam, cv.dataset.model));
}

function selftest() {
  const out = {errors: errs};
  try {
    const cv = document.querySelector("canvas.atlas"), sh = document.getElementById("shape");
    const a0 = cv.toDataURL(), s0 = sh.toDataURL();
    const t = document.getElementById("tol"), l = document.getElementById("load");
    t.value = -3.5; t.dispatchEvent(new Event("input"));
    l.value = Math.floor(l.max / 2); l.dispatchEvent(new Event("input"));
    out.tolerance_changes_atlas = cv.toDataURL() !== a0;
    out.load_changes_shapes = sh.toDataURL() !== s0;
    out.atlases = document.querySelectorAll("canvas.atlas").length;
    out.mech_atlases = document.querySelectorAll("canvas.matlas").length;
  } catch (e) { errs.push(String(e)); }
  document.getElementById("selftest").textContent = JSON.stringify(out);
}

try {
  build();
  document.getElementById("tol").addEventListener("input", redrawAtlases);
  document.getElementById("load").addEventListener("input", drawShapes);
  redrawAtlases(); drawShapes();
} catch (e) { errs.push(String(e)); }
if (location.hash === "#selftest") selftest();
"""
