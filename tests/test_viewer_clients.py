"""The viewer with many tabs at once, driven by scripted websocket clients.

A scripted client speaks viser's own protocol (no browser): it opens the websocket with
the viser version as subprotocol, sends a camera message (viser counts a client as
connected from its first camera message, as a browser tab sends one as soon as its
canvas exists), reads everything the server sends, and can press a GUI button the way
the page does (a ``GuiUpdateMessage``).
"""

from __future__ import annotations

import asyncio
import threading
import time

import msgspec
import pytest
import viser
import websockets
from viser import _messages as messages

from fuzzynav.app.viewer import ViewerApp

pytestmark = pytest.mark.timeout(180)


class ScriptedClients:
    """Websocket clients on an event loop of their own (a thread)."""

    def __init__(self, url: str):
        self.ws_url = url.replace("http://", "ws://")
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.sockets: list = []
        self.received = []  # bytes received per client
        self.tasks = []

    def _run(self, coro, timeout=60.0):
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout)

    async def _one(self, width: int, height: int):
        ws = await websockets.connect(
            self.ws_url,
            subprotocols=[f"viser-v{viser.__version__}"],
            max_size=None,
            open_timeout=60,
        )
        camera = messages.ViewerCameraMessage(
            wxyz=(1.0, 0.0, 0.0, 0.0),
            position=(0.0, 0.0, 20.0),
            fov=0.78,
            near=0.01,
            far=1000.0,
            image_height=height,
            image_width=width,
            look_at=(0.0, 0.0, 0.0),
            up_direction=(0.0, 0.0, 1.0),
        )
        await ws.send(msgspec.msgpack.encode(camera.as_serializable_dict()))
        k = len(self.received)
        self.received.append(0)

        async def read():
            try:
                async for frame in ws:
                    self.received[k] += len(frame)
            except websockets.ConnectionClosed:
                pass

        self.tasks.append(asyncio.ensure_future(read()))
        self.sockets.append(ws)
        return ws

    def connect(self, n: int, width: int = 900, height: int = 700) -> list:
        """Open ``n`` clients at once (concurrently); returns their websockets."""

        async def many():
            return await asyncio.gather(*(self._one(width, height) for _ in range(n)))

        return self._run(many())

    def press(self, ws, handle, value) -> None:
        """What the page sends when a button (of a button group: ``value``) is clicked."""
        message = messages.GuiUpdateMessage(uuid=handle._impl.uuid, updates={"value": value})
        self._run(ws.send(msgspec.msgpack.encode(message.as_serializable_dict())))

    def close(self) -> None:
        async def close_all():
            await asyncio.gather(*(ws.close() for ws in self.sockets), return_exceptions=True)
            for task in self.tasks:
                task.cancel()

        try:
            self._run(close_all(), timeout=30)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(timeout=10)


@pytest.fixture
def served():
    from fuzzynav.app.viewer_ui import ViewerServer

    server = ViewerServer(ViewerApp("s1", "p"), port=0)
    yield server
    server.stop()


def wait_until(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def test_forty_tabs_joining_at_once_do_not_stall_another_tabs_buttons(served, capfd):
    """Defect 2: each new tab held one of viser's 32 worker threads for 20 s (a polling
    loop in the connect callback), so after 32 joined, every button of every tab waited
    for a free thread (a Speed click took 18 s). Now a press from another tab takes
    effect within a second while 40 tabs join together, and nothing is logged."""
    clients = ScriptedClients(served.url)
    try:
        (teacher,) = clients.connect(1)
        assert wait_until(lambda: len(served.server.get_clients()) == 1, 30)
        served.app.play()
        started = time.perf_counter()
        clients.connect(40)
        joined = time.perf_counter() - started
        assert wait_until(lambda: len(served.server.get_clients()) == 41, 30)
        # every new tab has been given the page: the scene and the panels
        assert wait_until(lambda: min(clients.received[1:]) > 10_000, 30), clients.received
        # the class has joined; a tab presses Speed 0.25 at once
        pressed = time.perf_counter()
        clients.press(teacher, served.speed, "0.25")
        assert wait_until(lambda: served.app.speed == 0.25, 10)
        latency = time.perf_counter() - pressed
        # and again a little later (a click queued behind the joiners would show here)
        time.sleep(0.5)
        pressed = time.perf_counter()
        clients.press(teacher, served.speed, "3")
        assert wait_until(lambda: served.app.speed == 3.0, 10)
        latency = max(latency, time.perf_counter() - pressed)
        with capfd.disabled():
            print(f"\n40 clients joined in {joined:.2f} s; button latency {latency:.3f} s")
        assert latency < 1.0, latency
        assert joined < 10.0, joined
        # the world kept running for everyone
        t = served.app.sim.time_s
        assert served.app.wait_for(lambda a: a.sim.time_s > t + 0.3, timeout=10)
    finally:
        clients.close()
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Error" not in err, err[-3000:]
