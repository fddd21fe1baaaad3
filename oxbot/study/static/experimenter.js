// The experimenter's page: participants so far, per-condition means with 95% intervals, the
// plots and the CSV; every request carries the token from this page's own URL.
"use strict";
const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.search).get("token") || "";
const withToken = (url) => `${url}?token=${encodeURIComponent(token)}`;
const MEASURES = ["success", "turns", "duration", "time_per_move", "confidence", "asked_again",
  "corrected", "well_formed", "sus", "likeability", "intelligence"];
const PLOTS = ["success", "turns", "sus", "likeability", "intelligence"];

const cell = (text) => { const td = document.createElement("td"); td.textContent = text; return td; };
const num = (x) => (x === null || x === undefined ? "–" : Number(x).toFixed(2));

async function refresh() {
  const r = await fetch(withToken("/study/results"));
  if (!r.ok) { document.body.textContent = "The token is missing or wrong."; return; }
  const data = await r.json();
  $("design").textContent = `${data.design.conditions.length} conditions, ` +
    `${data.design.blocks} per participant, ${data.design.games} game(s) each`;
  $("count").textContent = `(${data.participants.length})`;
  $("participants").replaceChildren(...data.participants.map((p) => {
    const tr = document.createElement("tr");
    tr.append(cell(p.id), cell(p.conditions.join(", ")), cell(p.games), cell(p.answered ? "yes" : "no"));
    return tr;
  }));
  const head = document.createElement("tr");
  head.append(cell("condition"), ...MEASURES.map(cell));
  $("summary-head").replaceChildren(head);
  $("summary").replaceChildren(...Object.entries(data.summary).map(([condition, m]) => {
    const tr = document.createElement("tr");
    tr.append(cell(condition), ...MEASURES.map((k) => cell(m[k].mean === null ? "–"
      : `${num(m[k].mean)} [${num(m[k].low)}, ${num(m[k].high)}] (${m[k].n})`)));
    return tr;
  }));
  const stamp = Date.now();
  $("plots").replaceChildren(...PLOTS.map((name) => {
    const img = document.createElement("img");
    img.alt = `${name} by condition`; img.src = `${withToken(`/study/plot/${name}.png`)}&t=${stamp}`;
    return img;
  }));
}

$("csv").href = withToken("/study/export.csv");
refresh();
setInterval(refresh, 15000);
