"""A component process killed mid-game and respawned takes the game up again (in one process
here, as oxbot.robot.resync does across processes): the manager replays the dialogue and
carries on from the robot's last act, the eyes hand a respawned manager the move it never got,
and the manager's watch over its parts is bounded."""

from __future__ import annotations

import numpy as np
import pytest

from oxbot.dialogue.domain import (
    FEEDBACK_ACTS,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    game_move_cell,
)
from oxbot.game.board import CELL_NAMES, EMPTY, USER, symbol_of
from oxbot.robot.bus import LocalBus
from oxbot.robot.game_moves import GameMoveComponent
from oxbot.robot.manager import InteractionManagerComponent, Phase
from oxbot.robot.messages import (
    ArmCommand,
    ComponentFailed,
    ComponentJoined,
    DialogueAct,
    GameMove,
    GameState,
    NewGame,
)
from oxbot.robot.resync import catch_up, current_game, with_the_visit
from oxbot.robot.session import shared_policy
from oxbot.robot.zenoh_bus import MAX_WATCHED_CHANGES, PartsWatcher, Peer
from tests.robot.helpers import ManagerAtHand, wait_for

PREFER = (4, 0, 2, 6, 8, 1, 3, 5, 7)

STAGES = {
    "greeting": lambda act, hand: act == GREETING,
    "invitation": lambda act, hand: act == INVITATION,
    "your move": lambda act, hand: act == MOVE_REQUEST,
    "after the robot's move": lambda act, hand: game_move_cell(act) is not None,
    "feedback": lambda act, hand: act in FEEDBACK_ACTS.values(),
}
"""Where in a game the manager's process dies: right after the robot's act."""


def step(hand: ManagerAtHand, move_now: bool = True) -> None:
    """The person's part in the game: a yes to questions, a drawing when asked, else quiet."""
    act = hand.last_act
    if act == INVITATION or act == "Request(repeat)":
        hand.say("yes let's play")
    elif act == MOVE_REQUEST and hand.manager.state.person_to_move and move_now:
        board = hand.manager.board
        hand.draw(next(c for c in PREFER if board[c] == EMPTY))
    else:
        hand.wait()


def respawn(hand: ManagerAtHand, seed: int = 1) -> list[dict]:
    """The manager's process dies; a fresh one on the same bus takes up the game so far (the
    record a component process answers a state query with). Its predecessor's transcript."""
    before = hand.manager.transcript
    fresh = InteractionManagerComponent(
        hand.bus,
        policy=shared_policy(),
        config=hand.manager.config,
        rng=np.random.default_rng(seed),
    )
    hand.manager = fresh
    catch_up("manager", fresh, hand.record.drain())
    hand._settle()
    return before


@pytest.mark.parametrize("stage", STAGES)
def test_a_respawned_manager_takes_up_the_dialogue_and_the_game_finishes(stage):
    hand = ManagerAtHand(robot_starts=False)
    for _ in range(60):
        if STAGES[stage](hand.last_act, hand):
            break
        step(hand)
    else:
        pytest.fail(f"the game never reached {stage}: {hand.said}")
    before = respawn(hand)
    assert hand.manager.transcript[: len(before)] == before  # the dialogue replayed, turn by turn
    for _ in range(60):
        if hand.done:
            break
        step(hand)
    text = "\n".join(hand.said)
    assert hand.done and hand.ended.outcome is not None, text  # the game was played to its end
    assert "stopped working" not in text


def test_a_manager_respawned_before_anyone_heard_a_later_games_first_act_does_not_greet_again():
    hand = ManagerAtHand(robot_starts=False)
    while hand.last_act != INVITATION:
        step(hand)
    first_game = hand.record.drain()
    # the next game, as a component process records it: killed at once, the manager's first
    # act reached nobody, and the NewGame keeps the greeting and introduction it takes up
    new_game = with_the_visit(NewGame(robot_starts=False), first_game)
    assert [act for _, act, _ in new_game.carried] == [GREETING, INTRODUCTION]
    said = {act: text for speaker, act, text in new_game.carried}
    spoken = [m for m in first_game if isinstance(m, DialogueAct)]
    assert said == {m.act: m.text for m in spoken if m.act in (GREETING, INTRODUCTION)}
    assert with_the_visit(new_game, []) == new_game  # a game that names what it takes up
    fresh = InteractionManagerComponent(
        hand.bus, policy=shared_policy(), config=hand.manager.config, rng=np.random.default_rng(3)
    )
    hand.manager = fresh
    catch_up("manager", fresh, [new_game, GameState(board=(0,) * 9, robot_starts=False)])
    hand._settle()
    acts = [t["act"] for t in fresh.transcript if t["speaker"] == "sys"]
    assert acts == [GREETING, INTRODUCTION, INVITATION], acts  # the first two taken up unsaid
    assert len(hand.said) == len(spoken) + 1 and hand.said[-1] not in said.values()


def test_a_manager_respawned_mid_drawing_has_its_move_drawn_and_goes_on():
    hand = ManagerAtHand(robot_starts=True)
    for _ in range(60):
        if game_move_cell(hand.last_act) is not None:
            break
        step(hand)
    cell = game_move_cell(hand.last_act)
    arm = hand.bus.subscribe(ArmCommand)
    respawn(hand)  # no ArmStroke in the record: its arm never started, so it is asked again
    assert [m.where for m in arm.drain()] == [CELL_NAMES[cell]]
    assert hand.manager.phase is Phase.LISTENING  # the arm's ArmDone came: on to the person


def test_a_manager_that_died_before_a_move_reached_it_gets_it_from_the_eyes():
    bus = LocalBus()
    moves = bus.subscribe(GameMove)
    eyes = GameMoveComponent(bus, robot_starts=False)
    eyes.handle(NewGame(robot_starts=False))
    eyes.handle(GameState(board=(0,) * 9, robot_starts=False))
    eyes.tracker.person_drew(4)  # accepted while the manager's process was dead
    eyes.handle(ComponentJoined(component="InteractionManagerComponent", part="mind"))
    got = moves.get(1.0)
    assert got == GameMove(
        who="usr", what="draw", where="middle", symbol=symbol_of(USER, False), stamp=got.stamp
    )
    # a move the manager announced is not handed over again
    eyes.handle(GameState(board=(0, 0, 0, 0, USER, 0, 0, 0, 0), robot_starts=False))
    eyes.handle(ComponentJoined(component="InteractionManagerComponent", part="mind"))
    assert moves.get(0.2) is None


def test_respawned_eyes_know_the_board_and_that_the_game_is_on():
    bus = LocalBus()
    eyes = GameMoveComponent(bus, robot_starts=True)
    game = [
        NewGame(robot_starts=True),
        DialogueAct(speaker="sys", act=GREETING, text="Hello!"),
        DialogueAct(speaker="sys", act=MOVE_REQUEST, text="Your turn."),
        GameState(board=(1, 0, 0, 0, 2, 0, 0, 0, 0), robot_starts=True),
    ]
    catch_up("perception", eyes, game)
    assert eyes.tracker.board[0] == eyes.tracker.robot_symbol
    assert eyes.tracker.board[4] == eyes.tracker.user_symbol
    assert eyes.tracker.playing and eyes.manager_board == game[-1].board
    assert current_game([*game, *game[:1]]) == game[:1]  # a new game starts the record over


class QuietBus:
    """What PartsWatcher needs of a bus: who is up, and where its news goes."""

    def __init__(self, up: list[Peer]) -> None:
        self.up, self.published = up, []

    def alive(self) -> list[Peer]:
        return list(self.up)

    def watch(self, callback) -> None:
        self.callback = callback

    def publish(self, message) -> None:
        self.published.append(message)


def test_the_parts_watchers_queue_is_bounded_and_a_dropped_death_is_still_noticed():
    arm = Peer(name="arm", format="1-x", zid="a1", pid=10)
    bus = QuietBus([arm])
    watcher = PartsWatcher(bus, {"arm": ("ArmComponent", "arm", True)}, rejoin_seconds=60)
    watcher._changed(arm, True)  # not started: nothing is read until the flood is in
    fake = [
        Peer(name="arm", format="1-x", zid=f"f{i}", pid=i) for i in range(3 * MAX_WATCHED_CHANGES)
    ]
    for peer in fake:
        watcher._queue(peer, True)
    watcher._queue(Peer(name="stranger", format="1-x", zid="s", pid=1), True)
    assert watcher._events.qsize() == MAX_WATCHED_CHANGES  # the rest dropped
    bus.up = []  # meanwhile the real arm died, and its change was among the dropped
    watcher._queue(arm, False)
    watcher.start()
    try:
        assert wait_for(lambda: any(isinstance(m, ComponentFailed) for m in bus.published), 10)
    finally:
        watcher.stop()
