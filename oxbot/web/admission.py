"""Who may open a game session, or read any route: the Host and Origin checks against DNS
rebinding and other sites' pages (on the socket and every HTTP route alike), and the sessions'
slots (at most `web.max_sessions` at once)."""

from __future__ import annotations

import ipaddress
import urllib.parse

from starlette.requests import HTTPConnection

from oxbot.config import WebConfig
from oxbot.web.inbound import excerpt


class Slots:
    """The sessions' slots, at most `limit` taken: taken and given back on the event loop,
    with no await between looking and taking, so that the limit holds under any burst."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.taken = 0

    def take(self) -> bool:
        if self.taken >= self.limit:
            return False
        self.taken += 1
        return True

    def give_back(self) -> None:
        self.taken -= 1


class Origins:
    """Which pages may open the game socket: those served under a Host that cannot be a DNS
    rebinding (an IP address, localhost, this server's configured name, an allowed origin's
    host), from the same origin as that Host or an origin in `web.allowed_origins`. A client
    that sends no Origin is not a browser page, and may."""

    def __init__(self, limits: WebConfig) -> None:
        self.allowed = {
            _origin_key(o)
            for o in (o.strip() for o in limits.allowed_origins.split(","))
            if o and _origin_key(o) is not None
        }
        self.hosts = {"localhost"} | {host for host, _ in self.allowed}
        if limits.host not in ("0.0.0.0", "::", ""):
            self.hosts.add(limits.host.lower())

    def refusal(self, websocket: HTTPConnection) -> str | None:
        """Why this socket or HTTP request is refused (for its close reason, its 403 and the
        log), or None."""
        host = websocket.headers.get("host", "")
        default_port = 443 if websocket.url.scheme in ("wss", "https") else 80
        served = _host_key(host, default_port)
        if served is None or not (served[0] in self.hosts or _is_ip(served[0])):
            return (
                f"Host {excerpt(host)} is not this server's; add its page's origin to "
                "web.allowed_origins"
            )
        origin = websocket.headers.get("origin")
        if not origin or served == _origin_key(origin):
            return None
        if _origin_key(origin) in self.allowed:
            return None
        return (
            f"pages from {excerpt(origin)} may not play here; add the origin to web.allowed_origins"
        )


def _origin_key(origin: str) -> tuple[str, int] | None:
    """(host, port) of an origin such as http://127.0.0.1:8000, or None if malformed."""
    scheme, _, rest = origin.strip().lower().partition("://")
    if scheme not in ("http", "https"):
        return None  # also "null", the origin of files and sandboxed frames
    return _host_key(rest, 443 if scheme == "https" else 80)


def _host_key(host: str, default_port: int) -> tuple[str, int] | None:
    """(host, port) of a Host header such as 127.0.0.1:8000 or [::1], or None if malformed."""
    try:
        parts = urllib.parse.urlsplit("//" + host.strip().lower())
        port = parts.port
    except ValueError:
        return None
    if not parts.hostname or parts.path or parts.username is not None:
        return None
    return parts.hostname, port if port is not None else default_port


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True
