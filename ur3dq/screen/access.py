"""Who may open the screen: loopback only, unless a token is given (then every page must bring it).

A WebSocket is not bound by the browser's same-origin rules: any web page the operator has open could connect to
the screen on 127.0.0.1 and move the arm. So the screen's WebSocket takes only its own page (the Origin header,
when a browser sends one, must name the host the request was sent to), and without a token only requests addressed
to a loopback name (a foreign name resolving to 127.0.0.1, DNS rebinding, is refused).
"""
from __future__ import annotations

import hmac
import ipaddress
from urllib.parse import urlsplit


def is_loopback(address: str) -> bool:
    """True for an address only this machine can reach (127.0.0.0/8, ::1, 'localhost').

    >>> is_loopback("127.0.0.1"), is_loopback("0.0.0.0"), is_loopback("::1")
    (True, False, True)
    """
    if address == "localhost":
        return True
    try:
        return ipaddress.ip_address(address).is_loopback
    except ValueError:
        return False


def token_accepted(required: str | None, given: str | None) -> bool:
    """True when no token is required, or `given` is it (compared in constant time)."""
    if required is None:
        return True
    return given is not None and hmac.compare_digest(given.encode(), required.encode())


def host_of(authority: str) -> str:
    """The host of a Host header or URL authority ('127.0.0.1:8765' -> '127.0.0.1', '[::1]:80' -> '::1')."""
    return urlsplit(f"//{authority}").hostname or ""


def request_allowed(host_header: str | None, origin: str | None, token_required: bool) -> bool:
    """True when a request to the screen may go on: its Origin (if any) is the page's own host, and without a token
    it was addressed to a loopback name.

    >>> request_allowed("127.0.0.1:8765", "http://127.0.0.1:8765", False)
    True
    >>> request_allowed("127.0.0.1:8765", "http://example.com", False)
    False
    >>> request_allowed("evil.example:8765", "http://evil.example:8765", False)
    False
    """
    if origin is not None and urlsplit(origin).netloc.lower() != (host_header or "").lower():
        return False
    return token_required or is_loopback(host_of(host_header or ""))
