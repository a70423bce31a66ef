"""The viewer answers only its own page: a guard on viser's websocket handshake.

A browser lets any web page open a websocket to ``ws://127.0.0.1:8080``; the server must
tell its own page from another one by the handshake's ``Origin`` header, and must check
the ``Host`` header against the address it is bound to (otherwise a page on a domain
that resolves to 127.0.0.1, DNS rebinding, is "its own page"). viser 1.1 checks neither,
so :func:`guarded_server_start` wraps the ``process_request`` hook that viser hands
``websockets.asyncio.server.serve`` while the viser server starts:

- ``Host`` must name the address the connection arrived on (its IP; ``localhost`` for a
  loopback address; the name given to ``--host``; this machine's name when bound to all
  interfaces) with the bound port;
- ``Origin``, when present (browsers always send it), must be ``http://`` and that same
  ``Host``: the page the viewer itself served. A client without ``Origin`` is no web
  page (a script on this machine) and is let through.

Anything else gets ``403 Forbidden`` before viser sees the connection.
"""

from __future__ import annotations

import contextlib
import http
import ipaddress
import socket
import threading
from urllib.parse import urlsplit

__all__ = ["guarded_server_start", "check_handshake"]

_PATCH_LOCK = threading.Lock()


def _split_host(value: str) -> tuple[str, int | None] | None:
    """``"127.0.0.1:8080"`` -> ``("127.0.0.1", 8080)``; ``"[::1]:80"`` -> ``("::1", 80)``;
    None if malformed."""
    try:
        parts = urlsplit(f"//{value}")
        port = parts.port
    except ValueError:
        return None
    if parts.hostname is None or parts.username is not None or parts.path:
        return None
    return parts.hostname.lower(), port


def allowed_host_names(bound_host: str, local_ip: str) -> set[str]:
    """The names a ``Host`` header may give for a server bound to ``bound_host`` that a
    client reached at ``local_ip``."""
    names = {local_ip.lower(), bound_host.lower().strip("[]")}
    try:
        ip = ipaddress.ip_address(local_ip)
    except ValueError:
        ip = None
    if ip is not None and ip.is_loopback:
        names.add("localhost")
    try:
        unspecified = ipaddress.ip_address(bound_host.strip("[]")).is_unspecified
    except ValueError:
        unspecified = False
    if unspecified:  # every interface: the machine's own names too
        names.add(socket.gethostname().lower())
        names.add(socket.getfqdn().lower())
    names.discard("")
    return names


def check_handshake(headers, bound_host: str, local_address, *, websocket: bool) -> str | None:
    """Why a request must be refused (one line), or None to let it through.

    ``headers``: the request's headers (``.get``); ``local_address``: the server side
    of the connection, ``(ip, port, ...)``; ``websocket``: whether it asks to upgrade.
    """
    local_ip, local_port = str(local_address[0]), int(local_address[1])
    for name in ("Host", "Origin"):
        if len(_all(headers, name)) > 1:
            return f"more than one {name} header"
    host_header = headers.get("Host")
    host = _split_host(host_header) if host_header else None
    if host is None:
        return f"Host header {host_header!r} is missing or malformed"
    name, port = host
    if port is not None and port != local_port:
        return f"Host {host_header!r} names port {port}, the viewer listens on {local_port}"
    if name not in allowed_host_names(bound_host, local_ip):
        return f"Host {host_header!r} is not this viewer's address"
    origin = headers.get("Origin")
    if websocket and origin is not None:
        try:
            parts = urlsplit(origin)
            origin_port = parts.port
        except ValueError:
            return f"Origin {origin!r} is malformed"
        if parts.scheme != "http" or parts.hostname is None:
            return f"Origin {origin!r} is not this viewer's page"
        same = parts.hostname.lower() == name and (origin_port or 80) == (port or 80)
        if not same or parts.path not in ("", "/"):
            return f"Origin {origin!r} is not this viewer's page (http://{host_header})"
    return None


def _all(headers, name: str) -> list[str]:
    get_all = getattr(headers, "get_all", None)
    if get_all is not None:
        return list(get_all(name))
    value = headers.get(name)
    return [] if value is None else [value]


def _guard(process_request, bound_host: str):
    def guarded(connection, request):
        websocket = (request.headers.get("Upgrade") or "").lower() == "websocket"
        why = check_handshake(
            request.headers, bound_host, connection.local_address, websocket=websocket
        )
        if why is not None:
            return connection.respond(http.HTTPStatus.FORBIDDEN, f"fuzzynav viewer: {why}\n")
        return process_request(connection, request) if process_request is not None else None

    return guarded


@contextlib.contextmanager
def guarded_server_start(bound_host: str):
    """Within this block, every websocket server started through
    ``websockets.asyncio.server.serve`` (viser's, while ``viser.ViserServer`` starts)
    gets the Origin and Host guard. Raises RuntimeError if no server started in it
    (a viser that starts its server some other way would run unguarded)."""
    import websockets.asyncio.server as ws_server

    started = []
    with _PATCH_LOCK:
        original = ws_server.serve

        def serve(handler, *args, process_request=None, **kwargs):
            started.append(True)
            return original(
                handler, *args, process_request=_guard(process_request, bound_host), **kwargs
            )

        ws_server.serve = serve
        try:
            yield
        finally:
            ws_server.serve = original
    if not started:
        raise RuntimeError(
            "the viewer's Origin guard was not installed: this viser does not start its "
            "server through websockets.asyncio.server.serve"
        )
