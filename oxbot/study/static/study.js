// The participant's page (oxbot study): consent, the questions about them, each condition's
// games in a frame (the game page, /study/game) and the questionnaires after each condition.
// Every answer is sent as soon as it is picked: the server keeps each in its own transaction.
// Where the participant is (their code, conditions, step) lives in sessionStorage, so that a
// reloaded page carries on where it was.
"use strict";

const $ = (id) => document.getElementById(id);
const POLL_MS = 1500, NEXT_GAME_MS = 2500;
let setup = null;
let me = JSON.parse(sessionStorage.getItem("oxbot-study") || "null");
// me: {participant, conditions, step}; steps: "pre", then for each block b: "play:b", "ask:b"

function save() { sessionStorage.setItem("oxbot-study", JSON.stringify(me)); }

function show(id) {
  for (const s of ["consent", "declined", "questions", "games", "done"]) $(s).hidden = s !== id;
}

async function post(url, body) {
  const r = await fetch(url, { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(body) });
  const data = await r.json();
  if (!r.ok) throw new Error(data.error || r.statusText);
  return data;
}

function consentPage() {
  $("consent-text").replaceChildren(...setup.consent.split(/\n\s*\n/).map((text) => {
    const p = document.createElement("p"); p.textContent = text; return p;
  }));
  show("consent");
}

$("consent-no").addEventListener("click", async () => {
  await post("/study/consent", { consent: false });
  show("declined");
});

$("consent-yes").addEventListener("click", async () => {
  $("consent-yes").disabled = true;
  const r = await post("/study/consent",
    { consent: true, recordings: $("consent-recordings").checked });
  me = { participant: r.participant, conditions: r.conditions, step: "pre" };
  save(); go();
});

// --- questionnaires ------------------------------------------------------------------------

function itemField(instrument, block, item, answered) {
  const field = document.createElement("fieldset");
  field.dataset.item = item.key;
  const legend = document.createElement("legend");
  // a statement (SUS, the questions about you) is its legend; a differential is its two ends
  legend.textContent = !item.low || instrument.name === "sus" ? item.text : "";
  field.append(legend);
  const row = document.createElement("div");
  row.className = item.low ? "scale" : "choices";
  const end = (text, cls) => {
    const span = document.createElement("span"); span.className = `end ${cls}`;
    span.textContent = text; return span;
  };
  if (item.low) row.append(end(item.low, "low"));
  for (const value of item.values) {
    const label = document.createElement("label");
    const input = document.createElement("input");
    input.type = "radio"; input.name = `${instrument.name}-${item.key}`; input.value = value;
    input.dataset.testid = `${instrument.name}-${item.key}-${value}`;
    input.addEventListener("change", async () => {
      try {
        await post("/study/answer", { participant: me.participant, instrument: instrument.name,
          block, item: item.key, value });
        answered.add(`${instrument.name}/${item.key}`);
        field.classList.add("answered");
      } catch (err) { alert(`That answer was not kept: ${err.message}`); input.checked = false; }
      answered.check();
    });
    label.append(input, document.createTextNode(value));
    row.append(label);
  }
  if (item.low) row.append(end(item.high, "high"));
  field.append(row);
  return field;
}

function askPage(instruments, block, title, then) {
  const answered = new Set();
  const total = instruments.reduce((n, i) => n + i.items.length, 0);
  answered.check = () => { $("questions-next").disabled = answered.size < total; };
  const form = $("questions-form");
  form.replaceChildren();
  for (const instrument of instruments) {
    const h = document.createElement("h3"); h.textContent = instrument.title;
    const p = document.createElement("p"); p.className = "hint"; p.textContent = instrument.instructions;
    form.append(h, p);
    for (const item of instrument.items) form.append(itemField(instrument, block, item, answered));
  }
  $("questions-title").textContent = title;
  $("questions-hint").textContent = "Your answers are kept as you pick them.";
  answered.check();
  $("questions-next").onclick = (e) => { e.preventDefault(); then(); };
  show("questions");
  window.scrollTo(0, 0);
}

// --- the games ------------------------------------------------------------------------------

function howToAnswer(condition) {
  const start = condition.starter === "robot" ? "The robot draws first." : "You draw first.";
  const input = condition.input === "voice"
    ? "Answer the robot by speaking: hold “Hold to talk” while you speak, or turn “Hands-free” on."
    : "Answer the robot by typing in the box and pressing Enter.";
  return `Press Start to meet the robot. ${input} Draw your moves on the sheet. ${start}`;
}

function playPage(block) {
  const condition = me.conditions[block - 1];
  let poll = null;
  const load = (done) => {
    $("games-title").textContent =
      `Part ${block} of ${me.conditions.length}: game ${done + 1} of ${setup.games}`;
    $("games-hint").textContent = howToAnswer(condition);
    const q = new URLSearchParams({ participant: me.participant, block, input: condition.input });
    $("game").src = `/study/game?${q}`;
  };
  let seen = null;
  const check = async () => {
    const r = await fetch(`/study/progress/${me.participant}`);
    if (!r.ok) return;
    const done = (await r.json()).games[block] || 0;
    if (seen === null) { seen = done; if (done < setup.games) load(done); }
    if (done === seen) return;
    seen = done;
    if (done >= setup.games) {
      clearInterval(poll);
      setTimeout(() => { $("game").src = "about:blank"; me.step = `ask:${block}`; save(); go(); },
        NEXT_GAME_MS);
    } else {
      setTimeout(() => load(done), NEXT_GAME_MS);
    }
  };
  show("games");
  check().then(() => { if (seen >= setup.games) { me.step = `ask:${block}`; save(); go(); } });
  poll = setInterval(check, POLL_MS);
}

// --- the steps ------------------------------------------------------------------------------

function go() {
  $("code").textContent = me ? `your code: ${me.participant}` : "";
  if (!me) { consentPage(); return; }
  const [step, b] = me.step.split(":");
  const block = Number(b);
  if (step === "pre") {
    askPage([setup.pre], 0, "A few questions about you", () => { me.step = "play:1"; save(); go(); });
  } else if (step === "play") {
    playPage(block);
  } else if (step === "ask") {
    askPage(setup.after, block, `About the robot you just played with (part ${block})`, () => {
      me.step = block < me.conditions.length ? `play:${block + 1}` : "done"; save(); go();
    });
  } else {
    $("done-code").textContent = me.participant;
    show("done");
  }
}

fetch("/study/setup").then((r) => r.json()).then((s) => { setup = s; go(); });
