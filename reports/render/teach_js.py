"""The teaching page's inline script: draws the atlases (on axes with ticks and a colour bar,
re-coloured by the tolerance slider), the deformed shapes moved by the load slider and the
recommender's error profiles, from the embedded data (``reports.render.teach_html``).

``#selftest`` in the page's URL makes the script move both sliders and write a JSON verdict
(drawings changed, errors caught) into ``<pre id="selftest">`` -- what the browser test reads.
"""

JS = r"""
"use strict";
const D = JSON.parse(document.getElementById("data").textContent);
const errs = [];
window.addEventListener("error", e => errs.push(String(e.message)));
const COL = D.colours || {};
const colour = (m, k) => COL[m] || ["#1f77b4","#ff7f0e","#2ca02c","#d62728","#9467bd"][k % 5];
const el = (tag, attrs, text) => { const e = document.createElement(tag);
  Object.assign(e, attrs || {}); if (text !== undefined) e.textContent = text; return e; };
const pct = x => (x * 100).toPrecision(3) + " %";
function line(ctx, pts) {
  ctx.beginPath(); pts.forEach((p, j) => j ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1]));
  ctx.stroke();
}
function tol() { return Math.pow(10, +document.getElementById("tol").value); }
function niceTicks(a, b, n) {
  if (a > b) [a, b] = [b, a];  // a driver may run downwards (0 to -120 deg)
  const span = b - a || 1, raw = span / n, p = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 2.5, 5, 10].map(m => m * p).find(s => s >= raw);
  const out = []; for (let v = Math.ceil(a / step) * step; v <= b + 1e-9 * span; v += step)
    out.push(+v.toPrecision(6));
  return out;
}
function cellColour(e, t) {
  if (e === null) return "#bbb";
  return e <= t ? `hsl(120,60%,${30 + 50 * (1 - Math.min(1, e / t))}%)`
                : `hsl(0,70%,${Math.max(35, 70 - 10 * Math.log10(e / t))}%)`;
}
const AX = {l: 42, r: 62, t: 6, b: 32};  // plot margins: ticks left and below, colour bar right

function axisLabels(fam) {
  if (fam.startsWith("mech:")) { const A = D.atlas[fam]; return [A.xlabel, A.ylabel]; }
  return fam === "moment" ? ["end moment ML/EI", ""] : ["load PL²/EI", "angle [deg]"];
}

function drawAtlas(cv, fam, model) {
  const A = D.atlas[fam], M = A.models[model], ctx = cv.getContext("2d"), t = tol();
  const na = A.angles.length, nm = A.mags.length;
  const W = cv.width - AX.l - AX.r, H = cv.height - AX.t - AX.b;
  const x0 = A.mags[0], x1 = A.mags[nm - 1], y0 = A.angles[0], y1 = A.angles[na - 1];
  // cell edges halfway between the sampled values
  const dx = nm > 1 ? (x1 - x0) / (nm - 1) : 1, dy = na > 1 ? (y1 - y0) / (na - 1) : 1;
  const X = v => AX.l + W * (v - (x0 - dx / 2)) / (x1 - x0 + dx);
  const Y = v => AX.t + H - H * (v - (y0 - dy / 2)) / (y1 - y0 + dy);
  const w = W / nm, h = H / na;
  ctx.clearRect(0, 0, cv.width, cv.height);
  for (let i = 0; i < na; i++) for (let j = 0; j < nm; j++) {
    ctx.fillStyle = cellColour(M.error[i][j], t);
    ctx.fillRect(AX.l + j * w, AX.t + (na - 1 - i) * h, w + 0.5, h + 0.5);
  }
  (M.claims || []).forEach((cl, k) => {
    ctx.strokeStyle = k ? "#0050ff" : "#000"; ctx.lineWidth = 1.5;
    for (let i = 0; i < na; i++) for (let j = 0; j < nm; j++) {
      if (!cl.region[i][j]) continue;
      const x = AX.l + j * w, y = AX.t + (na - 1 - i) * h, r = cl.region;
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
  // axes: frame, ticks, labels
  ctx.strokeStyle = "#333"; ctx.lineWidth = 1; ctx.strokeRect(AX.l, AX.t, W, H);
  ctx.fillStyle = "#222"; ctx.font = "10px sans-serif"; ctx.textAlign = "center";
  niceTicks(x0, x1, 5).forEach(v => { const x = X(v);
    line(ctx, [[x, AX.t + H], [x, AX.t + H + 3]]); ctx.fillText(String(v), x, AX.t + H + 13); });
  const [xl, yl] = axisLabels(fam);
  ctx.fillText(xl, AX.l + W / 2, cv.height - 3);
  if (na > 1) {
    ctx.textAlign = "right";
    niceTicks(y0, y1, 4).forEach(v => { const y = Y(v);
      line(ctx, [[AX.l - 3, y], [AX.l, y]]); ctx.fillText(String(v), AX.l - 5, y + 3); });
    ctx.save(); ctx.translate(10, AX.t + H / 2); ctx.rotate(-Math.PI / 2);
    ctx.textAlign = "center"; ctx.fillText(yl, 0, 0); ctx.restore();
  }
  // colour bar: error from tol/100 (bottom) to 100 tol (top) at the current tolerance
  const bx = AX.l + W + 8, bw = 10;
  for (let k = 0; k < H; k++) {
    const e = t * Math.pow(10, -2 + 4 * (1 - k / H));
    ctx.fillStyle = cellColour(e, t); ctx.fillRect(bx, AX.t + k, bw, 1.5);
  }
  ctx.strokeStyle = "#333"; ctx.strokeRect(bx, AX.t, bw, H);
  ctx.fillStyle = "#222"; ctx.textAlign = "left"; ctx.font = "9px sans-serif";
  const steps = H > 100 ? [-2, -1, 0, 1, 2] : [-2, 0, 2];
  steps.forEach(d => { const y = AX.t + H * (1 - (d + 2) / 4);
    ctx.fillText(pct(t * Math.pow(10, d)).replace(" ", ""), bx + bw + 2, y + 3); });
}

function mechSetup() {
  Object.values(D.mech_atlas || {}).forEach(A => {
    if (A.none) return;
    const models = {};
    Object.entries(A.models).forEach(([m, v]) => { models[m] = {error: v.error,
      message: v.message, claims: A.claims.filter(c => c.model === m)}; });
    D.atlas["mech:" + A.case] = {angles: A.values, mags: A.drive, models: models,
      xlabel: A.drive_label, ylabel: A.axis_label};
  });
}

function profileChart(cv) {
  // error / tolerance of every candidate along the load factor or driver (log scale)
  const a = D.advice.find(a => a.case === cv.dataset.case && a.tol === cv.dataset.tol);
  const names = Object.keys(a.profiles || {}), ctx = cv.getContext("2d");
  const all = names.flatMap(n => a.profiles[n]);
  const f0 = Math.min(...all.map(p => p[0])), f1 = Math.max(...all.map(p => p[0]));
  const L = 70, R = 130, T = 8, B = 32, W = cv.width - L - R, H = cv.height - T - B;
  const X = f => L + W * (f - f0) / (f1 - f0 || 1);
  const Y = r => T + H - H * (Math.log10(Math.max(r, 1e-3)) + 3) / 6;  // 1e-3 .. 1e3
  ctx.strokeStyle = "#333"; ctx.strokeRect(L, T, W, H);
  ctx.font = "10px sans-serif"; ctx.fillStyle = "#222"; ctx.textAlign = "right";
  [-3, -2, -1, 0, 1, 2, 3].forEach(d => { const y = Y(Math.pow(10, d));
    line(ctx, [[L - 3, y], [L, y]]);
    ctx.fillText(d ? `1e${d} x tol` : "tol", L - 5, y + 3); });
  ctx.textAlign = "center";
  niceTicks(f0, f1, 6).forEach(v => { const x = X(v); line(ctx, [[x, T + H], [x, T + H + 3]]);
    ctx.fillText(String(v), x, T + H + 13); });
  ctx.fillText("load factor (or driver coordinate)", L + W / 2, cv.height - 3);
  ctx.save(); ctx.translate(10, T + H / 2); ctx.rotate(-Math.PI / 2);
  ctx.fillText("error / tolerance", 0, 0); ctx.restore();
  ctx.strokeStyle = "#b00"; ctx.setLineDash([4, 3]); line(ctx, [[L, Y(1)], [L + W, Y(1)]]);
  ctx.setLineDash([]);
  ctx.textAlign = "left";
  names.forEach((n, k) => { ctx.strokeStyle = colour(n, k); ctx.lineWidth = 1.5;
    line(ctx, a.profiles[n].map(p => [X(p[0]), Y(p[1] || 1e-3)]));
    ctx.fillStyle = colour(n, k); ctx.fillText(n, L + W + 8, T + 10 + 12 * k); });
  ctx.lineWidth = 1;
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
    ctx.strokeStyle = i ? colour(m, i) : "#000"; ctx.lineWidth = i ? 1.5 : 4;
    line(ctx, pts.map(p => [X(p[0]), Y(p[1])]));
  });
  document.getElementById("loadv").textContent = "factor " + S.factors[k];
}

function redrawAtlases() {
  document.getElementById("tolv").textContent = pct(tol());
  document.querySelectorAll("canvas.atlas, canvas.matlas").forEach(
    cv => drawAtlas(cv, cv.dataset.fam, cv.dataset.model));
}

function openTarget() {
  // a link to a folded case opens it
  const t = location.hash && document.getElementById(location.hash.slice(1));
  if (t && t.tagName === "DETAILS") t.open = true;
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
  mechSetup();
  const load = document.getElementById("load");
  load.max = D.shapes.factors.length - 1; load.value = load.max;
  const lg = document.getElementById("legend");
  Object.keys(D.shapes.models).forEach((m, k) => lg.append(el("span",
    {style: `color:${k ? colour(m, k) : "#000"};margin-right:1em;white-space:nowrap`},
    k ? m : m + " (reference)")));
  document.querySelectorAll("canvas.profile").forEach(profileChart);
  document.getElementById("tol").addEventListener("input", redrawAtlases);
  load.addEventListener("input", drawShapes);
  window.addEventListener("hashchange", openTarget);
  redrawAtlases(); drawShapes(); openTarget();
} catch (e) { errs.push(String(e)); }
if (location.hash === "#selftest") selftest();
"""
