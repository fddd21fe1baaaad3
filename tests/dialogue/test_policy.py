"""The robot's `Policy` protocol, and a domain of one's own with its own feature layout."""

import numpy as np
import pytest

from oxbot.config import load_config
from oxbot.dialogue.baselines import load_manager
from oxbot.dialogue.model import build_dialogue_model
from oxbot.dialogue.policy import Policy, choose
from oxbot.errors import ConfigError, ModelFileError


class Always:
    """A policy with no Q-values that always names one act."""

    def __init__(self, action: int) -> None:
        self.action = action

    def act(self, observation, mask):
        return self.action


def test_a_policy_without_q_values_is_shown_as_its_choice():
    action, scores = choose(Always(2), np.zeros(4), np.array([True, False, True, True]))
    assert isinstance(Always(2), Policy)
    assert action == 2 and scores.tolist() == [0, 0, 1, 0]


def test_an_act_the_mask_does_not_offer_is_never_said():
    action, _ = choose(Always(1), np.zeros(4), np.array([False, False, True, True]))
    assert action == 2


def new_phrase_domain(folder):
    """The shipped domain with one more answer to "Shall we play?", in new words."""
    import shutil

    from oxbot.dialogue.domain import default_domain_dir

    shutil.copytree(default_domain_dir(), folder)
    with open(folder / "user_responses.txt", "a") as f:
        f.write('Request(playGame) => USR:[Confirm(playGame=yes)]"Absolutely, bring it on."\n')
    return folder


def test_a_domain_folder_gives_its_own_feature_layout(tmp_path):
    folder = new_phrase_domain(tmp_path / "mine")
    config = load_config(None, [f"dialogue.domain={folder}"])
    names = build_dialogue_model(config).layout.names
    assert {"word:absolutely", "word:bring"} <= set(names)
    assert "word:absolutely" not in build_dialogue_model(load_config()).layout.names


def test_the_shipped_policy_refuses_a_new_domain_naming_the_commands_to_run(tmp_path):
    folder = new_phrase_domain(tmp_path / "mine")
    config = load_config(None, [f"dialogue.domain={folder}"])
    with pytest.raises(ModelFileError) as refused:
        load_manager("dqn", config)
    message = str(refused.value)
    assert f"oxbot train agent --domain {folder} --out runs/agent" in message
    assert f"oxbot play --domain {folder} --policy runs/agent" in message


def test_a_domain_that_is_not_a_folder_is_a_config_error(tmp_path):
    config = load_config(None, [f"dialogue.domain={tmp_path / 'none'}"])
    with pytest.raises(ConfigError, match="not a folder"):
        build_dialogue_model(config)


def test_a_policy_file_goes_with_the_dqn_manager_only():
    with pytest.raises(ConfigError, match="policy"):
        load_config(None, ["robot.manager=rules", "robot.policy=runs/agent"])
