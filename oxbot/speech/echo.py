"""The robot's own voice in the person's microphone, modelled and taken out, so that the robot
can listen while it speaks and never takes itself for the person.

The listener knows what the robot says (each sentence's audio, as the page or the terminal
plays it) and when. A player that says where in the stream it began each sentence (the page
does) has it placed there, on one timeline: a new utterance cuts off what played before it,
and the echo's path, found once, is the room's and stays, fitted again on each new sentence
alone once `SENTENCE_HEARD` of it is heard (a player's marks are a few milliseconds off, and
a path 10 ms off leaves most of the echo) and changed only by a better fit. Otherwise the
first sentence is placed where the stream was when its SpeakingStarted came, each further
sentence right after the one before (or where the stream was when it came, if later), and the
path is found again for each utterance. What reaches the microphone is modelled as that audio
delayed and scaled, one delay and one gain, found by cross-correlation over
`MIN_DELAY`..`MAX_DELAY` once `ESTIMATE_AFTER` seconds of it can have been heard, and found
again on its latest `WINDOW` seconds as more comes. A browser's or a sound card's echo
canceller takes out most of a real room's echo before this; this takes out what is played
straight into the microphone, and tells what is left.

The residual (the microphone less the modelled echo) is what the person said over the robot. A
frame of it counts only where it is `ECHO_MARGIN` times louder than the echo it could be the
leftover of, and above `FLOOR_DBFS` (`EchoCanceller.separate`): the rest is silenced for a
voice activity detector, so that it hears the person and not the robot.
"""

from __future__ import annotations

import numpy as np

from oxbot.speech.audio import RATE

MIN_DELAY = -0.3
"""Seconds: the echo may begin this long before the stream's place at SpeakingStarted (a page
sends its microphone in pieces, so what the listener has heard lags what the page plays)."""
MAX_DELAY = 0.8
"""Seconds: the latest the echo may begin after it (decoding, a player's output)."""
PLACED_DELAYS = (-0.05, 0.4)
"""Seconds: where the echo may begin from where a player said it began a sentence (its output's
and the microphone's latency; a Bluetooth headset's is the longest)."""
MAX_GAIN = 4.0
"""An echo 12 dB louder than the robot's audio is no echo: a path found so is a chance match."""
ESTIMATE_AFTER = 0.5
"""Seconds of stream heard since the robot's audio was placed before its delay and gain are
first estimated; until then the stream is not listened to."""
MIN_CORRELATION = 0.3
"""A delay whose normalised correlation is below this finds no echo: the gain is 0."""
SURE_CORRELATION = 0.6
"""Before the latest echo can have shown, a delay is taken only this surely."""
SENTENCE_HEARD = 0.3
"""Seconds of a placed sentence heard before its path is estimated on it alone."""
BETTER_BY = 0.05
"""A placed player's path is changed only by one whose correlation is this much higher on the
same window (the person talking over the robot lowers both)."""
WINDOW = 2.0
"""Seconds of the robot's latest audio the delay and gain are estimated on, again every 0.5 s."""
ECHO_MARGIN = 2.0
"""A frame is surely the person when its residual is this many times louder (in RMS) than the
modelled echo it could be the leftover of: 6 dB, more than a path misjudged by a few samples
leaves."""
FLOOR_DBFS = -45.0
"""A residual frame below this level is silence (what an echo canceller leaves of the robot)."""
FRAME = 512
"""Samples of one level decision: the VAD's frame at 16 kHz."""
MIC_KEPT = WINDOW + MAX_DELAY - MIN_DELAY + 0.5
"""Seconds of the microphone kept for the estimate."""


class EchoCanceller:
    """The robot's speech as a reference on the microphone stream's samples, its echo path
    (`delay`, `gain`), and the residual. Positions count the stream's samples from its start
    (the listener's count)."""

    def __init__(self, rate: int = RATE) -> None:
        self.rate = rate
        self._reference = np.zeros(0, np.float64)
        self._start = 0  # where the reference's first sample was placed
        self._mic = np.zeros(0, np.float64)
        self._mic_start = 0  # the stream position of self._mic[0]
        self._kept_before = int(-MIN_DELAY * rate) + FRAME
        self.delay: int | None = None
        """Samples from the reference's place to its echo (None: not estimated yet)."""
        self.gain = 0.0
        self.correlation = 0.0
        self._estimated_at = 0
        self._cut_at: int | None = None
        self._sentence_at = 0  # where in the reference the latest placed sentence begins
        self._sentence_due: int | None = None  # heard this far, its path is estimated on it
        self.placed = False
        """Whether a player says where it began each sentence (`speak`'s `placed`)."""

    # --- what the robot says ---

    def speak(self, samples: np.ndarray, position: int, first: bool, placed: bool = False) -> None:
        """A sentence of the robot's audio (16 kHz int16) came when the stream was at `position`:
        the first of an utterance replaces what was playing, a further one follows it. `placed`:
        the player began it at `position` exactly; what played before it stays up to there, and
        the echo's path, once found, is kept."""
        audio = samples.astype(np.float64)
        self.placed = self.placed or placed
        # a new utterance where no echo was found yet is looked for again, as for a first time
        if placed and len(self._reference) and (self.gain > 0 or not first):
            played = self._reference[: self._played_length()]
            at = position - self._start
            if not first:
                at = max(at, len(played))
            if 0 <= at <= len(played) + MAX_DELAY * self.rate:  # its echo may still sound
                gap = np.zeros(max(0, at - len(played)))
                self._reference = np.concatenate([played[:at], gap, audio])
                self._cut_at, self._sentence_at = None, at
                self._sentence_due = at + max(self.delay or 0, 0) + int(SENTENCE_HEARD * self.rate)
                return
            if self.gain > 0:  # long after: a new timeline, on the path found
                self._reference, self._start, self._cut_at = audio, position, None
                self._estimated_at = self._sentence_at = 0
                self._sentence_due = None  # the old timeline's; the first estimate comes soon
                return
        if first or not len(self._reference):
            kept = self._mic[-self._kept_before :] if len(self._mic) else self._mic
            self._mic_start += len(self._mic) - len(kept)
            self._mic = kept.copy()
            self._reference, self._start = audio, position
            self.delay, self.gain, self.correlation = None, 0.0, 0.0
            self._estimated_at, self._cut_at, self._sentence_at = 0, None, 0
            self._sentence_due = None
            return
        gap = max(0, position - (self._start + len(self._reference)))
        self._sentence_at = len(self._reference) + gap
        self._reference = np.concatenate([self._reference, np.zeros(gap), audio])

    def cut(self, position: int) -> None:
        """The robot was cut short at `position`: its audio stops soon after."""
        self._cut_at = position

    def end(self) -> int:
        """Where the robot's audio, as modelled, has ended in the stream (its echo's last
        sample, at the latest delay until the delay is known)."""
        length = self._played_length()
        delay = self.delay if self.delay is not None else int(self._delays()[1] * self.rate)
        return self._start + max(0, length) + delay

    def _played_length(self) -> int:
        """Samples of the reference that play: all of it, or up to soon after a cut."""
        if self._cut_at is None:
            return len(self._reference)
        return min(len(self._reference), self._cut_at - self._start + int(0.25 * self.rate))

    def active(self, position: int, tail: float) -> bool:
        """Whether the robot's echo may be in the stream at `position` (or `tail` s after)."""
        return len(self._reference) > 0 and position < self.end() + int(tail * self.rate)

    # --- what the microphone hears ---

    def hear(self, mic: np.ndarray, position: int) -> None:
        """The stream's samples from `position` on (keeps what the estimate needs)."""
        if not len(self._mic):
            self._mic_start = position
        elif self._mic_start + len(self._mic) != position:  # a gap: start the record again
            self._mic, self._mic_start = np.zeros(0, np.float64), position
        self._mic = np.concatenate([self._mic, mic.astype(np.float64)])
        if len(self._mic) > (kept := int(MIC_KEPT * self.rate)):
            self._mic_start += len(self._mic) - kept
            self._mic = self._mic[-kept:]
        if not len(self._reference):
            self._mic = self._mic[-self._kept_before :]
            self._mic_start = position + len(mic) - len(self._mic)
            return
        heard = position + len(mic) - self._start
        due = heard >= ESTIMATE_AFTER * self.rate and heard - self._estimated_at >= 0.2 * self.rate
        again = heard - self._estimated_at >= 0.5 * self.rate
        if self._sentence_due is not None and heard >= self._sentence_due:
            again, self._sentence_due = True, None  # a new sentence: its own path, soon
        if due if self.delay is None else again:
            self._estimate(heard)

    def _estimate(self, heard: int) -> None:
        lo, hi = (int(d * self.rate) for d in self._delays())
        # the last WINDOW seconds of what can have been heard: a player that drifts (a busy
        # machine's audio) is followed
        end = min(len(self._reference), max(0, heard - max(lo, 0)))
        # ... and heard since the microphone's record begins (a player may say it began a
        # sentence before the stream did)
        r0 = max(0, end - int(WINDOW * self.rate), self._mic_start - self._start - lo)
        # ... and of the latest placed sentence alone, once enough of it can be heard: a
        # player's marks of two sentences may be a few milliseconds apart from the truth, and a
        # window over both would fit neither
        if self.placed and end - self._sentence_at >= SENTENCE_HEARD * self.rate:
            r0 = max(r0, self._sentence_at)
        reference = self._reference[r0:end]
        offset = self._start + r0 - self._mic_start  # the window's place in self._mic
        if len(reference) < FRAME or float(reference @ reference) <= 0:
            if self.delay is None and heard >= len(self._reference) + hi:
                self.delay, self.gain, self.correlation = 0, 0.0, 0.0  # none to look for
            return
        # mic[offset + lag + i] ~ gain * reference[i], for lags lo..hi
        first = max(0, offset + lo)
        segment = self._mic[first : offset + hi + len(reference)]
        n = len(segment) + len(reference)
        size = 1 << (n - 1).bit_length()
        corr = np.fft.irfft(
            np.fft.rfft(segment, size) * np.conj(np.fft.rfft(reference, size)), size
        )
        lags = np.arange(first - offset, first - offset + len(segment) - FRAME + 1)
        lags = lags[(lags >= lo) & (lags <= hi)]
        if not len(lags):
            return
        shifts = lags + offset - first
        energy = np.concatenate([[0.0], np.cumsum(segment**2)])
        ends = np.minimum(shifts + len(reference), len(segment))
        overlap = ends - shifts
        window = energy[ends] - energy[shifts]
        ref_energy = np.concatenate([[0.0], np.cumsum(reference**2)])[overlap]
        score = corr[shifts] / np.sqrt(np.maximum(window * ref_energy, 1e-9))
        best = int(np.argmax(score))
        self._estimated_at = heard
        correlation = float(score[best])
        gain = float(corr[shifts[best]] / max(ref_energy[best], 1e-9))
        if gain > MAX_GAIN:
            correlation = 0.0
        # the latest echo has shown
        settled = heard >= (self._delays()[1] + ESTIMATE_AFTER) * self.rate
        if self.delay is None and correlation < (MIN_CORRELATION if settled else SURE_CORRELATION):
            if settled:  # no echo to take out (a canceller took it, the sound is off)
                self.delay, self.gain, self.correlation = 0, 0.0, correlation
            return  # else more of it is waited for: a part of an echo can match elsewhere
        # the path found before stands against a weaker match (the person over the robot); a
        # placed player's is the room's, changed only by a sure one that fits this window
        # better than it does
        if self.delay is not None and correlation < (
            SURE_CORRELATION if self.placed and self.gain > 0 else MIN_CORRELATION
        ):
            return
        if self.placed and self.gain > 0 and self.delay in lags:
            kept = float(score[int(np.flatnonzero(lags == self.delay)[0])])
            if correlation < kept + BETTER_BY:
                self.correlation = kept
                return
        self.correlation = correlation
        self.delay = int(lags[best])
        self.gain = gain

    def _delays(self) -> tuple[float, float]:
        """Seconds: the earliest and latest the echo may begin from where its audio is placed."""
        return PLACED_DELAYS if self.placed else (MIN_DELAY, MAX_DELAY)

    def echo(self, position: int, count: int) -> np.ndarray:
        """The modelled echo of stream samples `position`..`position + count`."""
        out = np.zeros(count)
        if self.delay is None or not self.gain:
            return out
        at = position - self._start - self.delay  # index into the reference
        length = self._played_length()
        lo, hi = max(0, at), min(length, at + count)
        if hi > lo:
            out[lo - at : hi - at] = self.gain * self._reference[lo:hi]
        return out

    def separate(self, mic: np.ndarray, position: int) -> tuple[np.ndarray, np.ndarray] | None:
        """`mic` (stream samples from `position`) less the robot's modelled echo, and the same
        with every frame silenced that is not louder than that echo or is under `FLOOR_DBFS`
        (what is surely the person); None while the echo's path is not known yet (nothing can
        be told apart)."""
        if self.delay is None:
            return None
        echo = self.echo(position, len(mic))
        heard = mic.astype(np.float64)
        residual = heard - echo
        floor = 32768 * 10 ** (FLOOR_DBFS / 20)
        surely = residual.copy()
        for at in range(0, len(surely), FRAME):
            part, leak = slice(at, at + FRAME), echo[at : at + FRAME]
            # taken out only where that leaves less: where the audio stopped sooner than
            # modelled (cut short), the echo is not there to take out
            if np.sum(residual[part] ** 2) >= np.sum(heard[part] ** 2):
                residual[part] = surely[part] = heard[part]
            level = np.sqrt(np.mean(surely[part] ** 2))
            if level < floor or level <= ECHO_MARGIN * np.sqrt(np.mean(leak**2)):
                surely[part] = 0.0

        def pcm(x: np.ndarray) -> np.ndarray:
            return np.clip(np.round(x), -32768, 32767).astype(np.int16)

        return pcm(residual), pcm(surely)


__all__ = ["EchoCanceller"]
