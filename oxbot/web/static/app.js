// oxbot's page: the game sheet, the robot's face, the conversation and what the robot sees.
// Plain JS, no build step. One WebSocket per tab (/ws); the server runs a robot for it and
// sends every message of the robot's bus; see oxbot/web/session.py for the protocol.
"use strict";

const $ = (id) => document.getElementById(id);
const SIDE = 360, MARGIN = 30;          // oxbot/testing/sheet.py draws the same sheet
let SIZE = 3;                           // cells a side until the server's Hello says (game.SIZE)
const INK = "#1e223c", ROBOT_INK = "#8b1e3f";
const GRID_WIDTH = 4, PEN_WIDTH = 5;
const FRAME_PERIOD_MS = 100;            // paper §2.1: the board is read every 100 ms

const state = {
  ws: null, hello: null, ended: false, speaking: false,
  grid: [],              // the grid's strokes (canvas pixels)
  committed: [],         // the person's strokes that became moves
  pending: [],           // the person's strokes since the last accepted move
  drawing: null,         // the stroke under the pen (never sent: a move waits for the pen to lift)
  robotCells: new Set(), // cells the robot's arm drew in (on the overlay, not in the image)
  dirty: false,          // the sheet changed since the last frame sent
  sound: true, camera: null, cameraTimer: null,
  audio: null, analyser: null, gain: null, source: null, mouthUntil: 0,
  stats: { framesSent: 0, lastStrokeEnd: 0, moves: [], mouthMoves: 0, pointers: {}, cancels: 0,
           acts: [], speaking: [], cuts: [] },
  board: [],             // the board as the robot's manager last announced it (GameState)
  robotStrokes: {},      // cell -> the arm's strokes there (unit square), for paper's overlay
  paperDrawn: new Set(), // cells whose paper move is drawn on the canvas's overlay
  background: null,      // the sheet as the robot last saw it, after a reload (an Image)
  replay: null,          // while a Resumed message's replay runs: what it brought back
  notice: "",            // what the status says once connected, instead of "connected"
};
window.oxbot = state;     // for tests and the curious: the page's state

// --- the sheet ---------------------------------------------------------------------------

const board = $("board"), bctx = board.getContext("2d");
const overlay = $("robot-ink"), octx = overlay.getContext("2d");

function gridLines() {
  const step = (SIDE - 2 * MARGIN) / SIZE;
  return Array.from({ length: SIZE + 1 }, (_, i) => MARGIN + i * step);
}

function wobbly(x0, y0, x1, y1) {
  // a hand-drawn straight line: a gentle bow and a little tremor (as sheet.py's _wobbly)
  const n = 40, dx = x1 - x0, dy = y1 - y0, len = Math.hypot(dx, dy);
  const nx = -dy / len, ny = dx / len, bow = (Math.random() * 2 - 1) * 3;
  let walk = 0; const tremor = [];
  for (let i = 0; i < n; i++) { walk += (Math.random() * 2 - 1) * 0.4; tremor.push(walk); }
  const pts = [];
  for (let i = 0; i < n; i++) {
    const t = i / (n - 1), off = bow * Math.sin(Math.PI * t) + tremor[i] - t * tremor[n - 1];
    pts.push([x0 + t * dx + off * nx, y0 + t * dy + off * ny]);
  }
  return pts;
}

function newGrid() {
  const L = gridLines(), r = (a, b) => a + Math.random() * (b - a), strokes = [];
  for (let i = 1; i < SIZE; i++) {
    for (const vertical of [true, false]) {
      const pos = L[i] + r(-3, 3), a = L[0] - r(-4, 10), b = L[SIZE] + r(-4, 10), tilt = r(-4, 4);
      strokes.push(vertical ? wobbly(pos, a, pos + tilt, b) : wobbly(a, pos, b, pos + tilt));
    }
  }
  return strokes;
}

function strokePath(ctx, pts, width, color) {
  if (pts.length === 0) return;
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.lineCap = "round"; ctx.lineJoin = "round";
  ctx.beginPath(); ctx.moveTo(pts[0][0], pts[0][1]);
  if (pts.length === 1) ctx.lineTo(pts[0][0] + 0.1, pts[0][1] + 0.1);
  for (const [x, y] of pts.slice(1)) ctx.lineTo(x, y);
  ctx.stroke();
}

function redrawSheet() {
  bctx.fillStyle = "#faf8f0"; bctx.fillRect(0, 0, SIDE, SIDE);
  if (state.background && state.background.complete) bctx.drawImage(state.background, 0, 0, SIDE, SIDE);
  for (const s of state.grid) strokePath(bctx, s, GRID_WIDTH, INK);
  for (const s of [...state.committed, ...state.pending]) strokePath(bctx, s, PEN_WIDTH, INK);
  if (state.drawing) strokePath(bctx, state.drawing, PEN_WIDTH, INK);
}

function sheetImage() { return board.toDataURL("image/png"); }

function canvasPoint(e) {
  const r = board.getBoundingClientRect();
  return [(e.clientX - r.left) * SIDE / r.width, (e.clientY - r.top) * SIDE / r.height];
}

board.addEventListener("pointerdown", (e) => {
  if (!state.ws || e.button > 0) return;
  board.setPointerCapture(e.pointerId);
  state.stats.pointers[e.pointerType] = (state.stats.pointers[e.pointerType] || 0) + 1;
  state.drawing = [canvasPoint(e)];
  redrawSheet(); state.dirty = true;
});
board.addEventListener("pointermove", (e) => {
  if (!state.drawing) return;
  const events = e.getCoalescedEvents ? e.getCoalescedEvents() : [e];
  for (const ev of events.length ? events : [e]) state.drawing.push(canvasPoint(ev));
  redrawSheet(); state.dirty = true;
});
function endStroke() {
  if (!state.drawing) return;
  state.pending.push(state.drawing);
  state.drawing = null;
  redrawSheet();
  state.stats.lastStrokeEnd = performance.now();
  sendFrame();          // the finished stroke goes out at once, not at the next tick
}
board.addEventListener("pointerup", endStroke);
board.addEventListener("pointercancel", () => { state.stats.cancels++; endStroke(); });

function sendFrame() {
  if (state.ended) return;   // after the goodbye the robot no longer watches the sheet
  if (paper.on) return;      // the camera shows the robot the sheet, not the canvas
  // a symbol is whole only once the pen lifts: the sheet goes out then (endStroke)
  if (state.drawing) { state.dirty = true; return; }
  // a sheet brought back by a reload is drawn once decoded: never send the sheet without it
  if (state.background && !state.background.complete) { state.dirty = true; return; }
  if (!send({ type: "frame", image: sheetImage() })) return;
  state.dirty = false; state.stats.framesSent++;
}
setInterval(() => { if (state.dirty && !state.ended) sendFrame(); }, FRAME_PERIOD_MS);

$("undo").addEventListener("click", () => {
  if (!state.pending.length) return;
  state.pending.pop(); redrawSheet(); sendFrame();
});

// the robot's ink: drawn on an overlay, stroke by stroke, as the simulated arm draws it
function cellBox(where) {
  const i = state.hello ? state.hello.cells.indexOf(where) : -1, L = gridLines();
  if (i < 0) return null;
  const row = Math.floor(i / SIZE), col = i % SIZE;
  return [L[col], L[row], L[col + 1], L[row + 1]];
}

// A move said or typed instead of drawn: the person's symbol goes on the sheet for them, as
// strokes of their ink, so the sheet (and what the robot's eyes see of it) shows the game.
function inkForMoveInWords(where) {
  const box = cellBox(where);
  if (!box || !state.hello) return;
  const [l, t, r, b] = box, cx = (l + r) / 2, cy = (t + b) / 2, h = 0.3 * Math.min(r - l, b - t);
  const strokes = state.hello.user_symbol === "cross"
    ? [[[cx - h, cy - h], [cx + h, cy + h]], [[cx + h, cy - h], [cx - h, cy + h]]]
    : [Array.from({ length: 33 }, (_, k) => [cx + h * Math.cos(k * Math.PI / 16),
                                              cy + h * Math.sin(k * Math.PI / 16)])];
  state.pending.push(...strokes);
  redrawSheet(); state.dirty = true;
}

function drawArmStroke(where, points) {
  const box = cellBox(where);
  if (!box) return;
  const [l, t, r, b] = box;
  const pts = points.map(([u, v]) => [l + u * (r - l), t + v * (b - t)]);
  const speed = state.hello ? state.hello.speed_factor : 1;
  const ms = Math.max(30, 250 / speed), start = performance.now();
  const step = (now) => {
    const k = Math.min(1, (now - start) / ms), n = Math.max(2, Math.ceil(k * pts.length));
    strokePath(octx, pts.slice(0, n), PEN_WIDTH, ROBOT_INK);
    if (k < 1) requestAnimationFrame(step);
  };
  requestAnimationFrame(step);
}

// --- the connection -----------------------------------------------------------------------

function send(message) {
  if (!state.ws || state.ws.readyState !== WebSocket.OPEN) return false;
  state.ws.send(JSON.stringify(message));
  return true;
}

function connect(resumeToken) {
  let query = window.recordingQuery ? window.recordingQuery() : "";   // record.js's toggle
  if (resumeToken) query += `${query ? "&" : "?"}resume=${encodeURIComponent(resumeToken)}`;
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}${window.socketPath || "/ws"}${query}`);
  state.ws = ws;
  setStatus("Connecting…");
  ws.onopen = () => { setStatus("Connected."); };
  ws.onmessage = (e) => { try { onMessage(JSON.parse(e.data)); } catch (err) { console.error(err); } };
  ws.onclose = (e) => {
    state.stats.closed = [e.code, e.reason];
    if (state.ws === ws) {
      state.ws = null; gameUnderWay(false);
      setStatus(e.code === TAKEN_OVER ? `Disconnected: ${e.reason}. Press Start to play a new game here.`
        : "Disconnected. Press Start to play again.");
      $("start").textContent = "Start"; enableAnswers(false);
    }
  };
}

function startOrNewGame() {
  ensureAudio();
  if (!state.ws) { resetSheet(); connect(); return; }
  resetSheet();
  send(paper.on ? { type: "new_game" } : { type: "new_game", image: sheetImage() });
  addNote("New game ——————————");
}

function resetSheet() {
  state.grid = newGrid(); state.committed = []; state.pending = []; state.drawing = null;
  state.background = null;
  state.robotCells = new Set(); state.lastSeen = null; showCells(null);
  state.robotStrokes = {}; state.board = []; state.paperDrawn = new Set(); paper.moves.clear();
  drawPaperOverlay(); $("paper-hint").hidden = true;
  state.ended = false; octx.clearRect(0, 0, SIDE, SIDE); redrawSheet();
  showProblem(""); $("turn").textContent = ""; enableAnswers(!!state.hello);
}

$("start").addEventListener("click", startOrNewGame);

// --- what the server says -------------------------------------------------------------------

const handlers = {
  Hello(d) {
    state.hello = d; gameUnderWay(true);
    if (d.size !== SIZE) { SIZE = d.size; state.grid = newGrid(); redrawSheet(); }
    $("start").textContent = "New game";
    $("symbol-hint").textContent = `You draw ${d.user_symbol === "cross" ? "crosses (X)" : "circles (O)"}; `
      + `the robot draws ${d.robot_symbol === "cross" ? "crosses" : "circles"}.`;
    enableAnswers(true); buildDecisionTable(d.acts);
    // a game brought back after a reload: its sheet comes in Resumed, and a blank one sent now
    // would wipe the robot's view of it
    if (!d.resumed) sendFrame();
    if (paper.on) send({ type: "paper", on: true });
    showFingerprint(d.tls_fingerprint);
    setStatus(state.notice || `Game ${d.session}: connected.`); state.notice = "";
  },
  // After a reload: the game as it was. The sheet the robot last saw is drawn under the pen's
  // strokes (its grid and the person's ink), then the game so far is replayed through the
  // handlers (the log, the robot's ink, the board, the turn), and live messages go on from there.
  Resumed(d) {
    resetSheet();
    const sheet = typeof d.sheet === "string" && d.sheet.startsWith("data:image/") ? d.sheet : "";
    if (sheet) {
      state.grid = [];   // the grid is in the picture
      const img = new Image();
      img.onload = () => { if (state.background === img) redrawSheet(); };
      state.background = img; img.src = sheet;
    }
    state.replay = { sheet: !!sheet, paper: !!d.paper };
    try { for (const m of d.messages || []) onMessage(m); } finally { state.replay = null; }
    $("bubble").textContent = d.said || "";
    if (window.showRecording) window.showRecording(!!d.recording);
    addNote("The page was reloaded: the game goes on where it was.");
    if (d.paper) {
      // the camera went with the old page: the game goes on on the canvas, the person's moves
      // on paper shown on it (as "Back to the canvas" does)
      send({ type: "paper", on: false }); drawPaperMoves(); state.dirty = true;
      addNote("The game was on paper: press Play on paper to show the camera the sheet again.");
    }
    if (handsFreeWasOn()) addNote("Hands-free is off after the reload: press Hands-free to listen again.");
    setStatus(`Game ${state.hello.session}: back after the reload.`);
  },
  DialogueAct(d) {
    addLog(d.speaker, d.act, d.text);
    state.stats.acts.push({ speaker: d.speaker, act: d.act, at: performance.now() });
    const acts = state.hello ? state.hello.act_names : {};
    if (d.speaker === "sys" && d.act === acts.move_request) {
      $("turn").textContent = `Your turn: draw a ${state.hello.user_symbol}.`;
    } else if (d.speaker === "sys" && state.hello && state.hello.game_moves.includes(d.act)) {
      $("turn").textContent = paper.on ? "" : "The robot is drawing…";
      if (paper.on) showPaperHint(d.act);
    } else if (d.speaker === "sys" && d.act !== acts.problem) {
      $("turn").textContent = "";
    }
    // the robot has moved on: what it said of the sheet is past (the log keeps it), and a
    // camera's guidance is shown again while it lasts
    if (d.act !== acts.problem && !paper.guiding) showProblem("");
    // the box shows what the robot said of the sheet; the tracker's reason stays in the log
    if (d.speaker === "sys" && d.act === acts.problem) showProblem(d.text);
  },
  SpeakingStarted(d) {
    state.stats.speaking.push(performance.now());
    $("bubble").textContent = d.text; speak(d, true);
  },
  SpeakingContinued(d) { speak(d, false); },
  SpeakingFinished() { state.speaking = false; },
  // The person talked over the robot (barge-in): what still plays of that utterance stops now.
  StopSpeaking(d) {
    if (d.text !== state.playingText) return;
    state.cutText = d.text;   // a sentence of it still being decoded is not played either
    for (const src of state.sources || []) { try { src.stop(); } catch (_) { /* ended */ } }
    state.sources = []; state.sentences = []; state.source = null; state.mouthUntil = 0;
    state.speechChain = Promise.resolve(); state.stats.cuts.push(performance.now());
  },
  // Another game, from the button or asked for in words ("one more game"): a clean sheet on
  // the page too (paper is the person's to change), listening again, and the robot shown it.
  NewGame() {
    if (!paper.on) resetSheet(); else state.ended = false;
    gameUnderWay(true); sendFrame();
  },
  ArmStroke(d) {
    drawArmStroke(d.where, d.points);
    (state.robotStrokes[d.where] = state.robotStrokes[d.where] || []).push(d.points);
    drawPaperOverlay();
    if (!state.robotCells.has(d.where)) {
      state.robotCells.add(d.where);
      if (state.lastSeen) showSeen(state.lastSeen);
    }
  },
  ArmDone() {},
  BoardSeen(d) { showSeen(d); if (paper.on) seenOnPaper(d); },
  GameState(d) { state.board = d.board || []; },
  BoardProblem(d) {
    showProblem(d.reason); addNote(d.reason);
    if (GUIDANCE_KINDS.includes(d.kind)) { paper.guiding = true; return; }  // nothing to wipe
    // paper does not forget, but a page can: wipe the impossible ink (the strokes not yet
    // accepted, and the one under the pen) after a moment, so play can go on
    const wiped = new Set([...state.pending, state.drawing].filter(Boolean));
    setTimeout(() => {
      const kept = state.pending.filter((stroke) => !wiped.has(stroke));
      if (kept.length === state.pending.length) return;
      state.pending = kept; redrawSheet(); sendFrame();
    }, 1200);
  },
  GameMove(d) {
    state.stats.moves.push({ ...d, at: performance.now() });
    if (d.who === "usr") {
      const replay = state.replay;   // after a reload: the move is in the sheet brought back
      if (paper.on || (replay && replay.paper)) paper.moves.add(d.where);   // drawn on paper
      else if (!(replay && replay.sheet) && !state.pending.length) inkForMoveInWords(d.where);
      state.committed.push(...state.pending); state.pending = [];
      showProblem(""); $("turn").textContent = "";
    }
  },
  Decision(d) { showDecision(d); },
  SpeechHypotheses(d) { if (d.source === "microphone") showHeard(d.nbest || []); },
  HeadMove(d) { lookTowards(d.direction); },
  DialogueEnded(d) {
    state.ended = true;   // drawings stop; words still go: "new game", "again!" start another
    gameUnderWay(false);
    const text = {
      win: "The robot won.", loss: "You won!", draw: "A draw.",
      declined: "No game, as you wished.", stopped: "Stopped, as you asked.",
    }[d.outcome] || "The game ended.";
    $("turn").textContent = `${text} Press New game to play again.`;
    addNote(`Game over: ${d.outcome || "unfinished"}.`);
  },
  ComponentFailed(d) { addNote(`${d.component} failed: ${d.error}`); },
  ComponentLost(d) { addNote(`${d.component} is off until a new game: ${d.error}`); },
  Status(d) { setStatus(d.message); },
  Error(d) {
    // the server's words are for programs; a person is told what to do
    const forPerson = { game_over: "The game is over. Press New game to play again." };
    if (d.code === "resume_failed") {   // a new game follows at once: its greeting clears the box
      state.notice = "The game before the reload could not be brought back; this is a new one.";
      addNote(`The page was reloaded, and the game before it could not be brought back (it had `
        + `ended, or the page was away too long). A new game starts.`);
      return;
    }
    showProblem(forPerson[d.code] || d.message); addNote(`server: ${d.message}`);
  },
};

function onMessage(m) {
  const h = handlers[m.type];
  if (h) h(m.data || {});
}

function setStatus(text) { $("status").textContent = text; }

function enableAnswers(on) { $("say").disabled = !on; $("talk").disabled = !on; }

function showProblem(text) {
  const p = $("problem");
  p.hidden = !text; p.textContent = text;
}

function addLog(speaker, act, text) {
  const li = document.createElement("li");
  li.className = speaker;
  li.dataset.act = act; li.dataset.speaker = speaker;
  const who = document.createElement("span"); who.className = "who";
  // as the paper's Figure 1 prints a turn: "Rob: Your turn. [Request(userGameMove)]"
  who.textContent = speaker === "sys" ? "Rob: " : "Usr: ";
  const t = document.createElement("span"); t.className = "text"; t.textContent = text;
  const a = document.createElement("span"); a.className = "act"; a.textContent = ` [${act}]`;
  li.append(who, t, a);
  appendLog(li);
}

function addNote(text) {
  const li = document.createElement("li"); li.className = "note"; li.textContent = `— ${text}`;
  appendLog(li);
}

// What the recogniser heard in the last recording, best first with its confidence: the person
// sees whether a "no" was taken for a "go", or noise for nothing.
function showHeard(nbest) {
  const pct = (c) => `${Math.round(100 * c)}%`;
  $("heard").textContent = nbest.length
    ? `Heard: “${nbest[0][0]}” (${pct(nbest[0][1])})`
      + (nbest.length > 1 ? `; or ${nbest.slice(1, 3).map(([t, c]) => `“${t}” (${pct(c)})`).join(", ")}` : "")
    : "Heard nothing: noise or silence.";
  $("heard").dataset.text = nbest.length ? nbest[0][0] : "";
  $("heard").dataset.confidence = nbest.length ? String(nbest[0][1]) : "";
}

function appendLog(li) { const log = $("log"); log.append(li); log.scrollTop = log.scrollHeight; }

// --- typed and spoken answers -------------------------------------------------------------

// A key in the answer box tells the robot an answer is coming (at most once a second): it
// waits for it instead of going on after its short pause.
let typingSaidAt = -Infinity;
$("say").addEventListener("keydown", (e) => {
  if (e.key !== "Enter" && performance.now() - typingSaidAt > 1000) {
    typingSaidAt = performance.now();
    send({ type: "answering", how: "typing" });
  }
  if (e.key !== "Enter") return;
  const text = e.target.value.trim();
  if (text && send({ type: "say", text })) e.target.value = "";
});

// The microphone is opened once, at the first press of push-to-talk or when hands-free is
// turned on, and kept open (opened again if the device goes away): opening it takes long
// enough to clip a first word. The last pre_roll_seconds of audio are always kept, so a
// recording starts a little before the press, and the button says "Listening" only once
// samples really arrive. Hands-free streams the audio to the server in small pieces; the
// server cuts it into utterances with its VAD, the robot's own voice taken out while it speaks.
const mic = {
  stream: null, ctx: null, opening: null, live: false,
  ring: [], ringLength: 0,   // the pre-roll: the latest audio blocks (Float32), newest last
  recording: null, held: 0,  // push-to-talk: the blocks since the press, pre-roll first
  handsFree: false, piece: [], pieceLength: 0,   // hands-free: the stream's next piece
  pieceFrame: 0, played: [],  // its first sample's frame; the robot's sentences begun since
  stats: { opened: 0, firstSampleAt: 0, pressedAt: 0, listeningAt: 0, sent: [], pieces: 0 },
  pieceSentAt: 0,
};
state.mic = mic;

function audioRate() { return state.hello ? state.hello.audio_rate : 16000; }

function micOpen() {
  return !!mic.stream && mic.stream.getAudioTracks().some((t) => t.readyState === "live");
}

function openMicrophone() {
  if (micOpen()) return Promise.resolve();
  if (!mic.opening) mic.opening = reallyOpen().finally(() => { mic.opening = null; });
  return mic.opening;
}

async function reallyOpen() {
  closeMicrophone();
  // the context and its worklet first, so that the stream's first samples have a home
  const ctx = new AudioContext({ sampleRate: audioRate() });
  mic.ctx = ctx;
  try {
    await ctx.audioWorklet.addModule("/static/tap.js");
    const node = new AudioWorkletNode(ctx, "tap");
    node.port.onmessage = (m) => { if (mic.ctx === ctx) onSamples(m.data.samples, m.data.frame); };
    const stream = await navigator.mediaDevices.getUserMedia({
      // the browser's echo canceller takes out the robot's voice where it can; the server
      // takes out what is left (oxbot.speech.echo) and hears the person over it
      audio: { echoCancellation: true, noiseSuppression: false, autoGainControl: false } });
    if (mic.ctx !== ctx) { stream.getTracks().forEach((t) => t.stop()); return; }
    ctx.createMediaStreamSource(stream).connect(node);
    if (ctx.state === "suspended") await ctx.resume();
    mic.stream = stream; mic.stats.opened++;
    stream.getAudioTracks().forEach((t) => t.addEventListener("ended", () => microphoneLost(stream)));
  } catch (err) {
    if (mic.ctx === ctx) closeMicrophone();
    throw err;
  }
}

function closeMicrophone() {
  if (mic.stream) mic.stream.getTracks().forEach((t) => t.stop());
  if (mic.ctx) mic.ctx.close();
  mic.stream = mic.ctx = null; mic.live = false;
  mic.ring = []; mic.ringLength = 0; mic.piece = []; mic.pieceLength = 0; mic.played = [];
}

function microphoneLost(stream) {
  if (mic.stream !== stream) return;
  closeMicrophone();
  if (mic.recording) { mic.recording = null; addNote("the microphone went away: hold to talk again"); }
  if (mic.handsFree) {
    send({ type: "listen_off" });
    openMicrophone().catch((err) => {
      setHandsFree(false); addNote(`the microphone went away and cannot be opened again: ${err}`);
    });
  }
  showTalk();
}

function onSamples(block, frame) {
  if (!mic.live) { mic.live = true; mic.stats.firstSampleAt = performance.now(); showTalk(); }
  if (mic.recording) {
    mic.recording.push(block); mic.held += block.length;
    return;     // hands-free pauses while push-to-talk is held
  }
  mic.ring.push(block); mic.ringLength += block.length;
  const keep = (state.hello ? state.hello.pre_roll_seconds : 0.3) * mic.ctx.sampleRate;
  while (mic.ringLength - mic.ring[0].length >= keep) mic.ringLength -= mic.ring.shift().length;
  if (mic.handsFree && !state.ended) streamPiece(block, frame);
}

function streamPiece(block, frame) {
  if (!mic.pieceLength) mic.pieceFrame = frame;
  mic.piece.push(block); mic.pieceLength += block.length;
  const rate = mic.ctx.sampleRate, h = state.hello || {};
  // shorter while the robot's voice plays: someone talking over it is heard (and it is cut
  // short) as soon as a piece is full
  const seconds = (robotAudible() ? h.stream_piece_seconds_over_speech : h.stream_piece_seconds) || 0.1;
  if (mic.pieceLength < rate * seconds) return;
  // a busy page gets its samples in bursts: what comes sooner than a piece's time after the
  // last one goes with the next, so the stream never sends more messages than it is long
  const now = performance.now();
  if (now - mic.pieceSentAt < 900 * seconds && mic.pieceLength < rate * 0.5) return;
  const samples = concat(mic.piece);
  // where in this piece the robot's sentences began to play (later ones: past its end), so
  // that the server finds its own voice in the stream however late the pieces come
  const played = mic.played.map((p) => ({ text: p.text, sentence: p.sentence, at: p.frame - mic.pieceFrame }));
  mic.piece = []; mic.pieceLength = 0; mic.pieceSentAt = now; mic.played = [];
  if (send({ type: "listen", rate, pcm: toBase64(toInt16(samples).buffer), played })) mic.stats.pieces++;
}

// Whether a sentence of the robot's is playing now (or about to: it is scheduled).
function robotAudible() {
  const last = state.sentences[state.sentences.length - 1];
  return !!last && last.played && last.end > speechClock();
}

// A sentence of the robot's begins at `start` on the speech clock: the microphone's frame
// then, for the next piece to say.
function markPlayed(text, sentence, start) {
  if (!mic.handsFree || !mic.ctx || !state.audio) return;
  const frame = Math.round((mic.ctx.currentTime + start - state.audio.currentTime) * mic.ctx.sampleRate);
  mic.played.push({ text, sentence, frame });
}

function showTalk() {
  const b = $("talk"), listening = !!mic.recording && mic.live;
  b.classList.toggle("recording", !!mic.recording);
  b.textContent = !mic.recording ? "Hold to talk"
    : listening ? "Listening… release to send" : "Opening the microphone…";
  if (listening && !mic.stats.listeningAt) mic.stats.listeningAt = performance.now();
}

function pressTalk() {
  if (!state.ws || mic.recording) return;
  mic.stats.pressedAt = performance.now(); mic.stats.listeningAt = 0;
  mic.recording = mic.ring; mic.held = 0;   // the pre-roll first: the audio just before the press
  send({ type: "answering", how: "speaking" });
  mic.ring = []; mic.ringLength = 0;
  if (mic.handsFree) { send({ type: "listen_off" }); mic.piece = []; mic.pieceLength = 0; }
  showTalk();
  openMicrophone().catch((err) => {
    addNote(`the microphone cannot be used: ${err}`); mic.recording = null; showTalk();
  });
}

async function releaseTalk() {
  const blocks = mic.recording;
  if (!blocks) return;
  mic.recording = null; showTalk();
  const rate = mic.ctx ? mic.ctx.sampleRate : audioRate(), wanted = audioRate();
  if (mic.held < rate * 0.1) {
    addNote(mic.live ? "too short: hold the button while you talk"
      : "the microphone was still opening: hold the button until it says Listening");
    return;
  }
  let samples = concat(blocks);
  if (rate !== wanted) samples = await resample(samples, rate, wanted);
  if (send({ type: "talk", rate: wanted, pcm: toBase64(toInt16(samples).buffer) })) {
    mic.stats.sent.push(samples.length / wanted);
  }
}

function concat(chunks) {
  const out = new Float32Array(chunks.reduce((n, c) => n + c.length, 0));
  let at = 0; for (const c of chunks) { out.set(c, at); at += c.length; }
  return out;
}

async function resample(samples, from, to) {
  const off = new OfflineAudioContext(1, Math.ceil(samples.length * to / from), to);
  const buf = off.createBuffer(1, samples.length, from); buf.copyToChannel(samples, 0);
  const src = off.createBufferSource(); src.buffer = buf; src.connect(off.destination); src.start();
  return (await off.startRendering()).getChannelData(0);
}

function toInt16(f) {
  const out = new Int16Array(f.length);
  for (let i = 0; i < f.length; i++) out[i] = Math.max(-32768, Math.min(32767, Math.round(f[i] * 32767)));
  return out;
}

function toBase64(buffer) {
  const bytes = new Uint8Array(buffer); let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

const talkButton = $("talk");
talkButton.addEventListener("pointerdown", (e) => { talkButton.setPointerCapture(e.pointerId); pressTalk(); });
talkButton.addEventListener("pointerup", releaseTalk);
talkButton.addEventListener("pointercancel", releaseTalk);

async function setHandsFree(on) {
  if (on) {
    try {
      await openMicrophone();
      if (mic.ctx.sampleRate !== audioRate()) {
        throw new Error(`this browser records at ${mic.ctx.sampleRate} Hz, not ${audioRate()} Hz; hold to talk instead`);
      }
    } catch (err) { addNote(`hands-free cannot listen: ${err.message || err}`); on = false; }
  } else if (mic.handsFree) {
    send({ type: "listen_off" });
  }
  mic.handsFree = on; mic.piece = []; mic.pieceLength = 0; mic.played = [];
  // what the robot is saying now is heard back too: the server is told where it began
  for (const s of on ? state.sentences : []) {
    if (s.played && s.end > speechClock()) markPlayed(s.text, s.index, s.start);
  }
  try { sessionStorage.setItem(HANDS_FREE, on ? "1" : ""); } catch (_) { /* storage off */ }
  $("hands-free").textContent = `Hands-free: ${on ? "on" : "off"}`;
  $("hands-free").setAttribute("aria-pressed", String(on));
}
$("hands-free").addEventListener("click", () => setHandsFree(!mic.handsFree));

// --- the face: speech audio, the mouth, the eyes --------------------------------------------

function ensureAudio() {
  if (state.audio) { if (state.audio.state === "suspended") state.audio.resume(); return; }
  state.audio = new AudioContext();
  state.gain = state.audio.createGain(); state.gain.gain.value = state.sound ? 1 : 0;
  state.analyser = state.audio.createAnalyser(); state.analyser.fftSize = 512;
  state.analyser.connect(state.gain); state.gain.connect(state.audio.destination);
  requestAnimationFrame(animateMouth);
}

// Speech comes a sentence at a time: SpeakingStarted's plays at once (cutting off anything
// still playing), each SpeakingContinued's right after the one before, on the audio clock.
// A sentence with visemes (Piper) moves the mouth through them on that clock; one without
// (espeak-ng) moves it with the loudness of what plays.
const VISEME_SHAPES = {   // [rx, ry] of the mouth's ellipse; ry <= 3 is a closed mouth
  rest: [28, 3], closed: [30, 1.5], rounded: [15, 12], open: [28, 20], mid: [28, 11],
  spread: [34, 6], teeth: [30, 5], narrow: [29, 8],
};
function speechClock() {   // seconds: the audio's own clock, or the page's without audio
  return state.audio ? state.audio.currentTime : performance.now() / 1000;
}
state.sentences = [];      // {start, end, visemes} on speechClock(), oldest first
state.speechChain = Promise.resolve();

function speak(d, first) {
  state.speaking = true;
  if (first) { state.playingText = d.text; state.cutText = null; }
  state.speechChain = state.speechChain.then(() => playSentence(d, first));
}

async function playSentence(d, first) {
  const speed = state.hello ? state.hello.speed_factor : 1;
  if (first) {
    for (const src of state.sources || []) { try { src.stop(); } catch (_) { /* ended */ } }
    state.sources = []; state.sentences = []; state.source = null; state.sentenceIndex = 0;
  } else {
    state.sentenceIndex = (state.sentenceIndex || 0) + 1;
  }
  const last = state.sentences[state.sentences.length - 1];
  let start = Math.max(speechClock(), last ? last.end : 0), seconds = (d.seconds || 0.5) / speed;
  let played = false;
  if (d.audio && state.audio) {
    try {
      const bytes = Uint8Array.from(atob(d.audio), (c) => c.charCodeAt(0));
      const buffer = await state.audio.decodeAudioData(bytes.buffer);
      if (state.cutText === d.text) return;   // cut short while it was decoded
      start = Math.max(state.audio.currentTime, last ? last.end : 0); seconds = buffer.duration;
      const src = state.audio.createBufferSource(); src.buffer = buffer;
      src.connect(state.analyser); src.start(start);
      state.sources = [...(state.sources || []), src]; state.source = src;
      markPlayed(d.text, state.sentenceIndex, start); played = true;
      src.onended = () => {
        state.sources = state.sources.filter((s) => s !== src);
        if (state.source === src) state.source = null;
      };
    } catch (err) { console.warn("cannot play the robot's speech", err); }
  }
  state.sentences.push({ start, end: start + seconds, visemes: d.visemes || [],
                         scale: d.audio && state.audio ? 1 : 1 / speed,
                         text: d.text, index: state.sentenceIndex, played });
  state.mouthUntil = performance.now() + 1000 * (start + seconds - speechClock());
}

// The viseme the mouth shows at `t` (speechClock seconds), or null when no sentence with
// visemes plays then.
function visemeAt(t) {
  const s = state.sentences.find((x) => x.start <= t && t < x.end);
  if (!s || !s.visemes.length) return null;
  const into = (t - s.start) / s.scale;
  let name = "rest";
  for (const [at, v] of s.visemes) { if (at <= into) name = v; else break; }
  return name;
}

const level = new Uint8Array(256);
function animateMouth(now) {
  let rx = 30, open = 0;
  // what is heard now left the audio clock outputLatency ago
  const t = speechClock() - (state.audio ? state.audio.outputLatency || 0 : 0);
  const viseme = visemeAt(t);
  if (viseme) {
    [rx, open] = VISEME_SHAPES[viseme] || VISEME_SHAPES.narrow; open = (open - 3) / 17;
  } else if (state.source && state.analyser) {
    // the mouth follows the loudness of the audio playing (muted or not)
    state.analyser.getByteTimeDomainData(level);
    let sum = 0; for (const v of level) sum += (v - 128) * (v - 128);
    open = Math.min(1, Math.sqrt(sum / level.length) / 25);
  } else if (now < state.mouthUntil) {
    open = 0.5 + 0.5 * Math.sin(now / 60);   // no audio: a steady babble for the time it takes
  }
  $("mouth").setAttribute("rx", rx.toFixed(1));
  $("mouth").setAttribute("ry", (3 + 17 * open).toFixed(1));
  $("face").dataset.viseme = viseme || "";
  $("face").dataset.talking = open > 0.05 ? "yes" : "no";
  if (open > 0.05) state.stats.mouthMoves++;
  requestAnimationFrame(animateMouth);
}
requestAnimationFrame(animateMouth);

// HeadMove is where the robot turns its own head: its left is the viewer's right.
const GAZE = { left: [10, 0], right: [-10, 0], up: [0, -10], down: [0, 10], centre: [0, 0] };
function lookTowards(direction) {
  const [dx, dy] = GAZE[direction] || [0, 0];
  $("pupil-left").setAttribute("cx", 70 + dx); $("pupil-left").setAttribute("cy", 62 + dy);
  $("pupil-right").setAttribute("cx", 130 + dx); $("pupil-right").setAttribute("cy", 62 + dy);
  $("face").dataset.gaze = direction;
}

$("sound").addEventListener("click", () => {
  state.sound = !state.sound;
  $("sound").textContent = `Sound: ${state.sound ? "on" : "off"}`;
  $("sound").setAttribute("aria-pressed", String(state.sound));
  if (state.gain) state.gain.gain.value = state.sound ? 1 : 0;
});

$("camera").addEventListener("click", async () => {
  if (state.camera) { stopCamera(); return; }
  try {
    const stream = await navigator.mediaDevices.getUserMedia({ video: { width: 320, height: 240 } });
    const v = $("webcam"); v.srcObject = stream; await v.play();
    state.camera = stream;
    const grab = document.createElement("canvas"), g = grab.getContext("2d");
    state.cameraTimer = setInterval(() => {
      if (!v.videoWidth) return;
      const w = 320, h = Math.round(320 * v.videoHeight / v.videoWidth);
      grab.width = w; grab.height = h; g.drawImage(v, 0, 0, w, h);
      send({ type: "look", image: grab.toDataURL("image/jpeg", 0.7) });
    }, 200);
    $("camera").textContent = "Camera: on"; $("camera").setAttribute("aria-pressed", "true");
  } catch (err) { addNote(`the camera cannot be used: ${err}`); }
});

function stopCamera() {
  clearInterval(state.cameraTimer); state.cameraTimer = null;
  if (state.camera) state.camera.getTracks().forEach((t) => t.stop());
  state.camera = null; lookTowards("centre");
  $("camera").textContent = "Camera: off"; $("camera").setAttribute("aria-pressed", "false");
}

// --- what the robot sees ------------------------------------------------------------------

// The page's public `cells`: the robot's current reading of each cell, "partial" for ink that is not
// a whole symbol yet
const CELL_MARKS = { circle: "O", cross: "X", nothing: "", partial: "~" };
function showCells(d) {
  const cells = $("cells"), readings = d && d.readings ? d.readings : [];
  for (let i = 0; i < cells.children.length; i++) {
    const div = cells.children[i], label = readings[i] || "nothing";
    div.dataset.label = label; div.textContent = CELL_MARKS[label] ?? "?";
    div.title = d && d.confidences && d.confidences[i] !== undefined
      ? `${label} (${Math.round(100 * d.confidences[i])}%)` : label;
  }
}

function showSeen(d) {
  state.lastSeen = d;
  showCells(d);
  const crops = $("crops");
  const names = state.hello ? state.hello.cells : [];
  if (crops.children.length !== names.length) {
    crops.innerHTML = "";
    for (let i = 0; i < names.length; i++) {
      const div = document.createElement("div"); div.className = "crop";
      const img = document.createElement("img"); img.alt = "";
      const label = document.createElement("div");
      div.append(img, label); crops.append(div);
    }
  }
  for (let i = 0; i < names.length; i++) {
    const found = d.labels && d.labels.length;
    const reading = found && d.readings && d.readings[i] ? d.readings[i] : null;
    const label = reading || (found ? d.labels[i] : "no grid");
    const sure = reading && d.confidences ? ` ${Math.round(100 * d.confidences[i])}%` : "";
    const div = crops.children[i];
    if (d.cells && d.cells[i]) div.querySelector("img").src = `data:image/png;base64,${d.cells[i]}`;
    const mark = state.hello && state.hello.robot_symbol === "cross" ? "X" : "O";
    const robots = state.robotCells.has(names[i]) ? ` (robot's ${mark})` : "";
    div.querySelector("div").textContent = `${names[i] || i}: ${label}${sure}${robots}`;
    div.className = `crop ${label}`;
    div.dataset.label = label;
  }
  $("refusal").textContent = d.refusal || "";  // why no grid was found, in words
  const n = d.agreeing || 0;
  $("agreeing").querySelectorAll("i").forEach((dot, i) => dot.classList.toggle("on", i < n));
  const needed = state.hello ? state.hello.stable_readings : 3;
  $("agreeing").querySelector("b").textContent = `${Math.min(n, needed)}/${needed}`;
  $("agreeing").dataset.count = String(n);
}

function buildDecisionTable(acts) {
  const body = $("decision").querySelector("tbody"); body.innerHTML = "";
  for (const act of acts) {
    const tr = document.createElement("tr"); tr.className = "off"; tr.dataset.act = act;
    tr.innerHTML = `<td class="mark"></td><td class="name"></td><td class="q">—</td><td><span class="bar"></span></td>`;
    tr.querySelector(".name").textContent = act;
    body.append(tr);
  }
}

function showDecision(d) {
  const acts = state.hello ? state.hello.acts : [];
  const offered = new Set(d.offered), qs = d.q_values || [];
  const shown = acts.map((a, i) => offered.has(a) ? qs[i] : null).filter((q) => q !== null);
  const lo = Math.min(...shown, 0), hi = Math.max(...shown, 1e-6);
  acts.forEach((act, i) => {
    const tr = $("decision").querySelector(`tr[data-act="${CSS.escape(act)}"]`);
    if (!tr) return;
    const on = offered.has(act);
    tr.className = act === d.chosen ? "chosen" : on ? "" : "off";
    tr.querySelector(".mark").textContent = act === d.chosen ? "▶" : "";
    tr.querySelector(".q").textContent = qs[i] === undefined ? "—" : Number(qs[i]).toFixed(2);
    tr.querySelector(".bar").style.width = on ? `${Math.round(60 * (qs[i] - lo) / (hi - lo || 1))}px` : "0";
  });
}

// --- paper mode: real paper under the browser's camera --------------------------------------

// The page streams its camera's frames of the sheet to the robot, which reads them as it reads
// the canvas (the same game-move component, 3 agreeing readings at 10 Hz). Frames are shrunk
// to what the reader needs (cells of about CELL_PX pixels once the grid is found) and sent at
// most every PAPER_PERIOD_MS, less often while the socket has not passed the last ones on.
// Over the video: the grid the robot found, each cell's reading, the 3-in-a-row progress and
// the robot's own symbols, which it cannot draw (no arm reaches the paper): the person may
// draw them for it, or leave them on the screen.
const PAPER_PERIOD_MS = FRAME_PERIOD_MS, PAPER_SLOWEST_MS = 1000;
const CELL_PX = 60, MIN_SEND_WIDTH = 320, MAX_SEND_WIDTH = 960, JPEG_QUALITY = 0.8;
const GUIDANCE_KINDS = ["no_grid", "off_edge", "too_close", "too_dark", "blurred", "hand"];
const BACKLOG_BYTES = 64 * 1024;   // more unsent than this: the link is slower than the frames
const paper = {
  on: false, stream: null, deviceId: "", width: 480, period: PAPER_PERIOD_MS, lastSent: 0,
  grid: null, seen: null, timer: null, guiding: false,
  moves: new Set(),      // the person's moves accepted while in paper mode (cell names)
  stats: { sent: [], skipped: 0, opened: 0, errors: [] },
};
state.paper = paper;
const video = $("paper-video"), pctx = $("paper-overlay").getContext("2d");
const grab = document.createElement("canvas"), gctx = grab.getContext("2d");

const CAMERA_TROUBLE = {
  insecure: "This page cannot use a camera here: browsers lend it only to secure pages. Open "
    + "oxbot over HTTPS (oxbot play --https) or at http://localhost on this computer. "
    + "Meanwhile, play on on the canvas.",
  denied: "The camera is blocked for this page: allow it in the browser (the camera icon by the "
    + "address), then press Play on paper again. Meanwhile, play on on the canvas.",
  missing: "No camera found: plug one in, or open the page on a phone, then press Play on "
    + "paper again. Meanwhile, play on on the canvas.",
  busy: "The camera is in use by another program: close it, then press Play on paper again. "
    + "Meanwhile, play on on the canvas.",
  stopped: "The camera stopped (unplugged, or taken by another program). The game goes on on "
    + "the canvas; press Play on paper to try the camera again.",
};

function troubleOf(err) {
  const name = err && err.name;
  if (name === "NotAllowedError" || name === "SecurityError" || name === "PermissionDeniedError") return "denied";
  if (name === "NotFoundError" || name === "OverconstrainedError" || name === "DevicesNotFoundError") return "missing";
  if (name === "NotReadableError" || name === "TrackStartError" || name === "AbortError") return "busy";
  return null;
}

function showPaperMessage(kind, detail) {
  const box = $("paper-message");
  const text = kind ? CAMERA_TROUBLE[kind] || `The camera cannot be used: ${detail}` : "";
  box.hidden = !text; box.textContent = text; box.dataset.kind = kind || "";
  if (text) { addNote(text); paper.stats.errors.push(kind || String(detail)); }
}

async function startPaper(deviceId) {
  showPaperMessage("");
  if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia) {
    showPaperMessage("insecure"); return;
  }
  const video_ = deviceId ? { deviceId: { exact: deviceId } }
    : { facingMode: { ideal: "environment" }, width: { ideal: 640 }, height: { ideal: 480 } };
  let stream;
  try {
    stream = await navigator.mediaDevices.getUserMedia({ video: video_, audio: false });
  } catch (err) {
    stopPaper(); const kind = troubleOf(err); showPaperMessage(kind, `${err.name}: ${err.message}`);
    return;
  }
  if (paper.stream) paper.stream.getTracks().forEach((t) => t.stop());
  paper.stream = stream; paper.stats.opened++;
  const track = stream.getVideoTracks()[0];
  paper.deviceId = (track.getSettings && track.getSettings().deviceId) || deviceId || "";
  track.addEventListener("ended", () => cameraStopped(stream));
  video.srcObject = stream;
  try { await video.play(); } catch (_) { /* autoplay: muted video plays */ }
  setPaper(true);
  listCameras();
}

function cameraStopped(stream) {
  if (paper.stream !== stream) return;  // one we stopped ourselves
  stopPaper(); showPaperMessage("stopped");
}

function stopPaper() {
  if (paper.stream) { const s = paper.stream; paper.stream = null; s.getTracks().forEach((t) => t.stop()); }
  video.srcObject = null;
  setPaper(false);
}

function setPaper(on) {
  const was = paper.on;
  paper.on = on; paper.grid = null; paper.seen = null; paper.period = PAPER_PERIOD_MS;
  $("paper").setAttribute("aria-pressed", String(on));
  $("paper").textContent = on ? "Back to the canvas" : "Play on paper";
  $("paper-view").hidden = !on; $("camera-pick").hidden = !on;
  $("sheet").hidden = on; $("undo").hidden = on; $("guidance").hidden = true;
  $("paper-hint").hidden = !on || !$("paper-hint").textContent;
  $("agreeing").hidden = !on;  // readings agree on the camera's stream; a canvas is read once
  $("sees-source").textContent = on ? "the camera's picture of the paper, ten times a second"
    : "the sheet the page sends each time the pen lifts";
  drawPaperOverlay();
  if (on !== was) send({ type: "paper", on });
  if (!on && was) { drawPaperMoves(); state.dirty = true; sendFrame(); }  // the canvas again
  clearTimeout(paper.timer);
  if (on) paperTick();
}

async function listCameras() {
  const pick = $("camera-pick");
  let cameras = [];
  try { cameras = (await navigator.mediaDevices.enumerateDevices()).filter((d) => d.kind === "videoinput"); }
  catch (_) { return; }
  pick.innerHTML = "";
  cameras.forEach((c, i) => {
    const o = document.createElement("option");
    o.value = c.deviceId; o.textContent = c.label || `camera ${i + 1}`;
    o.selected = c.deviceId === paper.deviceId; pick.append(o);
  });
}
$("camera-pick").addEventListener("change", (e) => startPaper(e.target.value));
$("paper").addEventListener("click", () => (paper.on ? stopPaper() : startPaper(paper.deviceId)));

function paperTick() {
  if (!paper.on) return;
  paper.timer = setTimeout(paperTick, 20);
  const now = performance.now();
  if (now - paper.lastSent < paper.period || state.ended || !video.videoWidth) return;
  if (!state.ws || state.ws.readyState !== WebSocket.OPEN) return;
  if (state.ws.bufferedAmount > BACKLOG_BYTES) {   // the link is behind: send less often
    paper.period = Math.min(PAPER_SLOWEST_MS, paper.period * 1.5); paper.stats.skipped++;
    paper.lastSent = now; return;
  }
  paper.period = Math.max(PAPER_PERIOD_MS, paper.period * 0.9);
  const w = Math.min(paper.width, video.videoWidth), h = Math.round(w * video.videoHeight / video.videoWidth);
  grab.width = w; grab.height = h - (h % 2); gctx.drawImage(video, 0, 0, grab.width, grab.height);
  if (send({ type: "frame", image: grab.toDataURL("image/jpeg", JPEG_QUALITY) })) {
    paper.lastSent = now; paper.stats.sent.push(now);
  }
}

function seenOnPaper(d) {
  paper.seen = d;
  paper.grid = d.grid && d.grid.length === 32 ? d.grid : null;
  if (paper.grid) {  // send what the reader needs: cells of about CELL_PX pixels
    const xs = paper.grid.filter((_, i) => i % 2 === 0), span = Math.max(...xs) - Math.min(...xs);
    const wanted = Math.round(3 * CELL_PX / Math.max(span, 0.05));
    paper.width = Math.max(MIN_SEND_WIDTH, Math.min(MAX_SEND_WIDTH, video.videoWidth || 640, wanted));
  }
  const guide = $("guidance");
  guide.hidden = !d.refusal; guide.textContent = d.refusal || "";
  if (!d.refusal && paper.guiding) { paper.guiding = false; showProblem(""); }  // seen again
  drawPaperOverlay();
}

function lattice(r, c) {   // the grid's corner (r, c) in overlay pixels
  const k = 2 * (4 * r + c), cv = pctx.canvas;
  return [paper.grid[k] * cv.width, paper.grid[k + 1] * cv.height];
}

function inCell(i, u, v) {  // a point of cell i's unit square on the video: bilinear in its corners
  const r = Math.floor(i / SIZE), c = i % SIZE;
  const [a, b, e, f] = [lattice(r, c), lattice(r, c + 1), lattice(r + 1, c), lattice(r + 1, c + 1)];
  return [0, 1].map((k) => (1 - v) * ((1 - u) * a[k] + u * b[k]) + v * ((1 - u) * e[k] + u * f[k]));
}

function drawPaperOverlay() {
  const cv = pctx.canvas;
  if (video.videoWidth && (cv.width !== video.videoWidth || cv.height !== video.videoHeight)) {
    cv.width = video.videoWidth; cv.height = video.videoHeight;
  }
  pctx.clearRect(0, 0, cv.width, cv.height);
  const d = paper.seen, progress = $("paper-progress");
  if (!paper.on || !paper.grid || !d) { progress.textContent = ""; return; }
  const names = state.hello ? state.hello.cells : [], scale = cv.width / 480;
  pctx.lineWidth = Math.max(2, 2 * scale); pctx.strokeStyle = "rgba(34,197,94,.9)";
  for (let k = 0; k <= SIZE; k++) {  // the lattice the robot found: rows, then columns
    pctx.beginPath(); pctx.moveTo(...lattice(k, 0)); pctx.lineTo(...lattice(k, SIZE)); pctx.stroke();
    pctx.beginPath(); pctx.moveTo(...lattice(0, k)); pctx.lineTo(...lattice(SIZE, k)); pctx.stroke();
  }
  const robotMark = state.hello && state.hello.robot_symbol;
  let pending = -1;
  pctx.font = `${Math.round(12 * scale)}px system-ui, sans-serif`;
  for (let i = 0; i < names.length; i++) {
    const reading = (d.readings && d.readings[i]) || "nothing";
    const sure = d.confidences && d.confidences[i] !== undefined ? ` ${Math.round(100 * d.confidences[i])}%` : "";
    const strokes = state.robotStrokes[names[i]];
    if (strokes) {  // the robot's symbol: virtual, or drawn for it by the person
      const drawn = reading === robotMark;
      pctx.strokeStyle = drawn ? "rgba(139,30,63,.35)" : "rgba(139,30,63,.9)";
      pctx.lineWidth = Math.max(3, 5 * scale); pctx.lineCap = "round";
      for (const s of strokes) {
        pctx.beginPath();
        s.forEach(([u, v], j) => { const [x, y] = inCell(i, u, v); j ? pctx.lineTo(x, y) : pctx.moveTo(x, y); });
        pctx.stroke();
      }
    } else if ((reading === "circle" || reading === "cross") && !state.board[i]) {
      pending = i;  // a symbol not yet a move: the 3-in-a-row under way
    }
    const [x, y] = inCell(i, 0.06, 0.2), mark = { circle: "O", cross: "X", nothing: "·", partial: "~" }[reading] || "?";
    const label = strokes ? (reading === robotMark ? "robot's, drawn" : "robot's") : `${mark}${sure}`;
    pctx.fillStyle = "rgba(255,255,255,.8)";
    pctx.fillRect(x - 2, y - 12 * scale, pctx.measureText(label).width + 4, 15 * scale);
    pctx.fillStyle = i === pending ? "#2563eb" : "#111827"; pctx.fillText(label, x, y);
  }
  const needed = state.hello ? state.hello.stable_readings : 3, n = Math.min(d.agreeing || 0, needed);
  progress.textContent = pending >= 0 || n ? `new move: ${"●".repeat(n)}${"○".repeat(needed - n)} ${n}/${needed}` : "";
  if (pending >= 0) {  // a ring round the cell, filling with each agreeing reading
    const [cx, cy] = inCell(pending, 0.5, 0.5), [ex] = inCell(pending, 1, 0.5);
    pctx.strokeStyle = "#2563eb"; pctx.lineWidth = Math.max(3, 4 * scale);
    pctx.beginPath(); pctx.arc(cx, cy, Math.abs(ex - cx) * 0.9, -Math.PI / 2, -Math.PI / 2 + 2 * Math.PI * n / needed);
    pctx.stroke();
  }
}

function showPaperHint(act) {
  const cell = act.slice(act.indexOf("=") + 1, -1), hint = $("paper-hint");
  const where = cell === "middle" ? "the middle"   // upperleft -> the upper left
    : `the ${cell.replace(/^(upper|middle|lower)/, "$1 ")}`;
  const mark = state.hello.robot_symbol === "cross" ? "cross (X)" : "circle (O)";
  hint.textContent = `The robot plays ${where}: draw its ${mark} there for it if you like, `
    + "or leave it on the screen.";
  hint.hidden = false;
}

function drawPaperMoves() {
  // the person's moves made on paper, shown on the canvas's overlay (never sent: the robot
  // already knows them) when the game goes on on the canvas
  if (paper.on || !state.hello) return;
  const user = state.hello.user_symbol;
  paper.moves.forEach((where) => {
    if (state.paperDrawn.has(where)) return;
    const box = cellBox(where); if (!box) return;
    const [l, t, r, b] = box, cx = (l + r) / 2, cy = (t + b) / 2, q = (r - l) * 0.28;
    octx.strokeStyle = "#64748b"; octx.lineWidth = PEN_WIDTH; octx.lineCap = "round"; octx.beginPath();
    if (user === "circle") octx.arc(cx, cy, q, 0, 2 * Math.PI);
    else { octx.moveTo(cx - q, cy - q); octx.lineTo(cx + q, cy + q); octx.moveTo(cx + q, cy - q); octx.lineTo(cx - q, cy + q); }
    octx.stroke();
    state.paperDrawn.add(where);
  });
}

function showFingerprint(sha256) {
  const f = $("tls");
  f.hidden = !sha256;
  f.textContent = sha256 ? `This page's HTTPS certificate (self-signed by oxbot), SHA-256: ${sha256}` : "";
}
if (location.protocol === "https:") {
  fetch("/tls").then((r) => r.json()).then((t) => showFingerprint(t.sha256)).catch(() => {});
}
video.addEventListener("resize", drawPaperOverlay);

// the blank sheet, before the first game
state.grid = newGrid(); redrawSheet();

// A game lives in its socket's robot. The server keeps it a while when the page goes away
// mid-game (web.resume_seconds), and the page, reloaded, asks for it back with the token its
// Hello gave (kept per tab: two tabs never share a game). Hands-free stays off after a reload:
// a page may not open the microphone's audio until the person acts, so they turn it on again.
const RESUME = "oxbot.resume", HANDS_FREE = "oxbot.hands-free", TAKEN_OVER = 4000;
function gameUnderWay(on) {
  try {
    const token = state.hello && state.hello.resume_token;
    if (on && token) sessionStorage.setItem(RESUME, token); else sessionStorage.removeItem(RESUME);
  } catch (_) { /* storage off: a reload starts afresh */ }
}
let resumeToken = null, handsFreeBefore = false;
try {
  resumeToken = sessionStorage.getItem(RESUME);
  handsFreeBefore = sessionStorage.getItem(HANDS_FREE) === "1"; sessionStorage.removeItem(HANDS_FREE);
} catch (_) { /* storage off */ }
function handsFreeWasOn() { return handsFreeBefore; }
state.resuming = !!resumeToken;
if (resumeToken) {
  // after every script has run: record.js and a study's page set the socket's path and query
  addEventListener("DOMContentLoaded", () => {
    if (state.ws) return;
    setStatus("Bringing the game back…");
    ensureAudio(); connect(resumeToken);
  });
  // the robot's voice: a browser may hold audio until the person first acts on the page
  for (const kind of ["pointerdown", "keydown"]) addEventListener(kind, ensureAudio, { once: true });
}
