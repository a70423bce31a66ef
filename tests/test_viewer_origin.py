"""Issue 19, viewer: the websocket accepted any Origin, so any web page the user visited
could drive the viewer on 127.0.0.1. Now only its own page (and clients that are no web
page: no Origin) may connect, and the Host must be the bound address (DNS rebinding).
Tested with raw clients, not the browser."""

from __future__ import annotations

import asyncio
import socket

import pytest

pytest.importorskip("viser")
import websockets.asyncio.client as ws_client  # noqa: E402

from fuzzynav.app.viewer.origin_guard import check_handshake  # noqa: E402
from fuzzynav.app.viewer.serve import serve  # noqa: E402


@pytest.fixture(scope="module")
def viewer():
    server = serve("s1", port=0, block=False, open_message=False)
    yield server.port
    server.stop()


def _connect(port: int, origin: str | None, host: str = "127.0.0.1") -> str:
    async def attempt():
        headers = {"Origin": origin} if origin is not None else {}
        try:
            async with ws_client.connect(
                f"ws://{host}:{port}",
                additional_headers=headers,
                subprotocols=["viser-v1.1.1"],
                open_timeout=10,
            ):
                return "open"
        except Exception as exc:  # the refusal, as the client reports it
            return f"refused: {exc}"

    return asyncio.run(attempt())


def _raw_handshake(port: int, host_header: str, origin: str) -> str:
    """The first line of the server's answer to a handshake with these headers."""
    request = (
        "GET / HTTP/1.1\r\n"
        f"Host: {host_header}\r\n"
        "Upgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
        f"Origin: {origin}\r\n\r\n"
    )
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(request.encode())
        return sock.recv(4096).decode(errors="replace").splitlines()[0]


def test_its_own_page_connects(viewer):
    assert _connect(viewer, f"http://127.0.0.1:{viewer}") == "open"
    assert _connect(viewer, f"http://localhost:{viewer}", host="localhost") == "open"


def test_a_client_without_origin_is_no_web_page_and_connects(viewer):
    assert _connect(viewer, None) == "open"


@pytest.mark.parametrize(
    "origin",
    ["http://evil.example", "https://127.0.0.1:{port}", "http://127.0.0.1:1", "null"],
)
def test_another_page_is_refused(viewer, origin):
    answer = _connect(viewer, origin.format(port=viewer))
    assert answer.startswith("refused") and "403" in answer


def test_a_rebound_host_is_refused(viewer):
    """A page on rebind.example, whose name now resolves to 127.0.0.1, sends its own
    Host and Origin: same-origin, but not this viewer's address."""
    line = _raw_handshake(viewer, f"rebind.example:{viewer}", f"http://rebind.example:{viewer}")
    assert "403" in line
    own = _raw_handshake(viewer, f"127.0.0.1:{viewer}", f"http://127.0.0.1:{viewer}")
    assert "101" in own


def test_the_page_itself_is_served_only_to_its_own_host(viewer):
    with socket.create_connection(("127.0.0.1", viewer), timeout=10) as sock:
        sock.sendall(f"GET / HTTP/1.1\r\nHost: rebind.example:{viewer}\r\n\r\n".encode())
        assert "403" in sock.recv(4096).decode(errors="replace").splitlines()[0]


def test_check_handshake_rules():
    local = ("127.0.0.1", 8080)
    ok = {"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"}
    assert check_handshake(ok, "127.0.0.1", local, websocket=True) is None
    assert check_handshake({"Host": "localhost:8080"}, "127.0.0.1", local, websocket=True) is None
    assert "port" in check_handshake({"Host": "127.0.0.1:9"}, "127.0.0.1", local, websocket=True)
    assert "missing" in check_handshake({}, "127.0.0.1", local, websocket=True)
    lan = ("192.168.1.5", 8080)
    assert (
        check_handshake(
            {"Host": "192.168.1.5:8080", "Origin": "http://192.168.1.5:8080"},
            "0.0.0.0",
            lan,
            websocket=True,
        )
        is None
    )
    assert (
        check_handshake({"Host": "rebind.example:8080"}, "0.0.0.0", lan, websocket=True) is not None
    )
