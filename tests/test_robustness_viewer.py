"""Issue 26, viewer: what a raw websocket client sends is checked before viser acts on
it, a refused drag is drawn back, and live recordings never collide. The messages are
handed to the server's own handlers, as its websocket would. Each test failed before."""

from __future__ import annotations

import asyncio
import math
from types import SimpleNamespace

import pytest

from fuzzynav.app.viewer import compat_viser
from fuzzynav.app.viewer.model import MAX_UPLOAD_BYTES, ViewerApp

pytest.importorskip("viser")
GuiUpdateMessage = compat_viser.message_class("GuiUpdateMessage")
FileTransferStartUpload = compat_viser.message_class("FileTransferStartUpload")
FileTransferPart = compat_viser.message_class("FileTransferPart")


@pytest.fixture
def served():
    from fuzzynav.app.viewer.server import ViewerServer

    server = ViewerServer(ViewerApp("s1", "p"), port=0)
    yield server
    server.stop()


def _deliver(server, message) -> None:
    """Dispatch ``message`` as if a client had sent it."""
    asyncio.run(compat_viser.handle_incoming(server.server.gui, 1, message))


def test_a_gui_update_sets_only_the_value(served):
    """The key update_cb replaced the scenario dropdown's callbacks for every client."""
    dropdown = served.controls.scenario_dd
    uuid = compat_viser.handle_uuid(dropdown)
    callbacks = list(compat_viser.update_callbacks(dropdown))
    assert callbacks
    _deliver(served, GuiUpdateMessage(uuid, {"update_cb": []}))
    assert compat_viser.update_callbacks(dropdown) == callbacks
    # a value is still taken. This raw client is not connected, so viser calls no
    # callback and the render thread's sync would soon put the world's s1 back: stop it
    # first, so that what is checked is what the guard let through.
    served.render.stop()
    _deliver(served, GuiUpdateMessage(uuid, {"value": "s2"}))
    assert compat_viser.handle_value(dropdown) == "s2"


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_a_slider_never_becomes_nan(served, value):
    """An editor slider set to NaN stayed NaN."""
    slider = served.controls.noise
    before = compat_viser.handle_value(slider)
    _deliver(served, GuiUpdateMessage(compat_viser.handle_uuid(slider), {"value": value}))
    after = compat_viser.handle_value(slider)
    assert after == before and math.isfinite(after)


def test_an_upload_is_refused_at_its_declared_size(served):
    """Declared 1 TB, then 400 MB of parts: the server grew by 500 MB before refusing."""
    gui = served.server.gui
    uuid = compat_viser.handle_uuid(served.controls.scenario_upload)
    start = FileTransferStartUpload(
        uuid, "t1", "big.toml", "text/plain", part_count=10_000_000, size_bytes=10**12
    )
    _deliver(served, start)
    assert "t1" not in compat_viser.upload_states(gui)
    part = FileTransferPart(uuid, "t1", 0, b"x" * 1024)
    _deliver(served, part)
    assert "t1" not in compat_viser.upload_states(gui)
    # declared small, sent large: dropped at the part that passes the declared size
    small = FileTransferStartUpload(uuid, "t2", "s.toml", "text/plain", part_count=2, size_bytes=10)
    _deliver(served, small)
    assert "t2" in compat_viser.upload_states(gui)
    _deliver(served, FileTransferPart(uuid, "t2", 0, b"x" * (MAX_UPLOAD_BYTES)))
    assert "t2" not in compat_viser.upload_states(gui)


def _event(position, phase="update"):
    return SimpleNamespace(client=object(), phase=phase, target=SimpleNamespace(position=position))


@pytest.mark.parametrize("position", [(1e300, 0.0, 0.0), (math.nan, 1.0, 0.0)])
def test_a_refused_drag_is_drawn_back(served, position):
    """A handle dragged to 1e300 or NaN was refused but stayed drawn there."""
    target = tuple(served.app.snapshot().target)
    on_update = served.handles._make_drag_callback("/target", None)
    event = _event(position, "start")
    asyncio.run(on_update(event))
    assert tuple(event.target.position[:2]) == target
    assert "/target" not in served.handles.dragging


def test_a_drag_without_a_position_does_not_freeze_the_target(served):
    """An empty position raised in the callback and left the target held as dragged:
    its drawing froze for as long as the server ran."""
    on_update = served.handles._make_drag_callback("/target", None)
    asyncio.run(on_update(_event((), "start")))
    assert "/target" not in served.handles.dragging
    asyncio.run(on_update(_event(("a", "b"))))
    assert "/target" not in served.handles.dragging


def test_live_recordings_never_take_another_servers_file(tmp_path):
    """A second serve --rrd on the same path overwrote the first's -run2.rrd."""
    pytest.importorskip("fuzzynav.app.recordings.record")
    path = tmp_path / "session.rrd"
    other = tmp_path / "session-run2.rrd"
    other.write_bytes(b"the other server's second run")
    app = ViewerApp("s1", "p", rrd_path=path)
    try:
        for _ in range(2):
            with app.lock:
                for _ in range(5):
                    app.driver._step_locked()
            app.reset()
    finally:
        app.stop()
    assert app.recorded_files == [path, tmp_path / "session-run3.rrd"]
    assert other.read_bytes() == b"the other server's second run"
    assert all(p.stat().st_size > 1000 for p in app.recorded_files)


def test_serve_rrd_writes_a_file_only_for_a_run_that_stepped(tmp_path):
    """issue 26 item 14: with --rrd, 60 Reset clicks wrote 58 files. A run's file is
    written only when it has at least one step; the numbers follow the runs written."""
    pytest.importorskip("fuzzynav.app.recordings.record")
    path = tmp_path / "session.rrd"
    app = ViewerApp("s1", "p", rrd_path=path)
    try:
        for _ in range(60):
            app.reset()
        app.load_scenario("crossing")
        app.restore_layout()
        app.set_geometry("paper")
        app.set_geometry("husky")
        assert app.recorded_files == [] and list(tmp_path.iterdir()) == []
        for _ in range(3):
            app.step_once()
            for _ in range(20):
                app.reset()  # only the run before them has a step
        app.step_once()
    finally:
        app.stop()
    expected = [path] + [tmp_path / f"session-run{k}.rrd" for k in (2, 3, 4)]
    assert app.recorded_files == expected
    assert sorted(tmp_path.iterdir()) == sorted(expected)
    assert all(p.stat().st_size > 1000 for p in expected)


def test_a_second_server_on_the_same_path_never_replaces_the_first_s_first_run(tmp_path):
    """The first run went to --rrd itself in every server: a second serve --rrd on the
    same path, while the first ran, replaced the first's first run. The path is held by
    the server that wrote to it first until it stops; another numbers its runs."""
    pytest.importorskip("fuzzynav.app.recordings.record")
    import fcntl  # noqa: F401  (POSIX: the hold is an flock)

    path = tmp_path / "session.rrd"

    def one_run(app):
        with app.lock:
            for _ in range(5):
                app.driver._step_locked()
        app.reset()

    first, second = ViewerApp("s1", "p", rrd_path=path), ViewerApp("s2", "p", rrd_path=path)
    try:
        one_run(first)
        one_run(second)
        one_run(first)
        written = path.read_bytes()
    finally:
        second.stop()
        first.stop()
    assert first.recorded_files[0] == path
    assert path not in second.recorded_files and len(second.recorded_files) == 1
    assert len(set(first.recorded_files + second.recorded_files)) == 3
    assert path.read_bytes() == written  # not replaced by the second server's close
    third = ViewerApp("s1", "p", rrd_path=path)  # the first stopped: the path is free
    try:
        one_run(third)
    finally:
        third.stop()
    assert third.recorded_files == [path]
