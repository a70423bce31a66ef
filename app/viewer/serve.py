"""``fuzzynav serve``: the viewer's command line (the server around :mod:`.server`).

The app model (:mod:`fuzzynav.app.viewer.model`) knows nothing of the browser; the browser
side (:mod:`fuzzynav.app.viewer.server`) uses the model; this module starts both.
"""

from __future__ import annotations

import os
import signal
import socket
import threading
import time
from pathlib import Path

from fuzzynav.app.args import UsageError, add_geometry_option, integer_in, scenario_help
from fuzzynav.app.viewer.model import ViewerApp, ViewerError

# ---------------------------------------------------------------------------------------
# Command line


def _check_rrd(path):
    """Refuse an --rrd path that cannot be written, before the server starts."""
    if path is None:
        return None
    try:
        import fuzzynav.app.recordings.record  # noqa: F401 - the recorder is installed
    except ModuleNotFoundError as exc:
        if exc.name not in ("fuzzynav.app.recordings.record", "rerun"):
            raise

        raise UsageError(
            "--rrd: live recording needs app/recordings/record.py and rerun-sdk, "
            "which are not available in this installation"
        ) from None
    from fuzzynav.safe_files import check_output_path

    # the one output guard: never among the shipped rule bases and scenarios, and a file
    # that can be written (the live recording is renamed into place)
    return check_output_path(path, "--rrd", stream_ok=False)


def check_host(host: str) -> None:
    """Refuse a host this machine cannot listen on, before the server starts.

    (viser 1.1 retries an address it cannot bind on the next thousand ports and then
    waits forever for a server that never started; a port already in use is fine: it
    takes the next free one, and the printed address says which.)
    """
    try:
        family, _, _, _, address = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)[0]
    except (socket.gaierror, UnicodeError) as exc:
        raise ViewerError(f"--host {host!r}: unknown host ({exc})") from None
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((address[0], 0))
        except OSError as exc:
            raise ViewerError(
                f"--host {host!r}: this machine cannot listen on that "
                f"address ({exc.strerror or exc})"
            ) from None


#: The highest port there is; the server takes the next free port above a taken one.
MAX_PORT = 65535
#: How many ports above a taken one the server tries (viser's own search).
PORT_SEARCH = 1000


def _port_free(family, address, port: int) -> bool:
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        # as the server's own socket (asyncio sets it on Unix): a port whose last
        # connection is in TIME_WAIT is free, one another program listens on is not
        if os.name != "nt":  # (there, SO_REUSEADDR would let it take a port in use)
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((address[0], port))
        except OSError:
            return False
        return True


def check_port(host: str, port: int) -> int:
    """The port the viewer will listen on: ``port`` when free, else the next free one
    above it (as the server would search), found before the server starts; 0 stays 0
    (any free port). ViewerError (exit status 2) when every port from ``port`` up to
    the last one the search reaches is taken: viser's own search ran past 65535 into
    ``OverflowError`` in a thread and waited for ever."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= MAX_PORT:
        raise ViewerError(f"--port {port!r}: must be an integer from 0 to {MAX_PORT}")
    if port == 0:
        return 0
    family, _, _, _, address = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)[0]
    last = min(port + PORT_SEARCH - 1, MAX_PORT)
    for candidate in range(port, last + 1):
        if _port_free(family, address, candidate):
            return candidate
    taken = f"port {port} is in use" if last == port else f"ports {port} to {last} are all in use"
    raise ViewerError(
        f"--port {port}: {taken} on {host} (from a taken port the viewer moves to the next "
        f"free one, and there is none up to {last}): give another port, or --port 0 for "
        "any free one"
    )


def _print_url(server, host: str, open_message: bool) -> None:
    if not open_message:
        return
    print(f"fuzzynav viewer: {server.url}  (Ctrl-C stops it)", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(
            f"fuzzynav viewer: bound to {host}: other machines on the network can "
            "open it and change the world",
            flush=True,
        )


def serve(
    scenario="s1",
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    rrd=None,
    controller: str | None = None,
    open_message: bool = True,
    block: bool = True,
    geometry: str = "husky",
    classroom: bool = False,
    lesson=None,
):
    """Start the viewer. With ``block`` it runs until Ctrl-C and then stops cleanly;
    otherwise it returns the running :class:`app.viewer.server.ViewerServer` (or, with
    ``classroom``, the :class:`app.viewer.classroom.ClassroomServer`: a world per tab)."""
    from fuzzynav.app.viewer.server import ViewerServer

    if classroom and rrd is not None:
        raise UsageError("--rrd records one world: it cannot be used with --classroom")
    rrd = _check_rrd(rrd)
    check_host(host)
    port = check_port(host, port)
    app = ViewerApp(scenario, controller, rrd_path=rrd, geometry=geometry)  # checks them
    lesson_text = None
    if lesson is not None:  # a lesson file (--lesson): read and checked before serving
        from fuzzynav.resources import read_user_text

        try:
            lesson_text = read_user_text(lesson, "lesson file")
        except ValueError as exc:
            raise UsageError(f"--lesson: {exc}") from None
        try:
            view = app.open_lesson(lesson_text, str(lesson), background=True)
        except ViewerError as exc:
            raise UsageError(f"--lesson: {exc}") from None
    if classroom:
        from fuzzynav.app.viewer.classroom import ClassroomServer

        app = None

        def make_app():
            world = ViewerApp(scenario, controller, geometry=geometry)
            if lesson_text is not None:  # every tab opens the lesson in its own world
                world.open_lesson(lesson_text, str(lesson), background=True)
            return world

        server = ClassroomServer(make_app, host=host, port=port)
        if open_message:
            print(
                "fuzzynav viewer: classroom mode, every tab drives a world of its own; "
                f"the teacher's token (Teacher folder): {server.token}",
                flush=True,
            )
    else:
        server = ViewerServer(app, host=host, port=port)
        if lesson is not None:
            server.apply_view(view)
    if not block:
        _print_url(server, host, open_message)
        return server
    previous = None
    if threading.current_thread() is threading.main_thread():
        # `kill` (SIGTERM) stops the viewer as cleanly as Ctrl-C does.
        def on_term(signum, frame):
            raise KeyboardInterrupt

        previous = signal.signal(signal.SIGTERM, on_term)
    try:
        # The URL is printed inside the try: a Ctrl-C that arrives as soon as a user (or a
        # test) sees it must still stop the server cleanly.
        _print_url(server, host, open_message)
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        server.stop()
        files = ", ".join(str(p) for p in app.recorded_files) if app is not None else ""
        print(
            "fuzzynav viewer: stopped, port released" + (f"; recorded {files}" if files else ""),
            flush=True,
        )
    return None


def cmd_serve(args) -> int:
    serve(
        args.scenario,
        host=args.host,
        port=args.port,
        rrd=args.rrd,
        controller=getattr(args, "controller", None),
        geometry=getattr(args, "geometry", "husky"),
        classroom=getattr(args, "classroom", False),
        lesson=getattr(args, "lesson", None),
    )
    return 0


def add_commands(subparsers) -> None:
    from fuzzynav.controller.registry import controller_names

    parser = subparsers.add_parser("serve", help="start the interactive browser viewer")
    parser.add_argument("scenario", nargs="?", default="s1", help=scenario_help())
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to bind (default 127.0.0.1: this machine only)",
    )
    parser.add_argument(
        "--port",
        type=integer_in(0, 65535),
        default=8080,
        help="port (default 8080; the next free one if taken)",
    )
    parser.add_argument(
        "--rrd",
        type=Path,
        metavar="PATH",
        help="also record the session to rerun files: the first run "
        "to PATH, later runs to <stem>-run2.rrd, ... (the first free number; "
        "while another server records to PATH, every run is numbered)",
    )
    parser.add_argument(
        "--controller",
        choices=controller_names(),
        help="controller to start with (default: paper)",
    )
    add_geometry_option(parser)
    parser.add_argument(
        "--classroom",
        action="store_true",
        help="every tab drives a world of its own; a teacher's tab (with the "
        "token printed at start) can push its setup to all",
    )
    parser.add_argument(
        "--lesson",
        metavar="FILE",
        help="open a lesson saved from the page (Lesson → Save lesson): its "
        "scenario, layout, controller, settings, view and time",
    )
    parser.set_defaults(func=cmd_serve)
    # demo: serve with every option at its default
    demo = subparsers.add_parser("demo", help="the viewer on scenario s1 with default settings")
    demo.set_defaults(**vars(parser.parse_args([])))
