// The record toggle: off by default (on with `oxbot play --record`), with a
// one-line notice of what is kept. It uses app.js's `state` and `send`.
"use strict";
(() => {
  const box = document.getElementById("record");
  const notice = document.getElementById("record-notice");
  let text = "";
  const show = () => {
    notice.textContent = box.checked ? text : "Off: nothing of this game is kept.";
  };
  // the toggle's state when a tab connects: the server records from the game's start
  window.recordingQuery = () => (box.checked ? "?record=1" : "");
  // a game brought back after a reload records as it did: the toggle shows it
  window.showRecording = (on) => { if (!box.disabled) { box.checked = on; show(); } };
  box.addEventListener("change", () => {
    show();
    send({ type: "record", on: box.checked });   // a game under way: kept from now, or no more
  });
  fetch("/recording/status").then((r) => r.json()).then((status) => {
    text = status.notice;
    if (!status.available) {   // this robot cannot keep games: say so, and no toggle to press
      box.checked = false; box.disabled = true; notice.textContent = text;
      return;
    }
    if (status.on_by_default && !state.ws) box.checked = true;
    show();
  });
  show();
})();
