"""The robot on real paper: it says where it plays, and what to do when its camera
cannot show it the board, only while it waits for the person's drawing (real components)."""

import time

from oxbot.config import load_config
from oxbot.robot.messages import BoardProblem, DialogueAct
from oxbot.robot.session import Robot
from tests.robot.helpers import collect

CONFIG = load_config(None, ["robot.speed_factor=8", "game.robot_starts=true"])


def test_on_paper_the_robot_names_its_cell_and_says_what_to_do_when_it_cannot_see():
    with Robot(CONFIG, seed=3) as robot:
        acts = robot.bus.subscribe(DialogueAct)
        robot.paper(True)
        robot.bus.publish(BoardProblem(reason="dark", kind="too_dark"))  # not in a game: silent
        collect(acts, lambda m: m.act == "Request(playGame)", seconds=20)
        robot.say("yes let's play")
        got = collect(acts, lambda m: m.act == "Request(userGameMove)", seconds=20)
        time.sleep(1.0)  # "Your move." said: the robot listens
        robot.bus.publish(BoardProblem(reason="dark", kind="too_dark"))
        got += collect(acts, lambda m: m.act == "Inform(problem)", seconds=5)
        time.sleep(0.2)
        got += acts.drain()
    moves = [m for m in got if m.act.startswith("GameMove(")]
    assert moves and moves[0].text.startswith("I take the ")
    assert "[who=rob what=draw where=" in moves[0].text
    told = [m.text for m in got if m.act == "Inform(problem)"]
    assert told == ["It is too dark for me to see the sheet. Please turn on a light."]
