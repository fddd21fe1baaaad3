"""`oxbot play --https`'s certificate: made once, reused, renewed for a new address."""

import hashlib
import stat

from cryptography import x509
from cryptography.hazmat.primitives import serialization

from oxbot.config import WebConfig
from oxbot.web.server import uses_https
from oxbot.web.tls import ensure_certificate, qr_text


def test_the_certificate_is_made_once_kept_private_and_remade_for_a_new_address(tmp_path):
    first = ensure_certificate(["192.0.2.7"], folder=tmp_path)
    assert {"localhost", "127.0.0.1", "192.0.2.7"} <= set(first.names)
    assert stat.S_IMODE(first.key.stat().st_mode) == 0o600
    assert stat.S_IMODE(tmp_path.stat().st_mode) == 0o700
    cert = x509.load_pem_x509_certificate(first.cert.read_bytes())
    der = cert.public_bytes(serialization.Encoding.DER)
    assert first.fingerprint == ":".join(f"{b:02X}" for b in hashlib.sha256(der).digest())
    again = ensure_certificate(["192.0.2.7"], folder=tmp_path)
    assert again.fingerprint == first.fingerprint  # reused on a later start
    moved = ensure_certificate(["198.51.100.3"], folder=tmp_path)
    assert moved.fingerprint != first.fingerprint and "198.51.100.3" in moved.names
    first.cert.write_text("not a certificate")
    assert ensure_certificate([], folder=tmp_path).fingerprint != moved.fingerprint


def test_https_is_the_default_off_loopback_and_the_url_has_a_qr_code():
    assert not uses_https(WebConfig())
    assert not uses_https(WebConfig(host="localhost"))
    assert uses_https(WebConfig(host="0.0.0.0"))
    assert uses_https(WebConfig(host="192.168.1.20"))
    assert not uses_https(WebConfig(host="0.0.0.0", https="off"))
    assert uses_https(WebConfig(https="on"))
    qr = qr_text("https://192.168.1.20:8000/")
    assert len(qr.splitlines()) > 10 and "█" in qr


def test_a_key_that_is_not_the_certificates_is_a_clear_error(tmp_path):
    import pytest

    from oxbot.errors import ConfigError

    ensure_certificate([], folder=tmp_path / "a")
    other = ensure_certificate([], folder=tmp_path / "b")
    (tmp_path / "a" / other.key.name).write_bytes(other.key.read_bytes())
    with pytest.raises(ConfigError, match=r"is not the key of .*delete"):
        ensure_certificate([], folder=tmp_path / "a")
    (tmp_path / "a" / other.key.name).write_text("garbage")
    with pytest.raises(ConfigError, match="cannot be read"):
        ensure_certificate([], folder=tmp_path / "a")


def test_a_world_readable_key_is_made_private_with_a_warning(tmp_path, caplog):
    first = ensure_certificate([], folder=tmp_path)
    first.key.chmod(0o644)
    again = ensure_certificate([], folder=tmp_path)
    assert again.fingerprint == first.fingerprint
    assert stat.S_IMODE(first.key.stat().st_mode) == 0o600
    assert any("readable by others" in r.getMessage() for r in caplog.records)
