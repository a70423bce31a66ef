"""The private names fuzzynav takes from viser are there, and do what
the public API does: an upgrade that moves one fails here, loudly,
instead of silently slowing down or changing a run."""

from __future__ import annotations

import asyncio
import re
import warnings

import pytest

# -- viser (app/viewer/compat_viser.py) ---------------------------------------------------


@pytest.fixture(scope="module")
def viser_server():
    import viser

    server = viser.ViserServer(host="127.0.0.1", port=0)
    try:
        yield server
    finally:
        server.stop()


def test_the_installed_viser_is_one_compat_viser_was_checked_on():
    from fuzzynav.app.viewer import compat_viser

    installed = compat_viser.installed_version()
    if not compat_viser.is_supported():
        pytest.fail(
            f"viser {installed}: app/viewer/compat_viser.py was checked on "
            f"{compat_viser.SUPPORTED[0]}.x to {compat_viser.SUPPORTED[1]}.x; check its "
            "private names and update SUPPORTED"
        )


def test_the_installed_viser_has_every_private_name_the_viewer_reads(viser_server):
    from fuzzynav.app.viewer import compat_viser

    version = compat_viser.installed_version()
    assert compat_viser.missing_names() == [], f"viser {version} lacks them"
    assert compat_viser.missing_names(viser_server) == [], f"viser {version} lacks them"
    # ... and they are what the viewer takes them for
    gui = viser_server.gui
    box = gui.add_number("compat", 1.5)
    try:
        assert compat_viser.input_handle(gui, compat_viser.handle_uuid(box)) is box
        assert compat_viser.handle_value(box) == 1.5 == box.value
        assert not compat_viser.is_button(box) and not compat_viser.is_removed(box)
        calls = []
        box.on_update(calls.append)
        assert compat_viser.update_callbacks(box) == [calls.append]
        assert isinstance(compat_viser.upload_states(gui), dict)
        handlers = compat_viser.incoming_handlers(
            gui, compat_viser.message_class("GuiUpdateMessage")
        )
        assert handlers and all(callable(h) for h in handlers)
        assert compat_viser.resolve_client(gui, 12345) is None  # no such client
    finally:
        box.remove()
    assert compat_viser.is_removed(box)
    node = viser_server.scene.add_frame("/compat")
    assert not compat_viser.is_removed(node)
    node.remove()
    assert compat_viser.is_removed(node)
    compat_viser.sweep_scene_buffer(viser_server)  # viser's own sweep, called as it calls it


def test_the_accessors_the_tests_play_a_client_with_are_what_they_take_them_for(
    monkeypatch, viser_server
):
    from viser import _gui_api

    from fuzzynav.app.viewer import compat_viser

    gui = viser_server.gui
    box = gui.add_number("compat client", 1.5)
    try:
        real_sync = compat_viser.sync_callback(box)
        synced = []
        compat_viser.set_sync_callback(box, lambda *args: synced.append(args))
        update = compat_viser.message_class("GuiUpdateMessage")
        uuid = compat_viser.handle_uuid(box)
        asyncio.run(compat_viser.handle_incoming(gui, 7, update(uuid, {"value": 2.5})))
        assert box.value == 2.5 and synced == [(7, {"value": 2.5})]
        compat_viser.set_sync_callback(box, real_sync)
        assert compat_viser.sync_callback(box) is real_sync
        compat_viser.set_handle_value(box, 3.5)
        assert compat_viser.handle_value(box) == 3.5 == box.value
    finally:
        box.remove()
    assert compat_viser.thread_executor(gui).submit(lambda: 4).result(timeout=10) == 4
    camera = compat_viser.message_class("ViewerCameraMessage")
    assert camera(**{k: None for k in compat_viser.CLIENT_MESSAGE_FIELDS[camera.__name__]})
    monkeypatch.setattr(_gui_api, "_global_order_counter", 10)
    compat_viser.raise_order_counter(5000)
    assert _gui_api._global_order_counter == 5000
    compat_viser.raise_order_counter(20)  # never lowered
    assert _gui_api._global_order_counter == 5000


def test_compat_viser_finds_a_name_that_is_gone(monkeypatch):
    from viser import _messages

    from fuzzynav.app.viewer import compat_viser

    monkeypatch.delattr(_messages, "FileTransferPart")
    assert compat_viser.missing_names() == ["viser._messages.FileTransferPart"]


def test_compat_viser_finds_the_scene_sweep_gone(monkeypatch):
    from viser import _viser

    from fuzzynav.app.viewer import compat_viser

    monkeypatch.delattr(_viser.ViserServer, "_run_garbage_collector")
    assert compat_viser.missing_names() == ["viser._viser.ViserServer._run_garbage_collector"]


@pytest.mark.parametrize("version", ["1.0.3", "1.2.0", "2.0.0", "0.2.7"])
def test_installing_the_guards_warns_once_on_a_viser_outside_supported(
    monkeypatch, viser_server, version
):
    from fuzzynav.app.viewer import compat_viser
    from fuzzynav.app.viewer.guards import install_message_guards

    monkeypatch.setattr(compat_viser, "installed_version", lambda: version)
    monkeypatch.setattr(compat_viser, "_warned", False)
    with pytest.warns(UserWarning, match=rf"viser {re.escape(version)} .*compat_viser\.py"):
        install_message_guards(viser_server, 1000)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        install_message_guards(viser_server, 1000)  # once a process


def test_installing_the_guards_is_silent_on_a_supported_viser(monkeypatch, viser_server):
    from fuzzynav.app.viewer import compat_viser
    from fuzzynav.app.viewer.guards import install_message_guards

    low = compat_viser.SUPPORTED[0]
    monkeypatch.setattr(compat_viser, "installed_version", lambda: f"{low}.99")
    monkeypatch.setattr(compat_viser, "_warned", False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        install_message_guards(viser_server, 1000)
