"""What the robot says outside its policy's templates, and how it says a cell.

The policy chooses among the paper's acts and the templates word them (oxbot.dialogue.domain);
the interaction manager (oxbot.robot.manager) also has things to say that no template words:
a problem on the sheet (`PROBLEM_SENTENCES`, as the act PROBLEM), what to do when the camera
cannot show the board (`GUIDANCE_SENTENCES`), which cell a move in words meant (`WHICH_CELL`,
`TAKEN_IN_WORDS`), its own move on real paper, where nobody sees an arm point (`PAPER_MOVE`), a
part lost for good (`STOPPED_SENTENCE`, `LOST_SENTENCES`) and nobody there
(`NOBODY_SENTENCE`), its answers to questions asked in passing (`WHO_STARTS_SENTENCES`;
oxbot.dialogue.asides) and its offer of another game (`OFFER_SENTENCES`).
"""

from __future__ import annotations

from oxbot.dialogue.domain import CLOSING
from oxbot.game.board import COLUMN_NAMES, PLURALS, ROBOT, ROW_NAMES, SIZE, USER, Ending, symbol_of
from oxbot.robot.bus import Bus
from oxbot.robot.messages import DialogueAct, DialogueEnded, Utterance

PROBLEM_SENTENCES = {
    "occupied_cell": "That cell is already taken. Please draw in an empty one.",
    "two_new_symbols": "I see two new symbols at once. Please draw one at a time.",
    "wrong_symbol": "You draw {person} and I draw {robot}.",
    "out_of_turn": "Please wait, it is my turn.",
    "not_started": "We have not started a game yet.",
    "game_over": "The game is over.",
    "unclear_symbol": "I cannot tell what is in {cell}. If it is your move, please draw a "
    "whole {shape}.",
}
"""What the robot says (as the act PROBLEM, not one the policy chooses) about an impossible
drawing, by the tracker's or the manager's problem kind."""
SHAPES = {"cross": "cross, two strokes crossing like an X", "circle": "circle, one closed loop"}
"""The person's symbol as `unclear_symbol` describes it: a plus or an arc is not one."""
GUIDANCE_SENTENCES = {
    "no_grid": "I cannot see the grid. Please hold the camera over the whole sheet.",
    "off_edge": "I can see only part of the sheet. Please move the camera so that I see all of it.",
    "too_close": "The camera is too close. Please hold it a little higher.",
    "too_dark": "It is too dark for me to see the sheet. Please turn on a light.",
    "blurred": "The picture is blurred. Please hold the camera still.",
    "hand": "A hand is in the way. Please take it off the sheet.",
}
"""What the robot says when its camera cannot show it the board (by the guidance's kind,
`oxbot.perception.guidance`), only while it waits for the person's drawing: at other times the
page shows it, and a stale instruction is worse than none."""
PAPER_MOVE = "I take {cell}."
"""What the robot says for its GameMove on real paper, where nobody sees an arm point."""
STOPPED_SENTENCE = "Sorry, my {part} stopped working, so we have to stop here. Goodbye."
"""The robot's goodbye when a part the game needs is lost for good (as the act CLOSING)."""
NOBODY_SENTENCE = "Nobody seems to be there, so I'll stop here. Goodbye."
"""The robot's goodbye (as the act CLOSING) after `give_up_after` unanswered questions."""
LOST_SENTENCES = {"hearing": "Sorry, my hearing has stopped working. Please type your answers."}
"""What the robot tells the person when a part the game can do without is lost, by part."""
WHICH_CELL = "Which cell do you mean? Say it like top left, the middle, or number five."
"""What the robot asks (as the act PROBLEM) when the person seems to name their cell in words
but not surely enough to play it (`speech.min_move_confidence`), or among other words."""
TAKEN_IN_WORDS = "{cell} is already taken. Please pick an empty cell."
"""What the robot says (as the act PROBLEM) to a move in words on an occupied cell."""
WHO_STARTS_SENTENCES = {
    "robot": "I start this time: I draw {robot}, and you draw {person}.",
    "person": "You start this time: you draw {person}, and I draw {robot}.",
    "your_turn": "It's your turn: please draw a {symbol}.",
    "my_turn": "It's my turn.",
}
"""The robot's answer (as the act ANSWER) to "who starts?": before a game, who will; during
one, whose turn it is."""
RULES_SENTENCE = (
    "We take turns to draw in the grid: you draw {person}, I draw {robot}. Three in a row wins."
)
"""The robot's answer (as the act ANSWER) to "how do you play?" or "what are the rules?"."""
OFF_TOPIC_SENTENCE = "Sorry, I only know about noughts and crosses."
"""The robot's answer (as the act ANSWER) to a question it does not understand ("are you a
robot?"), instead of saying it did not catch words it heard clearly."""
HOLD_SENTENCE = "Sure, take your time."
"""The robot's answer (as the act ANSWER) to "wait" or "hold on": it then waits as long as for
an answer to a question."""
AFTER_GOODBYE = 'That game is over. Say "one more game" to play again.'
"""What the robot says (as the act PROBLEM) to words after its goodbye that ask for nothing it
can do (a goodbye, thanks or a no get no answer)."""
OFFER_SENTENCES = (
    "Would you like another game?",
    "Shall we play again?",
    "How about another game?",
)
"""What the robot asks after a game, before its goodbye (as the act OFFER_ANOTHER)."""
AFTER_ALL_SENTENCE = "Do you want to play after all?"
"""What the robot asks (as the act AFTER_ALL) when "Okay, maybe another time." is answered with
a bare yes."""
STOP_QUESTION_SENTENCE = "Do you want to stop?"
"""What the robot asks (as the act STOP_QUESTION) when it heard a stop mid-game too unsurely to
let the game go, instead of asking for the person's move as if they had said nothing."""
YES_QUESTION_SENTENCE = "Sorry, was that a yes?"
"""What the robot asks (as the act YES_QUESTION) when it heard a yes to playing too unsurely to
start a game on, instead of asking the whole question again."""


def say_goodbye(bus: Bus, part: str, result: Ending | None) -> None:
    """The game ends in words because `part`, which the game needs, stopped for good."""
    sentence = STOPPED_SENTENCE.format(part=part)
    bus.publish(DialogueAct(speaker="sys", act=CLOSING, text=sentence))
    bus.publish(Utterance(text=sentence, act=CLOSING))
    bus.publish(DialogueEnded(outcome=result))


def symbol_names(robot_starts: bool) -> dict[str, str]:
    """What the sentences above fill in for a game: `person` and `robot` (their symbols in the
    plural), the person's `symbol` and its `shape` as `unclear_symbol` describes it."""
    person, robot = symbol_of(USER, robot_starts), symbol_of(ROBOT, robot_starts)
    return {
        "person": PLURALS[person],
        "robot": PLURALS[robot],
        "symbol": person,
        "shape": SHAPES[person],
    }


def cell_in_words(cell: int) -> str:
    """A cell as a person says it: "the upper left", "the middle"."""
    row, column = ROW_NAMES[cell // SIZE], COLUMN_NAMES[cell % SIZE]
    return "the middle" if row == column == "middle" else f"the {row} {column}"


def spoken(text: str) -> str:
    """A template's words without its bracketed drawing tag: what the voice says."""
    return " ".join(text.split("[", 1)[0].split())
