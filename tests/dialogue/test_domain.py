import re
from collections import Counter

import pytest

from oxbot.dialogue.domain import (
    FEEDBACK_ACTS,
    GAME_MOVES,
    PAPER_ACTS,
    SYSTEM_ACTS,
    load_domain,
    words_of,
)
from oxbot.errors import DataError
from tests.dialogue.conftest import replace_line


def test_shipped_domain_has_varied_seed_dialogues_games_and_refusals():
    domain = load_domain()
    assert len(domain.dialogues) == 20
    feedback = Counter(
        u.act for d in domain.dialogues for u in d if u.act.startswith("Provide(feedback=")
    )
    assert set(feedback) == set(FEEDBACK_ACTS.values())  # robot wins, draws and losses
    games = [d for d in domain.dialogues if any(u.cell is not None for u in d)]
    starters = Counter(next(u.speaker for u in d if u.cell is not None) for d in games)
    assert starters == {"SYS": 9, "USR": 8}
    refusals = [d for d in domain.dialogues if d not in games]
    assert len(refusals) == 3  # no thanks; no twice; maybe later
    assert all("Acknowledge(playGame=no)" in [u.act for u in d] for d in refusals)
    # a no and a stop taken back after the robot let them go: it plays on (19, 20)
    taken_back = [d for d in games if "Acknowledge(playGame=no)" in [u.act for u in d]]
    taken_back += [d for d in games if "Acknowledge(stop)" in [u.act for u in d][:-2]]
    assert len(taken_back) == 2
    moves = {sum(u.cell is not None for u in d) for d in games}
    assert len(moves) >= 3  # games of different lengths
    openings = {tuple(u.act for u in d[:3]) for d in domain.dialogues}
    acceptances = {u.text for d in domain.dialogues for u in d if u.act == "Confirm(playGame=yes)"}
    assert len(openings) >= 3 and len(acceptances) >= 3


def test_every_act_has_templates_and_the_vocabulary_is_under_a_hundred_words():
    domain = load_domain()
    for act in SYSTEM_ACTS:
        assert domain.templates_for(act), act
    assert "I take this one [who=rob what=draw where=middle]" in domain.templates_for(
        "GameMove(gridloc=middle)"
    )
    assert "Provide(feedback=loose)" in SYSTEM_ACTS  # the paper's spelling
    assert len(PAPER_ACTS) == 18 and SYSTEM_ACTS[:18] == PAPER_ACTS
    assert SYSTEM_ACTS[:9] == GAME_MOVES
    assert all(len(domain.templates_for(act)) >= 2 for act in SYSTEM_ACTS)  # varied
    assert 60 <= len(domain.vocabulary) <= 100
    assert {"hello", "oxbot", "turn", "won", "draw", "bye", "pick"} <= set(domain.vocabulary)


def test_words_leave_out_the_drawing():
    assert words_of("I pick this one [who=usr what=draw where=middle]") == [
        "i",
        "pick",
        "this",
        "one",
    ]
    assert words_of("Yes, let's go.") == ["yes", "let's", "go"]


@pytest.mark.parametrize(
    "file,old,new,message",
    [
        (
            "dialogues.txt",
            'SYS:[Provide(name)]"I am oxbot."',
            'SYS:[Provide(name)]"I am oxbot.',
            "malformed line",
        ),
        (
            "dialogues.txt",
            'SYS:[Provide(name)]"I am oxbot."',
            'SYS:[Provide(age)]"I am oxbot."',
            "unknown system act 'Provide(age)'",
        ),
        (
            "dialogues.txt",
            'SYS:[Provide(name)]"I am oxbot."',
            'SYS:[Provide(name)]"I am robby."',
            "'robby' not in the vocabulary",
        ),
        (
            "dialogues.txt",
            "where=lowerright]",
            'SYS:[GameMove(gridloc=middleleft)]"I take this one '
            '[who=rob what=draw where=middleleft]"',
            "already taken",
        ),
        (
            "dialogues.txt",
            'SYS:[Provide(feedback=win)]"Yes, I won."',
            'SYS:[Provide(feedback=draw)]"It is a draw."',
            "does not match the game (win)",
        ),
        (
            "templates.txt",
            'SYS:[Salutation(greeting)]"Hi!"',
            'SYS:[Salutation(hug)]"Hi!"',
            "unknown system act 'Salutation(hug)'",
        ),
        (
            "user_responses.txt",
            "Provide(name) => USR:[Silence]",
            'Provide(name) -> USR:[Silence]""',
            "malformed line",
        ),
        (
            "user_responses.txt",
            "Provide(name) => USR:[Silence]",
            'Provide(name) => USR:[Dance]""',
            "unknown user act 'Dance'",
        ),
    ],
)
def test_a_broken_line_is_reported_with_its_file_and_number(domain_dir, file, old, new, message):
    line = replace_line(domain_dir / file, old, new)
    with pytest.raises(DataError, match=re.escape(message)) as error:
        load_domain(domain_dir)
    if new:  # a removed line cannot be pointed at; the message names the missing act instead
        assert f"{file}:{line}" in str(error.value) or file == "templates.txt"
    else:
        assert file in str(error.value)


def test_an_empty_vocabulary_is_refused(domain_dir):
    templates = domain_dir / "templates.txt"
    lines = [
        line.split("]", 1)[0] + ']""'
        if line.startswith("SYS:") and "[GameMove" not in line
        else line
        for line in templates.read_text().splitlines()
    ]
    lines = [
        'SYS:[GameMove(gridloc=$loc)]"[who=rob what=draw where=$loc]"'
        if "[GameMove" in line
        else line
        for line in lines
    ]
    templates.write_text("\n".join(lines) + "\n")
    (domain_dir / "user_responses.txt").write_text("# nothing\n")
    with pytest.raises(DataError, match=r"vocabulary derived from .* is empty"):
        load_domain(domain_dir)


def test_a_missing_file_is_named(domain_dir):
    (domain_dir / "dialogues.txt").unlink()
    with pytest.raises(DataError, match=r"dialogues\.txt does not exist"):
        load_domain(domain_dir)


def test_an_act_without_a_template_is_reported(domain_dir):
    templates = domain_dir / "templates.txt"
    lines = templates.read_text(encoding="utf-8").splitlines()
    kept = [line for line in lines if not line.startswith("SYS:[Request(repeat)]")]
    templates.write_text("\n".join(kept) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=re.escape("no template for Request(repeat)")):
        load_domain(domain_dir)


def test_an_act_no_seed_dialogue_shows_is_refused(domain_dir):
    dialogues = domain_dir / "dialogues.txt"
    text = dialogues.read_text(encoding="utf-8").replace(
        "Acknowledge(stop)", "Acknowledge(playGame=no)"
    )
    dialogues.write_text(text, encoding="utf-8")
    with pytest.raises(DataError, match=re.escape("shows the robot's Acknowledge(stop)")):
        load_domain(domain_dir)


def test_phrasings_are_read_by_act_and_checked(domain_dir):
    domain = load_domain(domain_dir)
    assert {"sure why not", "yes please"} <= set(domain.phrasings["Confirm(playGame=yes)"])
    assert "no thanks" in domain.phrasings["Reject(playGame=no)"]
    assert sum(len(p) for p in domain.phrasings.values()) >= 400  # hundreds of phrasings
    phrases = domain_dir / "user_phrases.txt"
    phrases.write_text(phrases.read_text(encoding="utf-8") + "\n[Dance]\ncha cha\n")
    with pytest.raises(DataError, match=r"user_phrases.txt:\d+: unknown user act \[Dance\]"):
        load_domain(domain_dir)


@pytest.mark.parametrize(
    "content",
    [
        b"\xff\xfe\x00garbage\x00" * 100,
        b"SYS:[" + b"[" * 100_000 + b']"hello"\n',
        b'SYS:[Greet]"' + b"[who=rob what=draw " * 10_000 + b'"\n',
        b"x" * 1_000_000,
    ],
    ids=["binary", "deep brackets", "many tags", "one long line"],
)
def test_malformed_domain_files_are_data_errors(domain_dir, content):
    (domain_dir / "templates.txt").write_bytes(content)
    with pytest.raises(DataError, match=r"templates\.txt"):
        load_domain(domain_dir)


def test_a_folder_or_unreadable_domain_file_is_a_data_error(domain_dir, monkeypatch):
    (domain_dir / "dialogues.txt").unlink()
    (domain_dir / "dialogues.txt").mkdir()
    with pytest.raises(DataError, match=r"dialogues\.txt is a folder"):
        load_domain(domain_dir)

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(type(domain_dir), "read_text", refuse)
    with pytest.raises(DataError, match=r"templates\.txt cannot be read \(Permission denied\)"):
        load_domain(domain_dir)
