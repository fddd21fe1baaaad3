"""Recorded dialogues of simulated people, for the project's own tests and benchmarks.

A policy talks with the user simulator of `config` (`InteractiveGameEnv`), and every turn goes
through a real `Recorder` as the robot's bus would carry it: the robot's acts as DialogueAct,
each spoken answer as the recogniser's SpeechHypotheses (the simulator's noisy words with
their confidences) followed by the act it was understood as, the goodbye as DialogueEnded.

    with RecordingStore(folder) as store:
        record_simulated_dialogues(store, load_policy(), population, 200)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import DQNPolicy
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.simulator import UserTurn
from oxbot.game.board import EMPTY_BOARD
from oxbot.recording.recorder import Recorder
from oxbot.recording.store import RecordingStore
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import (
    DialogueAct,
    DialogueEnded,
    GameState,
    SpeechHypotheses,
)


def population(decline: float = 2.0, noise: float = 2.0, base: OxbotConfig | None = None):
    """The default simulated people, declining `decline` times as often (at first and for
    good) and heard with `noise` times the recognition noise."""
    from oxbot.config import with_overrides

    config = base if base is not None else OxbotConfig()
    d = config.dialogue
    return with_overrides(
        config,
        {
            "dialogue": {
                "decline_probability": min(1.0, d.decline_probability * decline),
                "refuse_probability": min(1.0, d.refuse_probability * decline),
                "asr_noise": min(1.0, d.asr_noise * noise),
            }
        },
    )


def record_simulated_dialogues(
    store: RecordingStore,
    policy: DQNPolicy,
    config: OxbotConfig,
    dialogues: int,
    seed: int = 0,
    opponent: str = "random",
) -> list[int]:
    """Record `dialogues` dialogues of `policy` with the people of `config` (who starts
    alternates); the sessions' ids."""
    recorder = Recorder(LocalBus(), store, mode="simulated")
    rng = np.random.default_rng(seed)
    for i in range(dialogues):
        env = InteractiveGameEnv(opponent=opponent, robot_starts=i % 2 == 0, config=config)
        obs, info = env.reset(seed=int(rng.integers(2**31)))
        answers = _listen_to(env)
        recorder.handle(GameState(board=EMPTY_BOARD, robot_starts=env.robot_starts))
        seen, board = 0, EMPTY_BOARD
        done = False
        while not done:
            action = policy.act(obs, info["action_mask"])
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            transcript = env.state.transcript
            understood = env.state.understood_turns
            for turn, act in zip(transcript[seen:], understood[seen:], strict=True):
                _publish(recorder, turn, act, answers)
            seen = len(transcript)
            if env.board != board:  # the manager announces each change (an empty one: a new game)
                board = env.board
                recorder.handle(GameState(board=board, robot_starts=env.robot_starts))
        # as the robot saw it, like the interaction manager's DialogueEnded
        recorder.handle(DialogueEnded(outcome=env.state.ending))
    return recorder.sessions


def _listen_to(env: InteractiveGameEnv) -> list[UserTurn]:
    """The simulated person's answers, as they are given (what the recogniser heard)."""
    simulator = env._simulator  # the person of this dialogue; its answers carry the heard words
    heard: list[UserTurn] = []
    respond = simulator.respond

    def respond_and_keep(*args: Any) -> UserTurn:
        answer = respond(*args)
        heard.append(answer)
        return answer

    simulator.respond = respond_and_keep  # type: ignore[method-assign]
    return heard


def _publish(recorder: Recorder, turn: dict[str, str], act: str, answers: list[UserTurn]) -> None:
    if turn["speaker"] == "sys":
        recorder.handle(DialogueAct(speaker="sys", act=turn["act"], text=turn["text"]))
        return
    answer = next((a for a in answers if a.text == turn["text"]), None)
    if answer is not None:
        answers.remove(answer)
    if answer is None or not answer.heard:  # nothing heard: a drawing without words
        recorder.handle(DialogueAct(speaker="usr", act=act, text=turn["text"]))
        return
    text = " ".join(w for w, _ in answer.heard)
    confidence = float(np.mean([c for _, c in answer.heard]))
    recorder.handle(
        SpeechHypotheses(nbest=((text, confidence),), source="microphone", words=answer.heard)
    )
    recorder.handle(DialogueAct(speaker="usr", act=act, text=text))
