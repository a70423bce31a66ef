"""What the viewer's server takes from a browser: checked before viser acts on it.

A raw websocket client can send any message a browser could, with any values. viser
trusts them; these guards sit in front of its handlers:

- a GUI update may set a component's ``value`` only (an ``update_cb`` key would replace
  a widget's callbacks for every client), and a number never becomes NaN or infinite;
- an upload declared larger than the viewer takes is refused at its first message, and
  one whose parts pass their declared size is dropped;
- uploads under way are bounded: at most :data:`.budget.MAX_UPLOADS_IN_FLIGHT` at once
  on one GUI (a tab's in a classroom, the server's otherwise), each charged its declared
  size to the world's account in the server's budget while under way, and one not whole
  :data:`.budget.UPLOAD_TIMEOUT_S` after its first message is dropped.

What each guard stops, and the test that shows it: docs/robustness.md.

viser has no public API for its handlers, widgets' state or uploads under way: every
private name of viser read here is read through :mod:`.compat_viser`.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import inspect
import math
import time
from collections.abc import Callable

from fuzzynav.app.viewer import compat_viser as _viser
from fuzzynav.app.viewer.budget import MAX_UPLOADS_IN_FLIGHT, UPLOAD_TIMEOUT_S

__all__ = ["install_message_guards", "value_sent", "ALLOWED_GUI_PROPS"]

#: (handle, value) of the GUI update being handled: the value the client sent, as viser
#: casts it. Set on viser's event loop for the length of the update's handling.
_SENT: contextvars.ContextVar = contextvars.ContextVar("fuzzynav_value_sent", default=None)

#: The only property of a GUI component a client may change.
ALLOWED_GUI_PROPS = frozenset({"value"})


def _finite(value) -> bool:
    """Whether a value holds no NaN or infinity (a number, or a tuple of them)."""
    if isinstance(value, bool):
        return True
    if isinstance(value, int | float):
        return math.isfinite(value)
    if isinstance(value, list | tuple):
        return all(_finite(v) for v in value)
    return True


def _cast_as_viser(current, value):
    """``value`` cast to the type of the widget's ``current`` value, as viser does."""
    if isinstance(current, tuple):
        return tuple(type(current[0])(v) for v in value) if current else tuple(value)
    return type(current)(value)


def value_sent(handle):
    """The value a client sent for ``handle`` in the update being handled, else the
    widget's value. Read in an update callback: the render thread (another OS thread)
    may set the widget back to the world's value at any moment after viser set it, even
    before the callback's first line (CI: a controller press applied the old
    controller, "Controller: p.")."""
    sent = _SENT.get()
    if sent is not None and sent[0] is handle:
        return sent[1]
    return handle.value


def _unchanged(handle, value) -> bool:
    """Whether viser would take ``value`` as no change of an input's value."""
    current = _viser.handle_value(handle)
    if _viser.is_button(handle) or _viser.is_removed(handle) or isinstance(current, tuple):
        return False
    try:
        return current == type(current)(value)
    except (TypeError, ValueError):
        return False


async def _run_callbacks(gui, client_id, handle) -> None:
    """Call an input's update callbacks as viser does for a changed value."""
    from viser import GuiEvent

    client = _viser.resolve_client(gui, client_id)
    if client is None:
        return
    for cb in list(_viser.update_callbacks(handle)):
        if inspect.iscoroutinefunction(cb):
            await cb(GuiEvent(client, client_id, handle))
        else:
            _viser.submit_callback(gui, cb, GuiEvent(client, client_id, handle))


def _wrap(gui, message_name, make_guard) -> None:
    """Put a guard in front of each handler ``gui``'s server has for a message class
    (named as :data:`.compat_viser.MESSAGE_FIELDS` names it)."""
    handlers = _viser.incoming_handlers(gui, _viser.message_class(message_name))
    for k, handler in enumerate(list(handlers)):
        handlers[k] = make_guard(handler)


class UploadsUnderWay:
    """The uploads under way on one GUI: when each began and what it was charged.

    ``account`` (a :class:`.budget.Account`, optional) is charged each upload's declared
    size while it is under way. Runs on viser's event loop, as its upload handlers do."""

    def __init__(self, gui, account=None, clock=time.monotonic, say=None):
        self.gui, self.account, self.clock = gui, account, clock
        self.say = say or (lambda text: None)
        self.began: dict[str, tuple[float, int]] = {}  # transfer -> (time, bytes charged)

    def sweep(self) -> None:
        """Forget the uploads that ended; drop those not whole in time."""
        states = _viser.upload_states(self.gui)
        now = self.clock()
        for transfer, (began, charged) in list(self.began.items()):
            if transfer in states and now - began <= UPLOAD_TIMEOUT_S:
                continue
            if transfer in states:
                states.pop(transfer, None)
                self.say(
                    f"upload dropped: not whole {UPLOAD_TIMEOUT_S:g} s after it began "
                    f"({charged} bytes declared)"
                )
            del self.began[transfer]
            if self.account is not None:
                self.account.give("uploads", charged)

    def admit(self, transfer: str, size: int) -> str | None:
        """Why a new upload is refused, or None (and it is counted from now)."""
        self.sweep()
        if len(self.began) >= MAX_UPLOADS_IN_FLIGHT:
            return (
                f"upload refused: {len(self.began)} uploads are under way already (at most "
                f"{MAX_UPLOADS_IN_FLIGHT}); try again when they are done"
            )
        if self.account is not None and not self.account.take("uploads", size):
            return "upload refused: the server's memory budget is spent"
        self.began[transfer] = (self.clock(), size)
        # ... and swept when it is due, whatever else arrives (no loop running, called
        # from a test: swept lazily)
        with contextlib.suppress(RuntimeError):
            asyncio.get_running_loop().call_later(UPLOAD_TIMEOUT_S + 0.5, self.sweep)
        return None


def install_message_guards(
    server,
    max_upload_bytes: int,
    on_refused: Callable[[str], None] | None = None,
    account=None,
    clock=time.monotonic,
) -> UploadsUnderWay:
    """Guard the GUI and upload messages of a ``viser.ViserServer`` (module doc).
    ``on_refused(text)`` is told of each refusal (the viewer shows it); ``account`` is
    charged the uploads under way. Returns what counts them."""
    _viser.warn_if_unsupported()
    gui = server.gui
    say = on_refused or (lambda text: None)
    uploads = UploadsUnderWay(gui, account, clock, say)

    def gui_guard(handler):
        async def guarded(client_id, message):
            handle = _viser.input_handle(gui, message.uuid)
            updates = message.updates if isinstance(message.updates, dict) else {}
            kept = {k: v for k, v in updates.items() if k in ALLOWED_GUI_PROPS}
            if not kept:
                return
            if "value" in kept and handle is not None:
                current = _viser.handle_value(handle)
                numeric = isinstance(current, int | float | tuple) and not isinstance(current, bool)
                if numeric and not _finite(kept["value"]):
                    say(f"refused a value that is not a finite number: {kept['value']!r}")
                    return
            message.updates = kept
            token = None
            if "value" in kept and handle is not None:
                # (a value viser's cast refuses is refused as viser would have)
                with contextlib.suppress(TypeError, ValueError, IndexError):
                    sent = _cast_as_viser(_viser.handle_value(handle), kept["value"])
                    token = _SENT.set((handle, sent))
            try:
                if "value" in kept and handle is not None and _unchanged(handle, kept["value"]):
                    # viser drops a value equal to the widget's as "no change". But the
                    # render thread's sync may have just written a stale value into the
                    # widget (taken before a scenario load ended): the press that restores
                    # it was dropped. The client changed its widget, so its callbacks run.
                    await _run_callbacks(gui, client_id, handle)
                    return
                result = handler(client_id, message)
                if inspect.isawaitable(result):
                    await result
            finally:
                if token is not None:
                    _SENT.reset(token)

        return guarded

    def start_guard(handler):
        def guarded(client_id, message):
            size, parts = message.size_bytes, message.part_count
            if not (
                isinstance(size, int)
                and isinstance(parts, int)
                and 0 <= size <= max_upload_bytes
                and 0 <= parts <= max(1, size)
            ):
                say(
                    f"upload refused: {size!r} bytes declared, at most {max_upload_bytes} are taken"
                )
                return  # never registered: its parts are dropped as they come
            why = uploads.admit(message.transfer_uuid, size)
            if why is not None:
                say(why)
                return
            result = handler(client_id, message)
            uploads.sweep()  # (a zero-byte upload ends at once)
            return result

        return guarded

    def part_guard(handler):
        def guarded(client_id, message):
            states = _viser.upload_states(gui)
            state = states.get(message.transfer_uuid)
            if state is not None:
                content = message.content if isinstance(message.content, bytes) else b""
                if state["transferred_bytes"] + len(content) > state["total_bytes"]:
                    states.pop(message.transfer_uuid, None)
                    uploads.sweep()
                    say("upload refused: more bytes than it declared")
                    return
            try:
                return handler(client_id, message)
            finally:
                if message.transfer_uuid not in _viser.upload_states(gui):
                    uploads.sweep()  # ended: its charge is given back

        return guarded

    _wrap(gui, "GuiUpdateMessage", gui_guard)
    _wrap(gui, "FileTransferStartUpload", start_guard)
    _wrap(gui, "FileTransferPart", part_guard)
    return uploads
