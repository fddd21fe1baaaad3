"""Zenoh's own security for a robot's bus: TLS with mutual authentication, and access control
so that only the robot's parts may publish, subscribe, query or declare liveliness on its keys.

Every process of the robot gets a certificate signed by the robot's certificate authority (CA)
and connects over `tls/HOST:PORT` endpoints; a peer whose certificate the CA did not sign is
refused at the handshake (`BusUnreachable` on its side). Each process also enforces Zenoh's
access control on what reaches it: everything on `oxbot/**` is denied unless the sender's
certificate's common name is one of `allowed`; a peer with a certificate of the CA but another
name connects, and what it sends is dropped.

    make_credentials(folder, ["launcher", "arm-machine"])   # ca.pem, <name>.pem, <name>-key.pem
    BusSecurity(folder / "ca.pem", folder / "launcher.pem", folder / "launcher-key.pem",
                allowed=("launcher", "arm-machine"))

In a launch file: a `[security]` table with `ca`, `certificate`, `key` and `allowed`.
"""

from __future__ import annotations

import datetime
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from oxbot.errors import ConfigError

ZENOH_MESSAGES = (
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "reply",
    "declare_queryable",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
)
"""Every kind of message Zenoh's access control rules on."""
VALID_DAYS = 825


@dataclass(frozen=True)
class BusSecurity:
    """The files and names of a robot's bus security (see the module docstring)."""

    ca: Path
    """The robot's CA certificate (PEM): the only signer whose certificates are accepted."""
    certificate: Path
    """This process's certificate (PEM), signed by the CA."""
    key: Path
    """This process's private key (PEM)."""
    allowed: tuple[str, ...]
    """Certificate common names that may use the robot's keys."""

    def __post_init__(self) -> None:
        for what, path in (("ca", self.ca), ("certificate", self.certificate), ("key", self.key)):
            if not Path(path).is_file():
                raise ConfigError(f"bus security: {what} {path} is not a file")
        if not self.allowed:
            raise ConfigError("bus security: `allowed` names no certificate; nothing could talk")

    def zenoh_settings(self) -> dict[str, Any]:
        """Zenoh configuration entries (key path -> value) for TLS with mutual authentication
        and access control."""
        tls = "transport/link/tls/"
        return {
            tls + "root_ca_certificate": str(self.ca),
            tls + "enable_mtls": True,
            tls + "listen_private_key": str(self.key),
            tls + "listen_certificate": str(self.certificate),
            tls + "connect_private_key": str(self.key),
            tls + "connect_certificate": str(self.certificate),
            # the CA is the robot's own: its signature, not a host name, says who is a part
            tls + "verify_name_on_connect": False,
            "access_control": {
                "enabled": True,
                "default_permission": "deny",
                "rules": [
                    {
                        "id": "parts",
                        "messages": list(ZENOH_MESSAGES),
                        "flows": ["ingress", "egress"],
                        "permission": "allow",
                        "key_exprs": ["oxbot/**"],
                    }
                ],
                "subjects": [{"id": "robot", "cert_common_names": list(self.allowed)}],
                "policies": [{"rules": ["parts"], "subjects": ["robot"]}],
            },
        }


def make_credentials(folder: str | Path, names: list[str]) -> dict[str, tuple[Path, Path]]:
    """A new CA in `folder` (`ca.pem`, `ca-key.pem`) and a certificate and key per name
    (`<name>.pem`, `<name>-key.pem`, keys 0600); each name's (certificate, key)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    folder = Path(folder)
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    now = datetime.datetime.now(datetime.UTC)

    def subject(name: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])

    def write(stem: str, key: Any, cert: Any) -> tuple[Path, Path]:
        key_path, cert_path = folder / f"{stem}-key.pem", folder / f"{stem}.pem"
        fd = os.open(key_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as out:
            out.write(
                key.private_bytes(
                    serialization.Encoding.PEM,
                    serialization.PrivateFormat.PKCS8,
                    serialization.NoEncryption(),
                )
            )
        cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        return cert_path, key_path

    def builder(name: str, issuer: x509.Name, public: Any) -> x509.CertificateBuilder:
        return (
            x509.CertificateBuilder()
            .subject_name(subject(name))
            .issuer_name(issuer)
            .public_key(public)
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
        )

    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = subject(f"oxbot CA {folder.name}")
    ca_cert = (
        builder(ca_name.rfc4514_string()[3:], ca_name, ca_key.public_key())
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .sign(ca_key, hashes.SHA256())
    )
    write("ca", ca_key, ca_cert)
    made = {}
    for name in names:
        key = ec.generate_private_key(ec.SECP256R1())
        cert = (
            builder(name, ca_name, key.public_key())
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .sign(ca_key, hashes.SHA256())
        )
        made[name] = write(name, key, cert)
    return made
