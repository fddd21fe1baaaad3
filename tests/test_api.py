"""The top-level API: a few names, loaded on first use."""

import subprocess
import sys

import oxbot


def test_the_top_level_names_are_the_real_ones():
    from oxbot.config import load_config
    from oxbot.dialogue import InteractiveGameEnv, load_policy
    from oxbot.perception import read_board
    from oxbot.robot.session import Robot

    assert oxbot.read_board is read_board and oxbot.load_policy is load_policy
    assert oxbot.InteractiveGameEnv is InteractiveGameEnv and oxbot.Robot is Robot
    assert oxbot.load_config is load_config
    assert set(oxbot.__all__) >= {"read_board", "InteractiveGameEnv", "load_policy", "Robot"}


def test_importing_oxbot_does_not_load_torch():
    code = "import sys, oxbot; print('torch' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "False", result.stderr
