"""`oxbot learn agent` on recorded dialogues of simulated people, with a tiny budget."""

from __future__ import annotations

import json

import pytest
import torch
from typer.testing import CliRunner

from oxbot.cli import app
from oxbot.dialogue.agent import load_policy
from oxbot.recording import RecordingStore
from oxbot.recording.agent import (
    expected_confidence,
    fit_person,
    noise_for,
    repeated_questions,
    shipped_agent_config,
)
from oxbot.testing.simulated_people import population, record_simulated_dialogues


@pytest.fixture(scope="module")
def dialogues(tmp_path_factory):
    torch.set_num_threads(1)
    folder = tmp_path_factory.mktemp("dialogues")
    with RecordingStore(folder) as store:
        record_simulated_dialogues(store, load_policy(), population(), 120, seed=1)
    return folder


def test_noise_is_recovered_from_the_mean_word_confidence():
    for noise in (0.0, 0.2, 0.4, 0.8):
        assert noise_for(expected_confidence(noise)) == pytest.approx(noise, abs=1e-6)


def test_the_fitted_person_hears_as_noisily_and_says_no_as_often_as_the_recorded_one(dialogues):
    with RecordingStore(dialogues) as store:
        recorded = store.dialogues()
        assert len(recorded) == 120
        person = fit_person(recorded, shipped_agent_config().dialogue)
    p = person.probabilities
    assert p["asr_noise"] == pytest.approx(0.4, abs=0.05)  # 2x the default 0.2
    # who says no at first (0.2 + 0.1): those the robot let go are counted as refusing
    assert p["refuse_probability"] + p["decline_probability"] == pytest.approx(0.3, abs=0.1)
    assert person.spoken_words > 500 and person.phrasings


def test_repeated_questions_count_asking_again():
    sys = lambda act: {"speaker": "sys", "act": act, "text": ""}  # noqa: E731
    usr = {"speaker": "usr", "act": "Unknown", "text": "hmm"}
    talk = [sys("Request(playGame)"), usr, sys("Request(repeat)"), usr, sys("Request(playGame)")]
    assert repeated_questions(talk) == 1
    assert repeated_questions([sys("Request(playGame)"), sys("Request(playGame)")]) == 1
    assert repeated_questions([sys("Salutation(greeting)"), sys("Provide(name)")]) == 0


def test_learn_agent_measures_before_and_after_and_writes_the_policy(dialogues, tmp_path):
    out = tmp_path / "learned"
    result = CliRunner().invoke(
        app,
        [
            "learn", "agent", "--data-dir", str(dialogues), "--out", str(out),
            "--steps", "300", "--games", "40", "--chunks", "2", "--select-games", "40",
            "--quiet",
        ],
    )  # fmt: skip
    refused = (out / "learn_agent.refused.json").exists()
    assert refused != (out / "learn_agent.json").exists()  # one or the other, never over it
    metrics = json.loads(
        (out / ("learn_agent.refused.json" if refused else "learn_agent.json")).read_text()
    )
    assert metrics["before"]["dialogues"] == metrics["after"]["dialogues"] == 80
    assert metrics["trained_config"]["dialogue"]["asr_noise"] == pytest.approx(0.4, abs=0.05)
    assert metrics["trained_config"]["agent"]["total_steps"] == 300
    assert "repeated questions per dialogue" in result.output
    assert [p["steps"] for p in metrics["pieces"]] == [150, 300]
    assert bool(metrics["refused"]) == refused
    if metrics["refused"]:  # a 300-step fine-tune may be worse: then nothing is shipped
        assert result.exit_code != 0 and not (out / "agent.pt").exists()
        assert "kept the policy" not in result.output and "refused" in result.output
    else:
        assert result.exit_code == 0, result.output
        policy = load_policy(out / "agent.pt")
        assert policy.metadata["learn_config"]["steps"] == 300
        assert len(policy.metadata["learned_from_sessions"]) == 120


def test_the_fitted_phrasings_are_the_ones_heard_and_the_person_says_them_so_often(dialogues):
    import numpy as np

    from oxbot.dialogue.domain import ACCEPT
    from oxbot.dialogue.model import shipped_dialogue_model
    from oxbot.dialogue.simulator import UserSimulator, phrasings_of

    domain = shipped_dialogue_model().domain
    with RecordingStore(dialogues) as store:
        person = fit_person(store.dialogues(), shipped_agent_config().dialogue)
    weights = person.phrasing_weights
    assert ACCEPT in weights
    assert set(weights[ACCEPT]) <= set(phrasings_of(domain)[ACCEPT])
    overrides = person.dialogue_config(shipped_agent_config().dialogue)
    assert json.loads(overrides["phrasing_weights"]) == weights

    # a person told that one way of saying yes weighs 50 says it far more often than 1/n
    favourite = phrasings_of(domain)[ACCEPT][0]
    n = len(phrasings_of(domain)[ACCEPT])
    simulator = UserSimulator(
        domain, rng=np.random.default_rng(0), phrasing_weights={ACCEPT: {favourite: 50.0}}
    )
    said = [simulator._say(ACCEPT, "Request(playGame)").text for _ in range(300)]
    assert said.count(favourite) / 300 > 50 / (50 + n) - 0.1


def test_a_refused_run_is_never_reported_as_kept(capsys):
    from oxbot.cli.data import _print_agent

    figures = {"repeated_questions_per_dialogue": 0.1, "ill_formed": 2, "losses": 3}
    metrics = {
        "person": {"dialogues": 20, "probabilities": {"asr_noise": 0.4}},
        "kept": 150,  # the best piece of the fine-tune, then worse in the final measurement
        "refused": ["losses"],
        "config": {"steps": 300},
        "before": {**figures, "task_success": 0.9},
        "after": {**figures, "losses": 5, "task_success": 0.8, "dialogues": 80},
    }
    _print_agent(metrics)
    printed = capsys.readouterr().out
    assert "kept the policy" not in printed and "refused: losses" in printed


def test_questions_in_passing_and_their_answers_are_no_answer_to_the_invitation():
    sys = lambda act: {"speaker": "sys", "act": act, "text": ""}  # noqa: E731
    usr = lambda act: {"speaker": "usr", "act": act, "text": "words"}  # noqa: E731
    asked = [sys("Salutation(greeting)"), sys("Provide(name)"), sys("Request(playGame)")]
    aside = [usr("Request(name)"), sys("Inform(answer)")]
    no = [usr("Reject(playGame=no)"), sys("Acknowledge(playGame=no)"), sys("Salutation(closing)")]
    plain = {"turns": [*asked, *no], "answers": []}
    around = {"turns": [*asked, *aside, *no], "answers": []}
    config = shipped_agent_config().dialogue
    fitted = [fit_person([d] * 10, config).probabilities for d in (plain, around)]
    assert fitted[0] == fitted[1]  # "what's your name?" first, then the no: a no all the same
    assert fitted[1]["refuse_probability"] > 0.5
