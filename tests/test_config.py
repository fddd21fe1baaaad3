import dataclasses
import re

import pytest

from oxbot.config import (
    AgentConfig,
    OxbotConfig,
    PerceptionConfig,
    RewardConfig,
    field_docs,
    load_config,
    to_toml,
)
from oxbot.errors import ConfigError


def test_defaults_are_the_papers_values():
    cfg = OxbotConfig()
    assert cfg.agent.hidden_sizes == (60, 60)
    assert cfg.agent.replay_size == 100_000
    assert cfg.agent.discount == 0.7
    assert cfg.agent.epsilon_min == 0.01
    assert cfg.agent.learning_rate == 0.001
    assert cfg.agent.batch_size == 32
    assert (cfg.reward.win_bonus, cfg.reward.draw_bonus) == (5.0, 1.0)
    assert (cfg.reward.bonus_weight, cfg.reward.length_penalty) == (0.5, 0.1)
    assert cfg.reward.mask_threshold == 0.001
    assert (cfg.tracker.period_s, cfg.tracker.stable_readings) == (0.1, 3)
    assert cfg.perception.image_size == 40
    assert (cfg.perception.conv1_filters, cfg.perception.conv2_filters) == (8, 16)


def _sections(cls: type) -> list[type]:
    found = []
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(f.default_factory):
            found += [f.default_factory, *_sections(f.default_factory)]
    return found


@pytest.mark.parametrize("section", _sections(OxbotConfig))
def test_every_field_has_a_docstring_saying_where_it_comes_from(section):
    docs = field_docs(section)
    for f in dataclasses.fields(section):
        assert f.name in docs, f"{section.__name__}.{f.name} has no docstring"
        assert (
            docs[f.name].split(":")[0] in {"oxbot"}
            or "paper" in docs[f.name].lower()
            or ("ConvNetJS" in docs[f.name])
        )


def test_toml_file_and_command_line_override_in_that_order(tmp_path):
    path = tmp_path / "oxbot.toml"
    path.write_text(
        '[agent]\ndiscount = 0.9\nhidden_sizes = [64, 64]\n[game]\nopponent = "random"\n'
    )
    cfg = load_config(path, ["agent.discount=0.8", "game.opponent=blocker"])
    assert cfg.agent.discount == 0.8
    assert cfg.agent.hidden_sizes == (64, 64)
    assert cfg.game.opponent == "blocker"
    assert cfg.agent.batch_size == 32  # untouched


def test_printed_config_reads_back_identically(tmp_path):
    cfg = load_config(None, ["agent.learning_rate=0.0005", "game.robot_starts=false"])
    path = tmp_path / "round.toml"
    path.write_text(to_toml(cfg))
    assert load_config(path) == cfg
    assert "# Paper §2.2: discount factor 0.7." in to_toml(cfg)


@pytest.mark.parametrize(
    "assignment,message",
    [
        ("agent.discount=2", r"\[agent\] discount must be a finite number in \[0, 1\], got 2.0"),
        ("agent.batch_size=0", r"\[agent\] batch_size must be a whole number > 0, got 0"),
        ("agent.batch_size=3.5", "wrong type; expected int"),
        ("agent.colour=3", "unknown field agent.colour"),
        ("robots.speed=3", r"unknown config section \[robots\]"),
        ("robot.speed=3", "unknown field robot.speed"),
        ("robot.arm.fill=2", r"\[robot.arm\] fill must be a finite number in \(0, 1\], got 2.0"),
        ("robot.arm=3", r"\[robot.arm\] must be a table"),
        ("robot.speed_factor=nan", r"\[robot\] speed_factor must be a finite number > 0, got nan"),
        ("web.port=70000", r"\[web\] port must be a whole number in \[1, 65535\], got 70000"),
        ("discount=3", "write it as section.field=value"),
        ("game.opponent=perfect", "choose one of random, blocker, minimax"),
    ],
)
def test_bad_overrides_say_what_is_wrong(assignment, message):
    with pytest.raises(ConfigError, match=message):
        load_config(None, [assignment])


def test_bad_files_say_what_is_wrong(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(tmp_path / "missing.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[agent\ndiscount = ")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(broken)


def test_configs_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        AgentConfig().discount = 0.9  # type: ignore[misc]
    assert PerceptionConfig(train_images=500).train_images == 500


def test_nested_tables_override_and_read_back(tmp_path):
    path = tmp_path / "robot.toml"
    path.write_text("[robot]\nspeed_factor = 2\n[robot.arm]\npen_speed = 0.3\n[web]\nport = 8123\n")
    cfg = load_config(path, ["robot.arm.travel=0.1"])
    assert (cfg.robot.speed_factor, cfg.robot.arm.pen_speed, cfg.robot.arm.travel) == (2, 0.3, 0.1)
    assert cfg.web.port == 8123 and cfg.robot.arm.fill == 0.7  # untouched
    text = to_toml(cfg)
    assert "[robot.arm]" in text and "[robot.head]" in text
    (tmp_path / "back.toml").write_text(text)
    assert load_config(tmp_path / "back.toml") == cfg


def test_a_folder_given_as_config_file_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="is a folder"):
        load_config(tmp_path)


def _numbers(cls: type = OxbotConfig, path: str = "") -> list[tuple[str, str, object]]:
    """(section, field, default) of every number in the config, found by introspection so that
    a new field is covered without touching these tests."""
    found = []
    defaults = cls()
    for f in dataclasses.fields(cls):
        value = getattr(defaults, f.name)
        if dataclasses.is_dataclass(value):
            found += _numbers(type(value), f"{path}.{f.name}" if path else f.name)
        elif isinstance(value, int | float) and not isinstance(value, bool):
            found.append((path, f.name, value))
    return found


NUMBERS = _numbers()
FLOATS = [(s, n) for s, n, v in NUMBERS if isinstance(v, float)]
INTS = [(s, n) for s, n, v in NUMBERS if isinstance(v, int)]


def test_the_introspection_finds_the_numbers():
    assert ("agent", "learning_rate") in FLOATS and ("robot.arm", "fill") in FLOATS
    assert ("web", "port") in INTS and len(NUMBERS) > 60


@pytest.mark.parametrize("section,name", FLOATS, ids=[f"{s}.{n}" for s, n in FLOATS])
@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_nan_and_infinity_are_refused_for_every_float(section, name, bad):
    message = rf"\[{re.escape(section)}\] {name} must be a finite number.*, got {bad}$"
    with pytest.raises(ConfigError, match=message):
        load_config(None, [f"{section}.{name}={bad}"])


@pytest.mark.parametrize("section,name", INTS, ids=[f"{s}.{n}" for s, n in INTS])
def test_every_count_refuses_a_negative_value_and_a_non_integer(section, name):
    with pytest.raises(ConfigError, match=rf"\[{re.escape(section)}\] {name} must be .*-1000000"):
        load_config(None, [f"{section}.{name}=-1000000"])
    with pytest.raises(ConfigError, match=rf"{re.escape(section)}.{name} = nan has the wrong type"):
        load_config(None, [f"{section}.{name}=nan"])


def test_a_config_built_in_python_is_checked_too():
    with pytest.raises(ConfigError, match=r"\[agent\] learning_rate must be a finite number > 0"):
        AgentConfig(learning_rate=float("nan"))
    with pytest.raises(ConfigError, match=r"\[reward\] win_bonus must be a finite number, got inf"):
        RewardConfig(win_bonus=float("inf"))
    with pytest.raises(ConfigError, match=r"\[perception\] epochs must be a number, got 'ten'"):
        PerceptionConfig(epochs="ten")  # type: ignore[arg-type]


def test_nan_in_a_toml_file_names_its_section_and_field(tmp_path):
    path = tmp_path / "nan.toml"
    path.write_text("[agent]\nlearning_rate = nan\n")
    with pytest.raises(
        ConfigError, match=r"^\[agent\] learning_rate must be a finite number > 0, "
    ):
        load_config(path)


@pytest.mark.parametrize("weight", ["nan", "inf", "0", "-1"])
def test_an_opponent_weight_must_be_a_finite_positive_number(weight):
    with pytest.raises(ConfigError, match="weight of minimax must be a finite number > 0"):
        load_config(None, [f"agent.opponents='random:1,minimax:{weight}'"])


@pytest.mark.parametrize(
    "text",
    [
        "v = " + "[" * 100_000 + "]" * 100_000,
        "v = " + "{a = " * 100_000 + "1" + "}" * 100_000,
        "[agent]\nhidden_sizes = " + "[" * 5_000 + "]" * 5_000,
        "[" + ".".join(["agent"] * 10_000) + "]\nx = 1",
    ],
    ids=["arrays", "inline tables", "in a section", "tables"],
)
def test_deeply_nested_toml_is_a_config_error(tmp_path, text):
    path = tmp_path / "deep.toml"
    path.write_text(text + "\n")
    with pytest.raises(ConfigError, match=r"deep\.toml|agent"):
        load_config(path)


def test_a_deeply_nested_set_value_is_a_config_error():
    with pytest.raises(ConfigError, match=r"--set agent\.hidden_sizes nests its value too deeply"):
        load_config(None, ["agent.hidden_sizes=" + "[" * 100_000 + "]" * 100_000])


def test_an_unreadable_config_file_is_a_config_error(tmp_path, monkeypatch):
    path = tmp_path / "secret.toml"
    path.write_text("[agent]\n")

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(type(path), "read_text", refuse)
    with pytest.raises(ConfigError, match=r"secret\.toml cannot be read \(Permission denied\)"):
        load_config(path)


def test_the_command_line_prints_config_errors_as_one_line_with_the_section(tmp_path):
    import subprocess
    import sys

    for args, message in (
        (["--set", "agent.learning_rate=nan"], "[agent] learning_rate must be a finite number > 0"),
        (["--config", str(tmp_path)], "is a folder; give a TOML file"),
    ):
        result = subprocess.run(
            [sys.executable, "-m", "oxbot.cli", *args, "config"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert result.returncode == 2
        assert message in result.stderr and "Traceback" not in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1
