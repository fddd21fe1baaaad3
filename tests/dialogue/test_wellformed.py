"""The rule that the robot never acts on an answer it said it did not catch, nor says it did not
catch an answer it acted on (`acts_on_what_it_did_not_catch`), on hand-written transcripts."""

import pytest

from oxbot.dialogue.wellformed import acts_on_what_it_did_not_catch, check_dialogue


def turns(*lines: str) -> list[dict[str, str]]:
    """`sys Act` / `usr Act` lines as a transcript (the words do not matter here)."""
    return [{"speaker": s, "act": a, "text": ""} for s, a in (line.split(" ", 1) for line in lines)]


START = ("sys Salutation(greeting)", "sys Provide(name)", "sys Request(playGame)")


@pytest.mark.parametrize(
    "after",
    [
        ("usr Confirm(playGame=yes)", "sys Request(repeat)", "sys Request(userGameMove)"),
        ("usr Confirm(playGame=yes)", "sys Request(repeat)", "sys Reply(playGame=yes)"),
        ("usr Confirm(playGame=yes)", "sys Request(repeat)", "sys GameMove(gridloc=middle)"),
        ("usr Reject(playGame=no)", "sys Request(repeat)", "sys Acknowledge(playGame=no)"),
        (
            "usr Reject(playGame=no)",
            "sys Request(repeat)",
            "usr Thank",
            "sys Acknowledge(playGame=no)",
        ),
    ],
    ids=["your turn", "let's play", "a move", "okay another time", "a thank you is no no"],
)
def test_acting_on_an_answer_after_asking_again_about_it_breaks_the_rule(after):
    problem = acts_on_what_it_did_not_catch(turns(*START, *after))
    assert problem is not None and problem.startswith("acts on an answer it said it did not")


@pytest.mark.parametrize(
    "after",
    [
        ("usr Confirm(playGame=yes)", "sys Reply(playGame=yes)", "sys Request(repeat)"),
        ("usr Reject(playGame=no)", "sys Acknowledge(playGame=no)", "sys Request(repeat)"),
        (
            "usr Confirm(playGame=yes)",
            "sys Request(userGameMove)",
            "usr GameMove(gridloc=middle)",
            "sys Request(repeat)",
        ),
    ],
    ids=["after let's play", "after okay another time", "after a drawing"],
)
def test_asking_again_about_an_answer_it_acted_on_breaks_the_rule(after):
    problem = acts_on_what_it_did_not_catch(turns(*START, *after))
    assert problem == "asks again about an answer it acted on"


@pytest.mark.parametrize(
    "after",
    [
        (
            "usr Confirm(playGame=yes)",
            "sys Request(repeat)",
            "usr Confirm(playGame=yes)",
            "sys Reply(playGame=yes)",
        ),
        (
            "usr Reject(playGame=no)",
            "sys Request(repeat)",
            "usr Reject(playGame=no)",
            "sys Acknowledge(playGame=no)",
        ),
        (
            "usr Confirm(playGame=yes)",
            "sys Request(repeat)",
            "sys Request(repeat)",
            "sys Salutation(closing)",
        ),
        (
            "usr Confirm(playGame=yes)",
            "sys Reply(playGame=yes)",
            "usr Unknown",
            "sys Request(repeat)",
        ),
        (
            "usr Confirm(playGame=yes)",
            "sys Request(repeat)",
            "usr GameMove(gridloc=middle)",
            "sys GameMove(gridloc=upperleft)",
        ),
    ],
    ids=["a new yes", "a new no", "asked again, then goodbye", "new words", "a drawing agrees"],
)
def test_a_new_answer_after_asking_again_may_be_acted_on(after):
    assert acts_on_what_it_did_not_catch(turns(*START, *after)) is None


def test_the_rule_reads_the_answers_as_the_robot_understood_them():
    said = turns(
        *START, "usr Confirm(playGame=yes)", "sys Request(repeat)", "sys Reply(playGame=yes)"
    )
    heard_as = [t["act"] for t in said]
    heard_as[3] = "Unknown"  # the yes was not understood: no answer was acted on
    assert acts_on_what_it_did_not_catch(said, heard_as) is None
    assert acts_on_what_it_did_not_catch(said) is not None


def test_a_dialogue_that_breaks_the_rule_is_not_well_formed():
    said = turns(*START, "usr Confirm(playGame=yes)", "sys Request(repeat)")
    said += turns("sys Request(userGameMove)", "sys Salutation(closing)")
    assert check_dialogue(said, None).startswith("acts on an answer it said it did not catch")
