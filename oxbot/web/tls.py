"""HTTPS for `oxbot play --https`: a self-signed certificate made on first start, reused after.

Browsers give a page the camera only on a secure origin: https://, or http://localhost. A phone
held over the sheet reaches the laptop by its LAN address, so the page must come over HTTPS.
There is no certificate authority on a LAN; oxbot makes its own certificate (an ECDSA P-256 key,
valid for `VALID_DAYS`, for localhost, this machine's name and its addresses), writes it and
its key atomically into `tls_folder()` (the key readable by the owner only), and reuses them on
later starts for as long as they are valid and name every address asked for. The person accepts
it once in the browser, after checking that the SHA-256 fingerprint the browser shows is the one
the terminal printed (the page shows it too).

    tls = ensure_certificate(["192.168.1.20"])
    tls.cert, tls.key, tls.fingerprint   # paths, and "AB:12:...:9F"
"""

from __future__ import annotations

import datetime
import ipaddress
import logging
import os
import socket
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from oxbot.atomic import atomic_write
from oxbot.errors import ConfigError

log = logging.getLogger(__name__)

VALID_DAYS = 397
"""oxbot: how long a certificate is valid; browsers refuse server certificates valid for
longer than 398 days, even self-signed ones accepted by hand (Safari)."""
RENEW_DAYS = 7
"""oxbot: a certificate with fewer days left than this is replaced at the next start."""
CERT_NAME, KEY_NAME = "oxbot-cert.pem", "oxbot-key.pem"


@dataclass(frozen=True)
class Certificate:
    """A certificate and key on disk, and the certificate's SHA-256 fingerprint."""

    cert: Path
    key: Path
    fingerprint: str
    """SHA-256 of the certificate (DER), as browsers show it: 32 hex pairs joined by colons."""
    names: tuple[str, ...]
    """The host names and addresses it is valid for."""


def tls_folder() -> Path:
    """Where oxbot keeps its certificate: $OXBOT_TLS_DIR, else $XDG_CONFIG_HOME/oxbot/tls, else
    ~/.config/oxbot/tls."""
    if os.environ.get("OXBOT_TLS_DIR"):
        return Path(os.environ["OXBOT_TLS_DIR"])
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "oxbot" / "tls"


def local_addresses() -> list[str]:
    """This machine's addresses a phone on the same network can reach, best first (the one
    the default route leaves from), without sending a packet."""
    found: list[str] = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("10.255.255.255", 1))  # UDP: picks a route, sends nothing
            found.append(probe.getsockname()[0])
        except OSError:
            pass
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            address = info[4][0]
            if address not in found:
                found.append(address)
    except OSError:
        pass
    return [a for a in found if not ipaddress.ip_address(a).is_loopback]


def ensure_certificate(
    hosts: list[str] | tuple[str, ...] = (), folder: Path | None = None
) -> Certificate:
    """The certificate in `folder` (default `tls_folder()`) if it is valid for at least
    RENEW_DAYS more and names localhost, 127.0.0.1 and every one of `hosts`; else a new one
    for them, written atomically over the old."""
    folder = folder if folder is not None else tls_folder()
    wanted = _names(hosts)
    cert_path, key_path = folder / CERT_NAME, folder / KEY_NAME
    existing = _load(cert_path, key_path)
    if existing is not None and set(wanted) <= set(existing.names):
        return existing
    try:
        folder.mkdir(parents=True, exist_ok=True)
        folder.chmod(0o700)  # the key is the server's identity: the owner's alone
        return _make(cert_path, key_path, wanted)
    except OSError as exc:
        raise ConfigError(
            f"cannot write the HTTPS certificate in {folder} ({exc.strerror}); set "
            "OXBOT_TLS_DIR to a folder you can write"
        ) from None


def _names(hosts: list[str] | tuple[str, ...]) -> tuple[str, ...]:
    names = ["localhost", "127.0.0.1", socket.gethostname().lower()]
    for host in hosts:
        host = host.strip().lower()
        if host and host not in ("0.0.0.0", "::") and host not in names:
            names.append(host)
    return tuple(names)


def _load(cert_path: Path, key_path: Path) -> Certificate | None:
    """The certificate on disk, if it and its key are there, readable and not near expiry."""
    from cryptography import x509

    if not cert_path.is_file() or not key_path.is_file():
        return None
    try:
        cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except (ValueError, x509.ExtensionNotFound, OSError) as exc:
        log.warning(
            "the HTTPS certificate in %s is unreadable (%s): making a new one", cert_path, exc
        )
        return None
    left = cert.not_valid_after_utc - datetime.datetime.now(datetime.UTC)
    if left < datetime.timedelta(days=RENEW_DAYS):
        log.info("the HTTPS certificate expires in %s: making a new one", left)
        return None
    _check_key(cert, key_path, cert_path)
    listed = [str(n) for n in names.get_values_for_type(x509.DNSName)]
    listed += [str(n) for n in names.get_values_for_type(x509.IPAddress)]
    return Certificate(cert_path, key_path, _fingerprint(cert), tuple(listed))


def _check_key(cert: Any, key_path: Path, cert_path: Path) -> None:
    """A ConfigError unless `key_path` holds the key of `cert`; a key others may read is made
    the owner's alone, with a warning (they may have copied it)."""
    from cryptography.hazmat.primitives import serialization

    mode = stat.S_IMODE(key_path.stat().st_mode)
    if mode & 0o077:
        os.chmod(key_path, 0o600)
        log.warning(
            "the HTTPS key %s was readable by others (mode %o): made it 0600; if others could "
            "log in here, delete %s and %s to make a new pair",
            key_path,
            mode,
            key_path,
            cert_path,
        )
    remedy = f"delete {key_path} and {cert_path} to make a new pair, or put the matching key there"
    try:
        key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
    except (ValueError, TypeError, OSError) as exc:
        raise ConfigError(f"the HTTPS key {key_path} cannot be read ({exc}); {remedy}") from None
    public = serialization.PublicFormat.SubjectPublicKeyInfo
    encoding = serialization.Encoding.DER
    if key.public_key().public_bytes(encoding, public) != cert.public_key().public_bytes(
        encoding, public
    ):
        raise ConfigError(f"the HTTPS key {key_path} is not the key of {cert_path}; {remedy}")


def _make(cert_path: Path, key_path: Path, names: tuple[str, ...]) -> Certificate:
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"oxbot on {names[2]}")])
    alternatives: list[x509.GeneralName] = []
    for name in names:
        try:
            alternatives.append(x509.IPAddress(ipaddress.ip_address(name)))
        except ValueError:
            alternatives.append(x509.DNSName(name))
    now = datetime.datetime.now(datetime.UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))  # clocks differ a little
        .not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
        .add_extension(x509.SubjectAlternativeName(alternatives), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .sign(key, hashes.SHA256())
    )
    key_pem = key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )
    with atomic_write(key_path) as out:
        out.write(key_pem)
    os.chmod(key_path, 0o600)
    with atomic_write(cert_path) as out:
        out.write(cert.public_bytes(serialization.Encoding.PEM))
    log.info("made a new HTTPS certificate in %s for %s", cert_path.parent, ", ".join(names))
    return Certificate(cert_path, key_path, _fingerprint(cert), names)


def _fingerprint(cert) -> str:
    from cryptography.hazmat.primitives import hashes

    return ":".join(f"{b:02X}" for b in cert.fingerprint(hashes.SHA256()))


def qr_text(text: str) -> str:
    """`text` (a URL) as a QR code drawn with block characters, for a terminal."""
    import io

    import segno

    out = io.StringIO()
    segno.make(text, error="m").terminal(out, compact=True, border=2)
    return out.getvalue()


__all__ = ["Certificate", "ensure_certificate", "local_addresses", "qr_text", "tls_folder"]
