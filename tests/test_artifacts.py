"""Model files: checksummed, versioned, and every kind of damage refused with a clear error."""

import io
import logging
import pickle
import zipfile

import numpy as np
import pytest
import torch

from oxbot import artifacts
from oxbot.dialogue.agent import POLICY_FORMAT, DQNPolicy, QNetwork, load_policy
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.errors import ModelFileError
from oxbot.perception.classifier import load_classifier, shipped_model_path

NAMES = shipped_dialogue_model().layout.names


@pytest.fixture
def policy_file(tmp_path):
    torch.manual_seed(0)
    path = tmp_path / "agent.pt"
    DQNPolicy(QNetwork(len(NAMES), (16, 16)), NAMES, {"seed": 3}).save(path)
    return path


def _payload_start(data: bytes) -> int:
    return data.index(b"\n") + 1


def _flip(data: bytes, n: int, start: int, seed: int = 0) -> bytes:
    out = bytearray(data)
    rng = np.random.default_rng(seed)
    for i in rng.choice(np.arange(start, len(data)), n, replace=False):
        out[i] ^= 0xFF
    return bytes(out)


def _load_policy_payload(path):
    return artifacts.load(path, "policy", 2, "policy file", "")


def test_a_file_is_a_header_with_kind_version_and_the_payloads_sha256(policy_file):
    import hashlib
    import json

    data = policy_file.read_bytes()
    header = json.loads(data[len(artifacts.MAGIC) : data.index(b"\n")])
    body = data[_payload_start(data) :]
    assert header == {
        "kind": "policy",
        "format_version": 2,
        "bytes": len(body),
        "sha256": hashlib.sha256(body).hexdigest(),
    }
    assert load_policy(policy_file).metadata == {"seed": 3}


@pytest.mark.parametrize("n", [1, 40])
def test_flipped_bytes_in_the_payload_are_refused(policy_file, tmp_path, n):
    data = policy_file.read_bytes()
    bad = tmp_path / "flipped.pt"
    bad.write_bytes(_flip(data, n, _payload_start(data)))
    with pytest.raises(ModelFileError, match=r"flipped\.pt is corrupt: its SHA-256 does not"):
        load_policy(bad)


def test_a_damaged_header_is_refused(policy_file, tmp_path):
    data = policy_file.read_bytes()
    bad = tmp_path / "header.pt"
    bad.write_bytes(data.replace(b'"sha256"', b'"sha257"', 1))
    with pytest.raises(ModelFileError, match="damaged header"):
        load_policy(bad)
    bad.write_bytes(data.replace(b"\n", b" ", 1))  # no end of the header line
    with pytest.raises(ModelFileError, match="damaged header"):
        load_policy(bad)


@pytest.mark.parametrize("keep", [0, 10, 200, -1])
def test_truncated_files_are_refused(policy_file, tmp_path, keep):
    data = policy_file.read_bytes()
    cut = tmp_path / "cut.pt"
    cut.write_bytes(data[:keep])
    with pytest.raises(ModelFileError, match=r"cut\.pt (is truncated|has a damaged header)"):
        load_policy(cut)


@pytest.mark.parametrize(
    "garbage",
    [b"", b"\x00" * 100, b"PK\x03\x04 not really a zip", pickle.dumps([1, 2, 3]), b"x" * 5000],
)
def test_garbage_is_refused(tmp_path, garbage):
    path = tmp_path / "garbage.pt"
    path.write_bytes(garbage)
    with pytest.raises(ModelFileError, match="truncated or not a model file"):
        load_policy(path)
    with pytest.raises(ModelFileError, match="truncated or not a model file"):
        load_classifier(path)


def test_a_checksummed_payload_that_is_not_a_torch_file_is_refused(tmp_path):
    import hashlib
    import json

    body = b"not a zip at all"
    header = {"kind": "policy", "format_version": 2, "bytes": len(body)}
    header["sha256"] = hashlib.sha256(body).hexdigest()
    path = tmp_path / "p.pt"
    path.write_bytes(artifacts.MAGIC + json.dumps(header).encode() + b"\n" + body)
    with pytest.raises(ModelFileError, match="holds no oxbot payload"):
        load_policy(path)


def test_another_kind_of_file_is_refused_by_name(policy_file):
    with pytest.raises(ModelFileError, match="is an oxbot policy file, not a perceiver"):
        load_classifier(policy_file)


def test_a_newer_format_version_says_to_update(policy_file, tmp_path):
    payload = _load_policy_payload(policy_file)
    artifacts.save(tmp_path / "new.pt", "policy", 3, payload)
    with pytest.raises(ModelFileError, match=r"format version 3.*reads version 2; update oxbot"):
        load_policy(tmp_path / "new.pt")


@pytest.mark.parametrize(
    "change",
    [
        {"feature_names": None},
        {"action_names": None},
        {"hidden_sizes": None},
        {"state_dict": None},
        {"feature_names": 5},
        {"hidden_sizes": "sixty"},
        {"hidden_sizes": [16]},
        {"board_features": 7},
        {"metadata": 5},
        {"state_dict": "weights"},
        {"state_dict": {"net.0.weight": torch.zeros(2, 2)}},
    ],
    ids=str,
)
def test_missing_keys_and_wrong_types_in_a_policy_are_refused(policy_file, tmp_path, change):
    payload = _load_policy_payload(policy_file)
    for key, value in change.items():
        if value is None:
            del payload[key]
        else:
            payload[key] = value
    path = artifacts.save(tmp_path / "odd.pt", "policy", 2, payload)
    with pytest.raises(ModelFileError, match=r"odd\.pt (is malformed|does not match)"):
        load_policy(path)


@pytest.mark.parametrize(
    "key,value",
    [("architecture", None), ("state_dict", None), ("config", 5), ("seed", "x"), ("metadata", 1)],
)
def test_missing_keys_and_wrong_types_in_a_perceiver_are_refused(tmp_path, key, value):
    payload = artifacts.load(shipped_model_path(), "perceiver", 2, "model", "", lambda p: True)
    if value is None:
        del payload[key]
    else:
        payload[key] = value
    path = artifacts.save(tmp_path / "odd.pt", "perceiver", 2, payload)
    with pytest.raises(ModelFileError, match=r"odd\.pt (is malformed|does not match)"):
        load_classifier(path)


def test_a_deeply_nested_payload_is_refused_not_a_recursion_error(policy_file, tmp_path):
    # a 100,000-deep list where the metadata goes, checksummed like a real file
    payload = _load_policy_payload(policy_file)
    payload["metadata"] = "PLACEHOLDER"
    buffer = io.BytesIO()
    torch.save(payload, buffer)
    depth = 100_000
    deep = b"]" * depth + b"a" * (depth - 1)
    rewritten = io.BytesIO()
    with (
        zipfile.ZipFile(io.BytesIO(buffer.getvalue())) as old,
        zipfile.ZipFile(rewritten, "w") as new,
    ):
        for item in old.infolist():
            data = old.read(item)
            if item.filename.endswith("data.pkl"):
                marker = b"X\x0b\x00\x00\x00PLACEHOLDER"  # BINUNICODE of the string
                assert marker in data
                data = data.replace(marker, deep)
            new.writestr(item, data)
    body = rewritten.getvalue()
    path = tmp_path / "deep.pt"
    _write_raw(path, "policy", 2, body)
    with pytest.raises(ModelFileError, match=r"deep\.pt is malformed"):
        load_policy(path)


def _write_raw(path, kind, version, body):
    import hashlib
    import json

    header = {"kind": kind, "format_version": version, "bytes": len(body)}
    header["sha256"] = hashlib.sha256(body).hexdigest()
    path.write_bytes(artifacts.MAGIC + json.dumps(header).encode() + b"\n" + body)


def test_a_folder_or_a_missing_file_is_refused(tmp_path):
    with pytest.raises(ModelFileError, match="is a folder"):
        load_classifier(tmp_path)
    with pytest.raises(ModelFileError, match=r"agent\.pt does not exist"):
        load_policy(tmp_path)  # a policy's folder: the agent.pt `train agent --out` writes
    with pytest.raises(ModelFileError, match="does not exist; retrain it with `oxbot train"):
        load_classifier(tmp_path / "none.pt")


def test_a_file_from_before_checksums_loads_with_a_warning(policy_file, tmp_path, caplog):
    payload = _load_policy_payload(policy_file)
    assert payload["format"] == POLICY_FORMAT
    old = tmp_path / "old.pt"
    torch.save(payload, old)  # the format before this header: the bare payload
    with caplog.at_level(logging.WARNING, logger="oxbot.artifacts"):
        policy = load_policy(old)
    assert policy.metadata == {"seed": 3}
    assert "before oxbot checksummed its files" in caplog.text and "re-save it" in caplog.text
    policy.save(old)  # re-saving adds the header
    assert old.read_bytes().startswith(artifacts.MAGIC)


def test_a_flipped_byte_of_the_shipped_perceiver_is_refused_and_says_what_to_do(tmp_path):
    data = shipped_model_path().read_bytes()
    bad = tmp_path / "perceiver.pt"
    bad.write_bytes(_flip(data, 1, len(data) // 2))
    with pytest.raises(ModelFileError, match=r"corrupt.*re-download oxbot/data/models/perceiver"):
        load_classifier(bad)


def test_the_shipped_files_carry_the_header():
    from oxbot.dialogue.agent import shipped_policy_path

    for path in (shipped_model_path(), shipped_policy_path()):
        assert path.read_bytes().startswith(artifacts.MAGIC), path
    assert load_classifier().fitted and load_policy().feature_names == NAMES


def test_a_damaged_or_incomplete_agent_checkpoint_is_refused(tmp_path):
    from oxbot.config import load_config
    from oxbot.dialogue.env import InteractiveGameEnv
    from oxbot.dialogue.training import (
        TrainingState,
        _load_checkpoint,
        _new_learner,
        _save_checkpoint,
    )

    config = load_config(None, ["agent.replay_size=100"])
    env = InteractiveGameEnv(config=config)
    path = tmp_path / "checkpoint.pt"
    _save_checkpoint(path, config, _new_learner(env, config.agent), TrainingState(step=5))
    assert _load_checkpoint(path, config, _new_learner(env, config.agent)).step == 5
    data = path.read_bytes()
    path.write_bytes(_flip(data, 40, _payload_start(data)))
    with pytest.raises(ModelFileError, match=r"checkpoint .* is corrupt.*--no-resume"):
        _load_checkpoint(path, config, _new_learner(env, config.agent))
    path.write_bytes(data)
    payload = artifacts.load(path, "agent-checkpoint", 2, "checkpoint", "")
    for key, value in (("replay", None), ("state", {"step": "five", "nonsense": 1})):
        odd = dict(payload)
        if value is None:
            del odd[key]
        else:
            odd[key] = value
        artifacts.save(path, "agent-checkpoint", 2, odd)
        with pytest.raises(ModelFileError, match=r"checkpoint.*--no-resume"):
            _load_checkpoint(path, config, _new_learner(env, config.agent))


def test_a_perceiver_checkpoint_from_other_settings_is_refused(tmp_path):
    from oxbot.perception.training import _load_checkpoint, _save_checkpoint

    settings = {"config": {"epochs": 3}, "images": 1500, "seeds": "s", "sizes": [100, 1500]}
    path = tmp_path / "perceiver.checkpoint.pt"
    point = {"images": 100, "accuracy": 0.5, "fit_seconds": 0.1}
    _save_checkpoint(path, settings, [point])
    assert _load_checkpoint(path, settings) == [point]
    with pytest.raises(ModelFileError, match=r"other settings \(images\).*--no-resume"):
        _load_checkpoint(path, {**settings, "images": 2000})
    _save_checkpoint(path, settings, [{"images": 100}])
    with pytest.raises(ModelFileError, match=r"is malformed \(missing 'accuracy'\)"):
        _load_checkpoint(path, settings)


@pytest.mark.parametrize(
    "content,message",
    [
        ("[" * 100_000 + "]" * 100_000, "nests its JSON too deeply"),
        ('{"accuracy": ', "is not valid JSON"),
        ("\udcff", "is not valid JSON"),
    ],
    ids=["deep", "cut", "not utf-8"],
)
def test_a_metrics_file_that_is_not_json_is_a_data_error(tmp_path, content, message):
    from oxbot.errors import DataError

    path = tmp_path / "perceiver.metrics.json"
    path.write_bytes(content.encode("utf-8", "surrogateescape"))
    with pytest.raises(DataError, match=rf"metrics {tmp_path}/perceiver\.metrics\.json {message}"):
        artifacts.load_json(path, "metrics", "re-download it")
    with pytest.raises(DataError, match="does not exist; re-download it"):
        artifacts.load_json(tmp_path / "none.json", "metrics", "re-download it")
