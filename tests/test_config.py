import dataclasses

import pytest

from oxbot.config import (
    AgentConfig,
    OxbotConfig,
    PerceptionConfig,
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
        ("agent.discount=2", "agent.discount is 2.0; use a value in"),
        ("agent.batch_size=0", "agent.batch_size is 0; it must be greater than 0"),
        ("agent.batch_size=3.5", "wrong type; expected int"),
        ("agent.colour=3", "unknown field agent.colour"),
        ("robots.speed=3", r"unknown config section \[robots\]"),
        ("robot.speed=3", "unknown field robot.speed"),
        ("robot.arm.fill=2", r"robot.arm.fill is 2.0; use a value in \(0, 1\]"),
        ("robot.arm=3", r"\[robot.arm\] must be a table"),
        ("robot.speed_factor=nan", "robot.speed_factor is nan; it must be greater than 0"),
        ("web.port=70000", "web.port is 70000"),
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
