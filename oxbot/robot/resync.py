"""What a respawned component process takes up from the game so far (across processes).

A component process killed mid-game takes its state with it. Its successor asks the other
processes for the game so far (`ZenohBus.game_so_far`: NewGame, GameStates, DialogueActs,
ArmStrokes, DialogueEnded) and takes it up here, so that the game goes on:

- the eyes (perception) learn which cells are drawn and whether the game is on;
- the interaction manager replays the dialogue into a fresh `DialogueState` and carries on
  from the robot's last act (`InteractionManagerComponent.resume`); it then announces itself
  (`ComponentJoined`, part "mind"), so that the eyes hand it again a move it never got.

The voice and the arm hold nothing between requests: the manager asks them again what their
predecessor never finished when they rejoin (`ComponentJoined`). The recogniser and the head's
two components hold nothing a game needs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Protocol, runtime_checkable

from oxbot.dialogue.asides import ASIDE_ACTS
from oxbot.dialogue.domain import (
    GREETING,
    INTRODUCTION,
    SYSTEM_ACTS,
    game_move_cell,
    words_of,
)
from oxbot.dialogue.situated import template_in
from oxbot.dialogue.state import DialogueState
from oxbot.game.board import EMPTY, EMPTY_BOARD, ROBOT, USER, cell_index
from oxbot.robot.bus import Component
from oxbot.robot.messages import (
    ArmStroke,
    ComponentJoined,
    DialogueAct,
    DialogueEnded,
    GameState,
    Message,
    NewGame,
)
from oxbot.robot.sentences import spoken


def current_game(history: Sequence[Message]) -> list[Message]:
    """The game under way in `history` (from its last NewGame on), or [] when none is: no game
    started, or the last one ended (DialogueEnded)."""
    starts = [i for i, m in enumerate(history) if isinstance(m, NewGame)]
    game = list(history[starts[-1] :]) if starts else list(history)
    if not game or any(isinstance(m, DialogueEnded) for m in game):
        return []
    return game


def with_the_visit(new_game: NewGame, record: Sequence[Message]) -> NewGame:
    """`new_game` as a record keeps it: with the visit's greeting and introduction (said in
    `record`, the game before, or taken up by it) as the turns it takes up when it names none,
    as the manager does. A manager process respawned before anyone heard its new dialogue's
    first act then knows it greeted, and does not greet again."""
    if new_game.carried:
        return new_game
    said = [t for m in record if isinstance(m, NewGame) for t in m.carried]
    said += [
        (m.speaker, m.act, m.text)
        for m in record
        if isinstance(m, DialogueAct) and m.speaker == "sys"
    ]
    introductions: dict[str, tuple[str, str, str]] = {}
    for turn in said:
        if turn[0] == "sys" and turn[1] in (GREETING, INTRODUCTION):
            introductions.setdefault(turn[1], turn)
    return dataclasses.replace(new_game, carried=tuple(introductions.values()))


def replay_dialogue(
    state: DialogueState,
    game: Sequence[Message],
    templates_for: Callable[[str], Sequence[str]] | None = None,
) -> None:
    """Replay the turns of `game` (DialogueActs, in order) into a fresh `state`.

    The person's words come back as the transcript has them, understood as their act with
    full confidence (the recogniser's N-best is not kept); turns outside the policy's acts and
    moves that no longer fit the board are kept in the transcript only. The robot's move comes
    back as the template its words were made around (`templates_for(act)`, the domain's), which
    is what the policy's state held (`oxbot.dialogue.situated`)."""
    for message in game:
        if not isinstance(message, DialogueAct):
            continue
        act, text = message.act, message.text
        cell = game_move_cell(act)
        if message.speaker == "sys":
            if cell is not None and templates_for is not None:
                text = _template_of(text, templates_for(act))
            if act in SYSTEM_ACTS and state.can_do(act):
                state.robot_says(act, text)
            else:
                state.robot_informs(act, text)
        elif cell is not None:
            if state.board[cell] == EMPTY and state.person_to_move:
                state.person_says(act, text)
            else:
                state.person_informs(act, text)
        elif text.startswith("[") or act in ASIDE_ACTS.values():
            state.person_informs(act, text)
        else:
            words = tuple((w, 1.0) for w in words_of(text))
            state.person_says(act, text, words, (act, 1.0))


def _template_of(said: str, templates: Sequence[str]) -> str:
    """The template (with its mark-up) that the words `said` were made around, else `said`."""
    spoken_forms = {spoken(t): t for t in templates}
    found = template_in(spoken(said), list(spoken_forms))
    return spoken_forms[found] if found is not None else said


def arm_started(game: Sequence[Message], cell: int) -> bool:
    """Whether the arm drew a stroke in `cell` after the robot's last turn in `game`."""
    turns = [i for i, m in enumerate(game) if isinstance(m, DialogueAct) and m.speaker == "sys"]
    after = game[turns[-1] + 1 :] if turns else game
    return any(isinstance(m, ArmStroke) and cell_index(m.where) == cell for m in after)


@runtime_checkable
class Resumable(Protocol):
    """A component that takes up a game under way (the interaction manager: `resume`)."""

    def resume(self, game: Sequence[Message]) -> None: ...


def catch_up(name: str, component: Component, history: Sequence[Message]) -> None:
    """Component process `name`, joining mid-game, takes up the game `history` holds."""
    game = current_game(history)
    if not game:
        return
    if name == "perception":
        eyes_catch_up(component, game)
    elif name == "manager":
        if not isinstance(component, Resumable):
            raise TypeError(f"the manager's component {component!r} cannot resume a game")
        component.resume(game)
        component.bus.publish(ComponentJoined(component=component.name, part=component.part))


def eyes_catch_up(component: Component, game: Sequence[Message]) -> None:
    """The eyes of a game under way: the cells drawn, who starts, whether the game is on."""
    from oxbot.perception.tracker import MoveTracker
    from oxbot.robot.game_moves import GameMoveComponent, game_started

    assert isinstance(component, GameMoveComponent)
    states = [m for m in game if isinstance(m, GameState)]
    board = states[-1].board if states else EMPTY_BOARD
    starts = states[-1].robot_starts if states else component.tracker.robot_starts
    tracker = MoveTracker(starts, component.config)
    for cell, who in enumerate(board):
        if who == ROBOT:
            tracker.robot_draws(cell)
        elif who == USER:
            tracker.person_drew(cell)
    turns = [m.act for m in game if isinstance(m, DialogueAct) and m.speaker == "sys"]
    if turns:  # a robot that talks: its game is on once it said so
        playing = False
        for act in turns:
            playing = game_started(act, playing)
        tracker.playing = playing
        component._talking = True
    component.tracker = tracker
    component.manager_board = board
