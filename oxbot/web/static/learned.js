// The "what I learned" page: fills learned.html from /recording/learned.
"use strict";
(async () => {
  const data = await (await fetch("/recording/learned")).json();
  const $ = (id) => document.getElementById(id);
  const cell = (row, text) => { const td = row.insertCell(); td.textContent = text; return td; };
  $("learned-notice").textContent = data.notice || "Nothing kept yet: tick “Keep this game” on the game page.";
  for (const s of data.sessions) {
    const row = $("sessions").tBodies[0].insertRow();
    row.dataset.session = s.id;
    for (const text of [s.id, new Date(s.started_at * 1000).toLocaleString(), s.mode, s.status,
      s.outcome || "-", s.turns, `${s.answers} (${s.repeated})`, `${s.crops} (${s.labelled})`]) {
      cell(row, text);
    }
  }
  $("model").textContent = data.model ? `now read by ${data.model}` : "";
  for (const c of data.crops) {
    const figure = document.createElement("figure");
    figure.className = "crop";
    Object.assign(figure.dataset, { label: c.label, readThen: c.read_then, readsNow: c.reads_now });
    const img = document.createElement("img");
    img.src = `data:image/png;base64,${c.png}`;
    img.alt = `a ${c.label}`;
    const caption = document.createElement("figcaption");
    const now = document.createElement("div");
    now.className = c.reads_now === c.label ? "right" : "wrong";
    now.textContent = `now: ${c.reads_now}`;
    for (const line of [`a ${c.label}`, `I read: ${c.read_then}`]) {
      const div = document.createElement("div"); div.textContent = line; caption.append(div);
    }
    caption.append(now);
    figure.append(img, caption);
    $("wrong-crops").append(figure);
  }
  if (!data.crops.length) $("wrong-crops").textContent = "None: I read every kept drawing right.";
  if (!data.answers.length) {
    const row = $("asked-again").tBodies[0].insertRow();
    cell(row, "None: I understood every answer I kept the first time.").colSpan = 4;
  }
  for (const a of data.answers) {
    const row = $("asked-again").tBodies[0].insertRow();
    const heard = JSON.parse(a.nbest)[0] || ["", 0];
    cell(row, a.session_id); cell(row, a.after_act);
    cell(row, `“${heard[0]}” (${Number(heard[1]).toFixed(2)})`); cell(row, a.understood || "-");
  }
})();
