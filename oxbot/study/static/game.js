// The game page inside the study's frame (/study/game?participant=..&block=..&input=..): the
// socket is the study's, which builds the robot for the block's condition; what the condition
// does not allow (typing or speaking), the manager's Q-values (they would tell the participant
// which manager it is), the record toggle and "New game" are hidden.
"use strict";
(() => {
  const params = new URLSearchParams(location.search);
  const query = new URLSearchParams({ participant: params.get("participant") || "",
    block: params.get("block") || "" });
  window.socketPath = "/study/ws";
  window.recordingQuery = () => `?${query}`;
  const hide = (el) => { if (el) el.hidden = true, el.style.display = "none"; };
  hide(document.querySelector(".recording"));
  hide(document.querySelector(".decision"));
  if (params.get("input") === "voice") hide(document.getElementById("say"));
  else { hide(document.getElementById("talk")); hide(document.getElementById("hands-free")); }
  const start = document.getElementById("start");
  start.addEventListener("click", () => setTimeout(() => hide(start), 0));
  if (window.oxbot && window.oxbot.resuming) hide(start);   // a game coming back after a reload
})();
