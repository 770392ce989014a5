// The live page: every REFRESH_MS the runs being recorded (/live.json) redrawn in place:
// progress, the live diagnosis's findings, latest readings, force against time, and the running segment's loops with the
// damper model's force and the rig's limits. A run that starts, ends or trips reloads the page.
const REFRESH_MS = 500;

function extent(values, pad) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) { if (v === null) continue; if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!isFinite(lo)) return [0, 1];
  if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
  const m = (hi - lo) * pad;
  return [lo - m, hi + m];
}

function ticks(lo, hi) {
  const step = Math.pow(10, Math.floor(Math.log10((hi - lo) / 4)));
  const s = [1, 2, 5, 10].map(k => k * step).find(k => (hi - lo) / k <= 6);
  const out = [];
  for (let v = Math.ceil(lo / s) * s; v <= hi; v += s) out.push(+v.toPrecision(6));
  return out;
}

// series: [{x, y, color, dash, label}]; marks: [{axis: "x"|"y", at, label}] (limits), drawn
// only when within 1.5 times the data's range, else listed as off the scale
function plot(canvas, title, series, xlabel, ylabel, marks) {
  const ctx = canvas.getContext("2d"), W = canvas.width, H = canvas.height, L = 56, R = 10, T = 20, B = 36;
  ctx.clearRect(0, 0, W, H);
  const xs = series.flatMap(s => s.x), ys = series.flatMap(s => s.y);
  let [x0, x1] = extent(xs, 0.02), [y0, y1] = extent(ys, 0.08);
  const shown = [], off = [];
  for (const m of marks) {
    const [a, b] = m.axis === "x" ? [x0, x1] : [y0, y1], span = b - a;
    (m.at > a - 1.5 * span && m.at < b + 1.5 * span ? shown : off).push(m);
  }
  for (const m of shown) {
    if (m.axis === "x") { x0 = Math.min(x0, m.at); x1 = Math.max(x1, m.at); }
    else { y0 = Math.min(y0, m.at); y1 = Math.max(y1, m.at); }
  }
  const px = v => L + (v - x0) / (x1 - x0) * (W - L - R), py = v => H - B - (v - y0) / (y1 - y0) * (H - T - B);
  ctx.font = "11px sans-serif"; ctx.strokeStyle = "#ddd"; ctx.fillStyle = "#333"; ctx.lineWidth = 1;
  ctx.textAlign = "center";
  for (const v of ticks(x0, x1)) {
    ctx.beginPath(); ctx.moveTo(px(v), T); ctx.lineTo(px(v), H - B); ctx.stroke();
    ctx.fillText(String(v), px(v), H - B + 14);
  }
  ctx.fillText(xlabel, L + (W - L - R) / 2, H - 4);
  ctx.save(); ctx.translate(12, T + (H - T - B) / 2); ctx.rotate(-Math.PI / 2); ctx.fillText(ylabel, 0, 0); ctx.restore();
  ctx.textAlign = "right";
  for (const v of ticks(y0, y1)) {
    ctx.beginPath(); ctx.moveTo(L, py(v)); ctx.lineTo(W - R, py(v)); ctx.stroke();
    ctx.fillText(String(v), L - 4, py(v) + 4);
  }
  ctx.textAlign = "left"; ctx.font = "bold 12px sans-serif"; ctx.fillText(title, L, 12); ctx.font = "11px sans-serif";
  for (const s of series) {
    ctx.strokeStyle = s.color; ctx.setLineDash(s.dash || []); ctx.lineWidth = 1.3; ctx.beginPath();
    let pen = false;  // lifted over a sample that is no number (null)
    s.x.forEach((v, i) => {
      if (v === null || s.y[i] === null) { pen = false; return; }
      pen ? ctx.lineTo(px(v), py(s.y[i])) : ctx.moveTo(px(v), py(s.y[i]));
      pen = true;
    });
    ctx.stroke();
  }
  ctx.strokeStyle = "#c00"; ctx.setLineDash([6, 4]);
  for (const m of shown) {
    ctx.beginPath();
    if (m.axis === "x") { ctx.moveTo(px(m.at), T); ctx.lineTo(px(m.at), H - B); }
    else { ctx.moveTo(L, py(m.at)); ctx.lineTo(W - R, py(m.at)); }
    ctx.stroke();
  }
  ctx.setLineDash([]);
  let lx = L + 4;
  for (const s of series.filter(s => s.label)) {
    ctx.fillStyle = s.color; ctx.fillText(s.label, lx, T + 12); lx += ctx.measureText(s.label).width + 14;
  }
  const beyond = [...new Set(off.map(m => m.label))];
  if (beyond.length) { ctx.fillStyle = "#c00"; ctx.fillText("limits beyond: " + beyond.join(", "), lx, T + 12); }
  canvas.dataset.points = String(xs.length);
  canvas.dataset.xmax = String(xs.length ? Math.max(...xs) : 0);
  canvas.dataset.series = series.map(s => s.label || "").join(",");
  canvas.dataset.limits = [...new Set(shown.map(m => m.label))].join(",");
}

function draw(section, r) {
  section.querySelector(".progress-text").textContent = r.progress;
  section.querySelector(".findings").replaceChildren(...(r.findings || []).map(([seg, lines]) => {
    const para = document.createElement("p"), b = document.createElement("b");
    b.textContent = seg;
    para.append(b, ": " + lines.join(" "));
    return para;
  }));
  section.querySelector("tbody").innerHTML = r.readings.map(([n, v, u]) => `<tr><td>${n}</td><td>${v}</td><td>${u}</td></tr>`).join("");
  const p = r.plots;
  if (!p.trace) return;
  const u = p.units, lim = p.limits || null, fl = lim ? `±${lim.force} ${u.force}` : "";
  const fmarks = lim ? [{axis: "y", at: lim.force, label: `force ${fl}`}, {axis: "y", at: -lim.force, label: `force ${fl}`}] : [];
  plot(section.querySelector("canvas.trace"), "Force, the last 10 s", [{x: p.trace.t, y: p.trace.force, color: "#1f77b4", label: "measured"}],
       "run time [s]", `force [${u.force}]`, fmarks);
  if (!p.loop) return;
  const loops = [["canvas.fv", "Force against velocity, this segment", p.loop.v, `velocity [${u.velocity}]`, lim ? [{axis: "x", at: lim.v, label: `velocity ±${lim.v}`}, {axis: "x", at: -lim.v, label: `velocity ±${lim.v}`}] : []],
                 ["canvas.fx", "Force against displacement, this segment", p.loop.x, `displacement [${u.length}]`, lim ? lim.x.map(a => ({axis: "x", at: a, label: `stroke ${lim.x[0]}-${lim.x[1]} ${u.length}`})) : []]];
  for (const [sel, title, x, label, marks] of loops) {
    const series = [{x, y: p.loop.force, color: "#1f77b4", label: "measured"}];
    if (p.loop.model) series.push({x, y: p.loop.model, color: "#000", dash: [4, 3], label: "model"});
    plot(section.querySelector(sel), title, series, label, `force [${u.force}]`, marks.concat(fmarks));
  }
}

async function refresh() {
  try {
    const runs = (await (await fetch("live.json", {cache: "no-store"})).json()).runs;
    const sections = [...document.querySelectorAll("section.live")];
    const same = runs.length === sections.length && runs.every((r, i) => sections[i].dataset.key === r.key &&
                                                                    !!sections[i].querySelector(".trip") === !!r.tripped);
    if (!same) { location.reload(); return; }
    runs.forEach((r, i) => draw(sections[i], r));
  } catch (e) { /* the server restarting or the run ending: the next refresh tells */ }
  setTimeout(refresh, REFRESH_MS);
}
refresh();
