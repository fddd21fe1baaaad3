"""What a study measures on each game, from the messages on the robot's bus.

`measure` turns a game's messages into its metrics; `GameWatcher` is the component that joins a
study session's robot (`Robot(..., joining=[...])`), collects them, and hands the metrics on when
the robot says goodbye (or stops first: the participant left). The metrics, as exported:

- `status`: "ended" (the robot said goodbye) or "left" (the session stopped before); one game
  per session: what follows the goodbye is not measured;
- `outcome`: the robot's side: win, draw, loss, or declined / stopped, none when left;
- `success`: 1 when a game was played to its end (win, draw or loss), the paper's task success;
- `turns`: dialogue acts said by either side; `moves`: the person's moves;
- `duration`: seconds from the robot's first act to the goodbye (or the last act);
- `time_per_move`: mean seconds from the robot's last act before each of the person's moves to
  the move (empty without moves);
- `confidence`: mean confidence of the recogniser's best hypothesis over spoken answers (empty
  when nothing was spoken); `spoken`, `typed`: answers by voice and typed;
- `asked_again`: the robot's `Request(repeat)` acts;
- `corrected`: misunderstandings the person corrected: after the robot took their answer for a
  no or a stop (`Acknowledge(playGame=no)`, `Acknowledge(stop)`), the person's next act was a
  yes (`Confirm(playGame=yes)`) or a move;
- `well_formed`: 1 when `oxbot.dialogue.wellformed.check_dialogue` accepts the transcript, with
  its reason in `problem` otherwise.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from statistics import fmean
from typing import Any

from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    GRANT_REFUSAL,
    GRANT_STOP,
    MOVE_ACT_TYPE,
)
from oxbot.dialogue.wellformed import check_dialogue
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import DialogueAct, DialogueEnded, Message, SpeechHypotheses

log = logging.getLogger(__name__)

GAME_OUTCOMES = ("win", "draw", "loss")


def measure(messages: Sequence[Message], status: str = "ended") -> dict[str, Any]:
    """The metrics of one game (see the module docstring) from its DialogueAct,
    SpeechHypotheses and DialogueEnded messages, in publish order."""
    acts = [m for m in messages if isinstance(m, DialogueAct)]
    heard = [m for m in messages if isinstance(m, SpeechHypotheses)]
    ended = next((m for m in messages if isinstance(m, DialogueEnded)), None)
    outcome = ended.outcome if ended is not None else None
    moves, waits, corrected = 0, [], 0
    last_sys: DialogueAct | None = None
    for act in acts:
        if act.speaker == "sys":
            last_sys = act
            continue
        is_move = act.act.startswith(MOVE_ACT_TYPE)
        if is_move:
            moves += 1
            if last_sys is not None:
                waits.append(act.stamp - last_sys.stamp)
        if last_sys is not None and last_sys.act in (GRANT_REFUSAL, GRANT_STOP):
            corrected += int(act.act == ACCEPT or is_move)
    spoken = [h for h in heard if h.source == "microphone"]
    confidences = [h.nbest[0][1] for h in spoken if h.nbest]
    transcript = [{"speaker": a.speaker, "act": a.act, "text": a.text} for a in acts]
    start = acts[0].stamp if acts else 0.0
    end = ended.stamp if ended is not None else (acts[-1].stamp if acts else 0.0)
    problem = check_dialogue(transcript, outcome) if ended is not None else "left before the end"
    return {
        "status": status,
        "outcome": outcome,
        "success": int(outcome in GAME_OUTCOMES),
        "turns": len(acts),
        "moves": moves,
        "duration": max(0.0, end - start),
        "time_per_move": fmean(waits) if waits else None,
        "confidence": fmean(confidences) if confidences else None,
        "spoken": len(spoken),
        "typed": len(heard) - len(spoken),
        "asked_again": sum(a.speaker == "sys" and a.act == ASK_AGAIN for a in acts),
        "corrected": corrected,
        "well_formed": int(problem is None),
        "problem": problem or "",
        "transcript": json.dumps(transcript),
    }


class GameWatcher(Component):
    """Collects a study session's game and hands its metrics to `on_game` at the goodbye, or
    when the robot stops first (the participant left after the robot's first act).

    One game per session: what follows the goodbye (a "new game" said to the robot while the
    study page moves on) is not measured, so that it can never count as another game."""

    listens_to = (DialogueAct, SpeechHypotheses, DialogueEnded)
    part = "study notes"
    essential = False

    def __init__(
        self, bus: Bus, on_game: Callable[[dict[str, Any]], None], name: str | None = None
    ) -> None:
        super().__init__(bus, name)
        self.on_game = on_game
        self.messages: list[Message] = []
        self.done = False

    def take_over(self, old: Component) -> None:
        assert isinstance(old, GameWatcher)
        self.messages, self.done = list(old.messages), old.done

    def handle(self, message: Message) -> None:
        if self.done:
            return
        self.messages.append(message)
        if isinstance(message, DialogueEnded):
            self._hand_on("ended")

    def stop(self, timeout: float = 2.0) -> None:
        super().stop(timeout)
        if self.abandoned:
            return
        for message in self.waiting():  # a goodbye published just before the robot stopped
            self.handle(message)
        if not self.done and any(isinstance(m, DialogueAct) for m in self.messages):
            self._hand_on("left")

    def _hand_on(self, status: str) -> None:
        messages, self.messages, self.done = self.messages, [], True
        try:
            self.on_game(measure(messages, status))
        except Exception:  # the game goes on; the experimenter sees the log
            log.exception("the study could not keep a game's metrics")
