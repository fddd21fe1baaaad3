"""Driving the page in Debian's Chromium with Playwright: what the browser tests and the
latency benchmark share.

Playwright's own browser download does not work on these machines; the system's Chromium
(`apt-get install chromium`, done by `make setup`) does, headless, with the flags below.
`page` arguments are Playwright `Page`s; this module does not import Playwright itself.
"""

from __future__ import annotations

import base64
import contextlib
import itertools
import json
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from oxbot.testing.sheet import SIDE, person_strokes, unit_to_canvas

CHROMIUM = "/usr/bin/chromium"
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--autoplay-policy=no-user-gesture-required",
)
"""Headless Chromium as this machine needs it, and sound without a click first."""


def draw(
    page: Any, where: str, symbol: str, rng: np.random.Generator, finger: bool = False
) -> None:
    """Draw `symbol` in cell `where` stroke by stroke, with the mouse or (`finger`) by touch."""
    box = page.get_by_test_id("board").bounding_box()
    scale = box["width"] / SIDE
    touch = page.context.new_cdp_session(page) if finger else None
    for stroke in person_strokes(symbol, rng):
        points = unit_to_canvas(where, stroke) * scale + (box["x"], box["y"])
        path = [points[0]]
        for a, b in itertools.pairwise(points):
            steps = max(1, int(np.hypot(*(b - a)) / 6))
            path += [a + (b - a) * k / steps for k in range(1, steps + 1)]
        if touch is None:
            page.mouse.move(*path[0])
            page.mouse.down()
            for x, y in path[1:]:
                page.mouse.move(x, y)
            page.mouse.up()
            continue
        kinds = ["touchStart"] + ["touchMove"] * (len(path) - 1)
        for kind, (x, y) in zip(kinds, path, strict=True):
            touch.send(
                "Input.dispatchTouchEvent",
                {"type": kind, "touchPoints": [{"x": float(x), "y": float(y)}]},
            )
            time.sleep(0.008)  # a finger reports about 120 times a second
        touch.send("Input.dispatchTouchEvent", {"type": "touchEnd", "touchPoints": []})
    if touch is not None:
        touch.detach()


ROOM = """
(() => {
  const voice = Uint8Array.from(atob(%s), (c) => c.charCodeAt(0)).buffer, openMs = %d;
  const room = { ctx: null, dest: null, buffer: null, spoken: [], listening: false };
  window.__room = room;
  async function ready() {
    if (room.ctx) return;
    room.ctx = new AudioContext();
    room.dest = room.ctx.createMediaStreamDestination();
    room.buffer = await room.ctx.decodeAudioData(voice.slice(0));
  }
  const real = navigator.mediaDevices.getUserMedia.bind(navigator.mediaDevices);
  navigator.mediaDevices.getUserMedia = async (constraints) => {
    if (!constraints || !constraints.audio) return real(constraints);
    await ready();
    await new Promise((r) => setTimeout(r, openMs));   // a device takes time to open
    return new MediaStream([room.dest.stream.getAudioTracks()[0].clone()]);
  };
  addEventListener("DOMContentLoaded", () => {
    ready();
    const button = document.getElementById("talk");
    new MutationObserver(() => {
      const now = /Listening/.test(button.textContent);
      if (now && !room.listening) {   // the person starts talking at once
        const src = room.ctx.createBufferSource();
        src.buffer = room.buffer; src.connect(room.dest); src.start();
        room.spoken.push(performance.now());
      }
      room.listening = now;
    }).observe(button, { childList: true, characterData: true, subtree: true });
  });
})();
"""


def room_script(wav: bytes, open_ms: int = 0) -> str:
    """A page init script (Playwright's `add_init_script`) that stands in for a person and a
    real microphone: the person says `wav` the moment the talk button says "Listening", in a
    "room" (an AudioContext) that the page's getUserMedia hears through a
    MediaStreamAudioDestinationNode, opened `open_ms` after it is asked for. Unlike
    Chromium's fake microphone, which starts its file when the page opens it, a real
    microphone hears the room whether the page listens yet or not: what the page misses, a
    person loses. `window.__room.spoken` holds when each sentence began (performance.now)."""
    return ROOM % (json.dumps(base64.b64encode(wav).decode()), open_ms)


CONVERSATION = """
(() => {
  const room = { ctx: null, input: null, streams: new WeakSet(), track: null };
  room.said = []; room.playing = 0;
  window.__room = room;
  room.say = async (b64) => {
    if (!room.ctx) return;   // no microphone is open: nobody hears the person
    const ctx = room.ctx, input = room.input;
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0)).buffer;
    const buffer = await ctx.decodeAudioData(bytes);
    const src = ctx.createBufferSource();
    src.buffer = buffer; src.connect(input);
    room.playing += 1; src.onended = () => { room.playing -= 1; };
    src.start(); room.said.push(performance.now());
  };
  const real = navigator.mediaDevices.getUserMedia.bind(navigator.mediaDevices);
  navigator.mediaDevices.getUserMedia = async (constraints) => {
    if (!constraints || !constraints.audio) return real(constraints);
    if (!room.track) room.track = new AudioContext().createMediaStreamDestination().stream
      .getAudioTracks()[0];
    const stream = new MediaStream([room.track.clone()]);
    room.streams.add(stream);
    return stream;
  };
  // The room is heard in the graph of the context that opens the microphone, not carried from
  // a second context over a MediaStream: two contexts keep their own clocks, and under load
  // the stream between them can drop or pad samples for the rest of the page's life.
  const open = AudioContext.prototype.createMediaStreamSource;
  AudioContext.prototype.createMediaStreamSource = function (stream) {
    if (!room.streams.has(stream)) return open.call(this, stream);
    const input = this.createGain(), hum = this.createConstantSource();
    hum.offset.value = 0; hum.connect(input); hum.start();   // a live microphone never stops
    room.ctx = this; room.input = input;
    return input;
  };
  // The robot's voice as the room's microphone hears it back (an echo, `room.echoGain`, none
  // when null): every sound the page plays in another context is played here too, at the
  // same moment and scaled, and stops when the page stops it.
  room.echoGain = %s; room.echoes = 0;
  const start = AudioBufferSourceNode.prototype.start, stop = AudioBufferSourceNode.prototype.stop;
  AudioBufferSourceNode.prototype.start = function (when, ...rest) {
    start.call(this, when, ...rest);
    if (room.echoGain === null || !room.ctx || this.context === room.ctx || !this.buffer) return;
    const ctx = room.ctx, twin = ctx.createBufferSource(), gain = ctx.createGain();
    twin.buffer = this.buffer; gain.gain.value = room.echoGain;
    twin.connect(gain); gain.connect(room.input);
    twin.start(ctx.currentTime + Math.max(0, (when || 0) - this.context.currentTime));
    this.__echo = twin; room.echoes += 1;
  };
  AudioBufferSourceNode.prototype.stop = function (...args) {
    stop.apply(this, args);
    if (this.__echo) { try { this.__echo.stop(); } catch (_) { /* not started */ } }
  };
})();
"""


def conversation_script(echo_db: float | None = None) -> str:
    """A page init script (Playwright's `add_init_script`) that stands in for a person in a
    room and the microphone that hears it: `window.__room.say(base64 WAV)` makes the person
    say a WAV now into the open microphone, whether the page listens hands-free or by
    push-to-talk. The page opens it with getUserMedia and hears it through its own
    AudioContext's `createMediaStreamSource`, which plays the room in that context. With
    `echo_db`, the microphone also hears what the page plays (the robot's voice) that many dB
    down, as it plays (`window.__room.echoes` counts the sounds fed back)."""
    return CONVERSATION % ("null" if echo_db is None else repr(10 ** (echo_db / 20)))


@contextlib.contextmanager
def conversation_page(app: Any, echo_db: float | None = None) -> Iterator[Any]:
    """A tab of Debian's Chromium on `app` (served on a free localhost port), its microphone a
    room where the test makes the person speak (`conversation_script`, with `echo_db`)."""
    from playwright.sync_api import sync_playwright

    from oxbot.web.server import serving_in_background

    args = [*FLAGS, "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]
    with serving_in_background(app) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=args)
        try:
            tab = browser.new_page()
            tab.add_init_script(conversation_script(echo_db))
            tab.goto(url + "/")
            yield tab
        finally:
            browser.close()


def say(page: Any, wav: bytes) -> None:
    """The person in `conversation_script`'s room says `wav`, and the call returns once they
    have finished speaking."""
    page.evaluate("(b64) => window.__room.say(b64)", base64.b64encode(wav).decode())
    page.wait_for_function("window.__room.playing === 0", timeout=30_000)


def log_items(page: Any) -> list[tuple[str, str, str]]:
    """(speaker, act, text) of every turn in the page's conversation log, oldest first."""
    return [
        tuple(row)
        for row in page.evaluate(
            """() => [...document.querySelectorAll('[data-testid=log] li[data-act]')]
                 .map(li => [li.dataset.speaker, li.dataset.act,
                             li.querySelector('.text').textContent])"""
        )
    ]
