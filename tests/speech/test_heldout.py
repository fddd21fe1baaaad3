"""The held-out listening benchmark's machinery: its data parse, its scoring counts what it says,
its voices and recordings reach the recogniser. No accuracy thresholds: those belong to the
understanding, which changes; bench/bench_speech.py measures it."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.errors import DataError
from oxbot.speech.audio import RATE
from oxbot.speech.evaluation import (
    CLEAN,
    CONDITIONS,
    HELD_OUT_ESPEAK,
    HELD_OUT_FLITE,
    INTENTS,
    UNSURE,
    VOICES,
    Condition,
    Trial,
    intent_of_act,
    listening_test,
    read_labelled_phrases,
    recording_test,
    speech_commands,
)
from oxbot.speech.speech_commands import speaker_of, split_of

BENCH_DATA = Path(__file__).parents[2] / "bench" / "data"
HELD_OUT = BENCH_DATA / "held_out_answers.txt"
SPEECH_COMMANDS = BENCH_DATA / "speech_commands"


@pytest.fixture(scope="module")
def classifier():
    return UserActClassifier(load_domain())


def trial(expected: str, act: str) -> Trial:
    return Trial("en-us", CLEAN, "words", expected, "heard", act, act, 0.01, 1.0)


def test_held_out_phrases_parse_with_known_labels_and_enough_answers():
    phrases = read_labelled_phrases(HELD_OUT)
    labels = list(phrases.values())
    assert set(labels) == set(INTENTS)
    assert labels.count("accept") >= 60 and labels.count("decline") >= 60
    assert all(phrase == " ".join(phrase.split()) and phrase for phrase in phrases)


def test_labelled_phrases_refuse_unknown_labels_and_repeats(tmp_path):
    bad_label = tmp_path / "label.txt"
    bad_label.write_text("# a comment\n\naccept  sure\nmaybe  perhaps\n")
    with pytest.raises(DataError, match=r"label.txt:4: unknown label 'maybe'"):
        read_labelled_phrases(bad_label)
    repeated = tmp_path / "repeat.txt"
    repeated.write_text("accept\tsure thing\ndecline  Sure  thing\n")
    with pytest.raises(DataError, match="already on line 1"):
        read_labelled_phrases(repeated)


def test_held_out_voices_are_none_of_the_tuning_voices():
    names = [voice.removeprefix("flite:").partition("@")[0] for voice in HELD_OUT_ESPEAK]
    assert not set(names) & set(VOICES)
    assert all(voice.startswith("flite:") for voice in HELD_OUT_FLITE)


def test_accept_read_as_any_decline_is_a_flip_and_unknown_is_not():
    later = trial("accept", "Reject(playGame=later)")
    assert later.flip and not later.right and not later.unsure
    assert trial("decline", "Confirm(playGame=yes)").flip
    asked_again = trial("accept", "Unknown")
    assert asked_again.unsure and not asked_again.flip and not asked_again.right
    elsewhere = trial("decline", "Salutation(closing)")
    assert not (elsewhere.flip or elsewhere.unsure or elsewhere.right)
    assert trial("decline", "Reject(playGame=later)").right
    assert trial("Reject(playGame=no)", "Reject(playGame=later)").right  # an act as expected
    assert trial("unrelated", "Silence").right and not trial("unrelated", "Acknowledge").right
    assert trial("Acknowledge", "Acknowledge").right and not trial("Acknowledge", "Other").right


def test_acts_are_read_as_intents_generously():
    assert intent_of_act("Confirm(playGame=yes)") == "accept"
    assert intent_of_act("Reject(playGame=later)") == "decline"
    assert intent_of_act("Unknown") == intent_of_act("Silence") == UNSURE
    assert intent_of_act("Salutation(greeting)") == "greet"
    assert intent_of_act("Salutation(closing)") == "goodbye"
    assert intent_of_act("Request(newGame)") == "new_game"
    assert intent_of_act("Request(whoStarts)") == "who_starts"
    assert intent_of_act("Inform(userFirst)") == "i_start"
    assert intent_of_act("GameMove(gridloc=middle)") == "move"
    assert intent_of_act("Acknowledge") == "acknowledge"


def test_conditions_add_silence_noise_or_quieten_as_named():
    speech = (np.sin(np.arange(RATE) / 5) * 10000).astype(np.int16)
    by_name = {c.name: c for c in CONDITIONS}
    zeros = by_name["lead zeros"].apply(speech, np.random.default_rng(1))
    lead = len(zeros) - len(speech)
    assert 0.5 * RATE <= lead <= 1.5 * RATE and not zeros[:lead].any()
    floor = by_name["lead floor"].apply(speech, np.random.default_rng(1))
    assert 5 < floor[: len(floor) - len(speech)].std() < 40
    quiet = by_name["quiet"].apply(speech, np.random.default_rng(1))
    assert abs(20 * np.log10(np.abs(quiet).max() / 32767) + 30) < 0.1
    noisy = Condition("10 dB", snr_db=10.0)
    assert np.array_equal(
        noisy.apply(speech, np.random.default_rng(2)), noisy.apply(speech, np.random.default_rng(2))
    )


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed (make setup)")
def test_a_flite_voice_is_decoded_to_something(classifier):
    (heard,) = listening_test({"yes please": "accept"}, classifier, ["flite:slt@1.1"], [CLEAN])
    assert heard.heard and heard.act != "Silence"
    assert heard.audio_seconds > 0.5 and heard.voice == "flite:slt@1.1"


@pytest.mark.skipif(
    not any(SPEECH_COMMANDS.glob("*/*.wav")),
    reason="the Speech Commands WAVs are not here (bench/data/speech_commands/SOURCES.md)",
)
def test_speech_commands_recordings_are_held_out_and_decoded_to_something(classifier):
    recordings = speech_commands(SPEECH_COMMANDS)
    assert {r.expected for r in recordings} == {"accept", "decline"}
    assert all(split_of(speaker_of(r.path.name)) != "testing" for r in recordings)
    first_yes = next(r for r in recordings if r.words == "yes")
    first_no = next(r for r in recordings if r.words == "no")
    trials = recording_test([first_yes, first_no], classifier, [CLEAN])
    assert [t.voice for t in trials] == [first_yes.speaker, first_no.speaker]
    assert all(t.voice.startswith("sc:") and t.heard for t in trials)
    assert all(0.5 < t.audio_seconds <= 1.01 for t in trials)
