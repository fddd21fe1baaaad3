"""The interaction manager says why it plays where it plays: the person opens in a corner, the
robot takes the centre, the person makes two in the top row, and the robot says it blocks them
as it does; the policy's state keeps the template's words."""

from __future__ import annotations

from oxbot.dialogue.domain import INVITATION, MOVE_REQUEST
from oxbot.dialogue.situated import PHRASINGS
from oxbot.robot.messages import DialogueAct

from .helpers import ManagerAtHand


def test_the_robot_says_it_blocks_a_row_as_it_blocks_it():
    hand = ManagerAtHand(robot_starts=False)
    published = hand.bus.subscribe(DialogueAct)
    moves = iter([0, 1])  # a corner, then two in the top row
    for _ in range(40):
        if hand.done or hand.manager.board[2]:
            break
        if hand.last_act in (INVITATION, "Request(repeat)"):
            hand.say("yes let's play")
        elif hand.last_act == MOVE_REQUEST and hand.manager.state.person_to_move:
            hand.draw(next(moves))
        else:
            hand.wait()
    robot_moves = [
        t
        for t in hand.manager.transcript
        if t["act"].startswith("GameMove(") and t["speaker"] == "sys"
    ]
    assert [t["act"] for t in robot_moves] == [
        "GameMove(gridloc=middle)",
        "GameMove(gridloc=upperright)",
    ]
    # the page's log shows what was said, with the move's mark-up; the state keeps the template
    shown = [m.text for m in iter(lambda: published.get(0), None) if m.act == robot_moves[1]["act"]]
    said = shown[0].split(" [", 1)[0]
    assert said in hand.said and "[who=rob" in shown[0]
    assert any(phrase in said for phrase in PHRASINGS["blocks"]), said
    assert robot_moves[1]["text"] != shown[0] and robot_moves[1]["text"].split(" [")[0] in said
