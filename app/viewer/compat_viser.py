"""What the viewer takes from viser beyond its public API, in one place, checked.

viser has no public API for what the viewer's message guards (:mod:`.guards`) and a few
panels need, so they read viser's internals, here and nowhere else:

- a GUI handle's ``_impl.uuid``: the id viser's page gives the widget (a ``<label
  for=uuid>``), which the classroom's token box, the editor's term plots and the what-if
  plots name in their HTML to reach the widget from the page;
- its ``_impl.value``: the value viser holds, read when a client's update arrives,
  before viser casts it (the guards compare and cast as viser does);
- its ``_impl.update_cb`` and ``_impl.is_button``: the callbacks viser calls on a
  changed value, which the guards call themselves for an update viser would drop as
  "no change";
- a GUI or scene handle's ``_impl.removed``: whether viser has removed it (a drag may
  outlive its node when another tab resets the run);
- ``GuiApi._gui_input_handle_from_uuid``: the handle a client's update names;
- ``GuiApi._current_file_upload_states``: the uploads under way, bounded by the guards;
- ``GuiApi._websock_interface._incoming_handlers``: viser's message handlers, the only
  place a guard can be put in front of them;
- ``GuiApi._resolve_client``, ``GuiApi._thread_executor`` and
  ``viser._threadpool_exceptions.print_threadpool_errors``: to call update callbacks as
  viser calls them (a thread of viser's pool, errors printed as viser prints them);
- ``viser._messages``' ``GuiUpdateMessage``, ``FileTransferStartUpload`` and
  ``FileTransferPart`` (and the fields the guards read): the messages guarded.

The tests, which play a raw or malicious client, take a few more, through the same
accessors: ``WebsockMessageHandler._handle_incoming_message`` (a message handled as if a
client had sent it), ``GuiApi._thread_executor`` itself, a GUI handle's ``_impl.sync_cb``
and its ``_impl.value`` set (a race with the render thread played),
``viser._messages.ViewerCameraMessage`` (a scripted tab's first message) and
``viser._gui_api._global_order_counter`` (a server that has served many tabs).

They were checked on the viser versions :data:`SUPPORTED` names. On another version the
viewer still runs, but :func:`warn_if_unsupported` (called when the guards are
installed) warns once; ``tests/test_compat.py`` fails loudly when the installed viser
lacks one of the names (:func:`missing_names`) or is outside :data:`SUPPORTED`, so an
upgrade that moves them is seen at once.
"""

from __future__ import annotations

import dataclasses
import importlib
import re
import warnings
from collections.abc import Callable
from importlib.metadata import version
from typing import Any

__all__ = [
    "SUPPORTED",
    "installed_version",
    "is_supported",
    "warn_if_unsupported",
    "missing_names",
    "handle_uuid",
    "handle_value",
    "is_button",
    "is_removed",
    "update_callbacks",
    "input_handle",
    "upload_states",
    "message_class",
    "incoming_handlers",
    "resolve_client",
    "submit_callback",
    "handle_incoming",
    "sweep_scene_buffer",
    "thread_executor",
    "sync_callback",
    "set_sync_callback",
    "set_handle_value",
    "raise_order_counter",
]

#: The viser versions whose private names were checked: (oldest, newest) "major.minor",
#: both included (every 1.1.x).
SUPPORTED = ("1.1", "1.1")

#: The fields of a GUI handle's state (``_GuiHandleState``) read here.
GUI_STATE_FIELDS = ("uuid", "value", "update_cb", "is_button", "removed", "sync_cb")
#: The fields of a scene node handle's state (``_SceneNodeHandleState``) read here.
SCENE_STATE_FIELDS = ("removed",)
#: The keys of an upload under way (``_FileUploadState``) the guards read.
UPLOAD_STATE_KEYS = ("transferred_bytes", "total_bytes")
#: The messages guarded, and the fields of each the guards read.
MESSAGE_FIELDS = {
    "GuiUpdateMessage": ("uuid", "updates"),
    "FileTransferStartUpload": ("transfer_uuid", "size_bytes", "part_count"),
    "FileTransferPart": ("transfer_uuid", "content"),
}
#: The messages the tests send as a client would, beyond those guarded, and the fields
#: they set.
CLIENT_MESSAGE_FIELDS = {
    "ViewerCameraMessage": (
        "wxyz",
        "position",
        "fov",
        "near",
        "far",
        "image_height",
        "image_width",
        "look_at",
        "up_direction",
    ),
}
#: The attributes of a live ``GuiApi`` (set in its ``__init__``) read here.
GUI_API_ATTRIBUTES = (
    "_gui_input_handle_from_uuid",
    "_current_file_upload_states",
    "_websock_interface",
    "_thread_executor",
)

_warned = False


def installed_version() -> str:
    """The installed viser's version, from its package metadata."""
    return version("viser")


def _major_minor(text: str) -> tuple[int, ...]:
    """``"1.1.1"`` -> ``(1, 1)``; ``"2rc1"`` -> ``(2,)``; not a version -> ``()``."""
    found = re.match(r"(\d+)(?:\.(\d+))?", text)
    return tuple(int(n) for n in found.groups() if n is not None) if found else ()


def is_supported(installed: str | None = None) -> bool:
    """Whether a viser version is within :data:`SUPPORTED`.

    Parameters
    ----------
    installed : str, optional
        A version ("1.1.1"); the installed one (:func:`installed_version`) by default.
    """
    mm = _major_minor(installed if installed is not None else installed_version())
    return _major_minor(SUPPORTED[0]) <= mm <= _major_minor(SUPPORTED[1])


def warn_if_unsupported() -> None:
    """Warn, once a process, when the installed viser is outside :data:`SUPPORTED` (the
    viewer runs on: a moved name fails where it is used)."""
    global _warned
    if _warned:
        return
    installed = installed_version()
    if not is_supported(installed):
        _warned = True
        warnings.warn(
            f"viser {installed} is outside the versions fuzzynav's viewer was checked on "
            f"({SUPPORTED[0]}.x to {SUPPORTED[1]}.x): the private names it reads "
            "(fuzzynav/app/viewer/compat_viser.py) may have moved; "
            "tests/test_compat.py checks them",
            stacklevel=2,
        )


def _field_names(cls: Any) -> set[str]:
    """The fields of a dataclass, else none."""
    return {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()


def _missing_in_modules() -> list[str]:
    """The names :func:`missing_names` checks on viser's modules and classes."""
    missing: list[str] = []

    def module(name: str) -> Any:
        try:
            return importlib.import_module(name)
        except ImportError:
            missing.append(name)
            return None

    def needs(where: str, names: tuple[str, ...], present: set[str]) -> None:
        missing.extend(f"{where}.{name}" for name in names if name not in present)

    threadpool = module("viser._threadpool_exceptions")
    if threadpool is not None and not hasattr(threadpool, "print_threadpool_errors"):
        missing.append("viser._threadpool_exceptions.print_threadpool_errors")
    props = module("viser._assignable_props_api")
    base = getattr(props, "AssignablePropsBase", None)
    if props is not None and "_impl" not in getattr(base, "__annotations__", {}):
        missing.append("viser._assignable_props_api.AssignablePropsBase._impl")
    handles = module("viser._gui_handles")
    if handles is not None:
        state = getattr(handles, "_GuiHandleState", None)
        needs("viser._gui_handles._GuiHandleState", GUI_STATE_FIELDS, _field_names(state))
    scene = module("viser._scene_handles")
    if scene is not None:
        state = getattr(scene, "_SceneNodeHandleState", None)
        where = "viser._scene_handles._SceneNodeHandleState"
        needs(where, SCENE_STATE_FIELDS, _field_names(state))
    viser_module = module("viser._viser")
    if viser_module is not None and not callable(
        getattr(getattr(viser_module, "ViserServer", None), "_run_garbage_collector", None)
    ):
        missing.append("viser._viser.ViserServer._run_garbage_collector")
    gui_api = module("viser._gui_api")
    if gui_api is not None:
        if not isinstance(getattr(gui_api, "_global_order_counter", None), int):
            missing.append("viser._gui_api._global_order_counter")
        if not callable(getattr(getattr(gui_api, "GuiApi", None), "_resolve_client", None)):
            missing.append("viser._gui_api.GuiApi._resolve_client")
        upload = getattr(gui_api, "_FileUploadState", None)
        keys = set(getattr(upload, "__annotations__", {}))
        needs("viser._gui_api._FileUploadState", UPLOAD_STATE_KEYS, keys)
    infra = module("viser.infra")
    handler_cls = getattr(infra, "WebsockMessageHandler", None)
    if infra is not None and (
        handler_cls is None
        or not isinstance(getattr(handler_cls(), "_incoming_handlers", None), dict)
    ):
        missing.append("viser.infra.WebsockMessageHandler._incoming_handlers")
    if infra is not None and not callable(getattr(handler_cls, "_handle_incoming_message", None)):
        missing.append("viser.infra.WebsockMessageHandler._handle_incoming_message")
    messages = module("viser._messages")
    if messages is not None:
        for name, fields in (MESSAGE_FIELDS | CLIENT_MESSAGE_FIELDS).items():
            cls = getattr(messages, name, None)
            if cls is None:
                missing.append(f"viser._messages.{name}")
            else:
                needs(f"viser._messages.{name}", fields, _field_names(cls))
    return missing


def missing_names(server: Any = None) -> list[str]:
    """Every private name of viser this module relies on that the installed viser lacks
    (``[]`` when all are there), checked on viser's modules and classes; the attributes
    a ``GuiApi`` sets in its ``__init__`` are checked too when a live ``server`` is given.

    Parameters
    ----------
    server : viser.ViserServer, optional
        A started server, whose ``gui`` (and one input added to it, then removed) is
        checked for the attributes only an instance has.
    """
    missing = _missing_in_modules()
    if server is None:
        return missing
    gui = server.gui
    missing.extend(f"GuiApi.{name}" for name in GUI_API_ATTRIBUTES if not hasattr(gui, name))
    interface = getattr(gui, "_websock_interface", None)
    if interface is not None and not isinstance(
        getattr(interface, "_incoming_handlers", None), dict
    ):
        missing.append("GuiApi._websock_interface._incoming_handlers")
    box = gui.add_number("fuzzynav compat check", 0.0)
    try:
        impl = getattr(box, "_impl", None)
        if impl is None:
            missing.append("GuiInputHandle._impl")
        else:
            missing.extend(
                f"GuiInputHandle._impl.{name}"
                for name in GUI_STATE_FIELDS
                if not hasattr(impl, name)
            )
        registered = getattr(gui, "_gui_input_handle_from_uuid", {})
        if impl is not None and registered.get(getattr(impl, "uuid", None)) is not box:
            missing.append("GuiApi._gui_input_handle_from_uuid[uuid]")
    finally:
        box.remove()
    return missing


def handle_uuid(handle: Any) -> str:
    """The id viser gives a GUI handle's widget (its page labels it ``for=`` this id).

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input (a number, a slider, a text box...).
    """
    return handle._impl.uuid


def handle_value(handle: Any) -> Any:
    """The value viser holds for a GUI input (no cast, no copy).

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    """
    return handle._impl.value


def is_button(handle: Any) -> bool:
    """Whether a GUI input is a button (viser handles its updates apart).

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    """
    return bool(handle._impl.is_button)


def is_removed(handle: Any) -> bool:
    """Whether viser has removed a GUI or scene handle.

    Parameters
    ----------
    handle : viser GUI or scene node handle
        The handle.
    """
    return bool(handle._impl.removed)


def update_callbacks(handle: Any) -> list[Callable[..., Any]]:
    """The callbacks viser calls when a client changes a GUI input: viser's own list.

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    """
    return handle._impl.update_cb


def input_handle(gui: Any, uuid: str) -> Any:
    """The GUI input whose id is ``uuid``, or None.

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    uuid : str
        The id a client's update names.
    """
    return gui._gui_input_handle_from_uuid.get(uuid)


def upload_states(gui: Any) -> dict[str, Any]:
    """The uploads under way on ``gui``: viser's own dict, transfer id -> its state (a
    dict with ``transferred_bytes`` and ``total_bytes``, among others).

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    """
    return gui._current_file_upload_states


def message_class(name: str) -> type:
    """One of viser's message classes, by name (a key of :data:`MESSAGE_FIELDS` or of
    :data:`CLIENT_MESSAGE_FIELDS`).

    Parameters
    ----------
    name : str
        Its class name, e.g. ``"GuiUpdateMessage"``.
    """
    from viser import _messages

    return getattr(_messages, name)


def incoming_handlers(gui: Any, message_cls: type) -> list[Callable[..., Any]]:
    """The handlers viser calls for a message class: viser's own list, which a guard
    may replace items of in place (an empty new list when there are none).

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    message_cls : type
        The message class (:func:`message_class`).
    """
    return gui._websock_interface._incoming_handlers.get(message_cls, [])


def resolve_client(gui: Any, client_id: int) -> Any:
    """The ``viser.ClientHandle`` of ``client_id``, or None once it has left.

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    client_id : int
        The client's id, as a handler is given it.
    """
    return gui._resolve_client(client_id)


def submit_callback(gui: Any, callback: Callable[..., Any], event: Any) -> None:
    """Call ``callback(event)`` on viser's thread pool, its errors printed as viser
    prints them.

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    callback : callable
        An update callback (not a coroutine function).
    event : viser.GuiEvent
        Its argument.
    """
    from viser._threadpool_exceptions import print_threadpool_errors

    gui._thread_executor.submit(callback, event).add_done_callback(print_threadpool_errors)


async def handle_incoming(gui: Any, client_id: int, message: Any) -> None:
    """Hand ``message`` to viser's handlers as if client ``client_id`` had sent it (each
    guard and handler in turn, as viser's websocket does).

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    client_id : int
        The client the message is said to come from.
    message : viser message
        A message (an instance of a :func:`message_class`).
    """
    await gui._websock_interface._handle_incoming_message(client_id, message)


def thread_executor(gui: Any) -> Any:
    """viser's thread pool, on which it calls update callbacks: viser's own executor.

    Parameters
    ----------
    gui : viser.GuiApi
        A server's (or a client's) GUI.
    """
    return gui._thread_executor


def sync_callback(handle: Any) -> Callable[..., Any] | None:
    """The callback viser calls, with ``(client_id, updates)``, between setting a GUI
    input's value from a client's update and calling its update callbacks, or None.

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    """
    return handle._impl.sync_cb


def set_sync_callback(handle: Any, callback: Callable[..., Any] | None) -> None:
    """Replace the callback :func:`sync_callback` returns.

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    callback : callable or None
        Called with ``(client_id, updates)``; None for none.
    """
    handle._impl.sync_cb = callback


def set_handle_value(handle: Any, value: Any) -> None:
    """Set the value viser holds for a GUI input (no cast, no callback, nothing sent to
    the clients): what :func:`handle_value` then returns.

    Parameters
    ----------
    handle : viser GUI handle
        A GUI input.
    value : object
        Its new value.
    """
    handle._impl.value = value


def raise_order_counter(at_least: int) -> None:
    """Raise viser's server-wide counter of GUI element orders to ``at_least`` (left as
    it is when already past it), as if many elements had been added.

    Parameters
    ----------
    at_least : int
        The lowest value the counter is left at.
    """
    from viser import _gui_api

    _gui_api._global_order_counter = max(_gui_api._global_order_counter, at_least)


def sweep_scene_buffer(server: Any) -> None:
    """Drop from ``server``'s scene message buffer the removal messages every tab has
    read, and what else targets a removed node: viser's own sweep
    (``ViserServer._run_garbage_collector``), which it runs only when a tab connects.
    A server without it (a classroom tab's scene, or another viser) is left alone.

    Parameters
    ----------
    server : viser.ViserServer
        A started server.
    """
    collect = getattr(server, "_run_garbage_collector", None)
    if collect is not None:
        collect()
