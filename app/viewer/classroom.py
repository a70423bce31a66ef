"""``fuzzynav serve --classroom``: every tab drives a world of its own.

Each tab that connects gets its own :class:`app.viewer.model.ViewerApp` (its robot, its drags,
its controller) and its own scene and panels (a :class:`app.viewer.server.ViewerServer` on
the tab's client-scoped viser API, :class:`app.viewer.server.ClientSurface`). A tab that
types the teacher's token (printed at start) in its **Teacher** folder can push its
scenario (with its layout as edited), settings and Editor to every other tab.

The worlds are built one after the other on a thread of their own, not on viser's
worker threads: forty tabs joining at once then wait their turn for their page, while
every tab already there keeps its buttons. A tab whose world fails to build is tried
again (up to :data:`BUILD_ATTEMPTS` times, the traceback printed each time) and, if it
still fails, told so on its page: never left without a world and without a word.
"""

from __future__ import annotations

import queue
import secrets
import threading
import traceback

import viser

from fuzzynav.app.viewer.budget import MemoryBudget
from fuzzynav.app.viewer.compat_viser import handle_uuid
from fuzzynav.app.viewer.model import ViewerError
from fuzzynav.app.viewer.origin_guard import guarded_server_start

BUILD_ATTEMPTS = 3  # a tab's world is built at most this many times before it is told
TEACHER_ORDER = 1e15  # the Teacher folder's place: after every component viser numbers


class ServerLockText:
    LOCKED = "The teacher has locked the controls: watch, and wait for the teacher."
    UNLOCKED = "The teacher has unlocked the controls."


class ClassroomServer:
    """The viser server of a classroom: one world per tab (see the module doc)."""

    def __init__(self, make_app, host: str = "127.0.0.1", port: int = 8080, token=None):
        self.make_app = make_app  # () -> a new ViewerApp
        self.host = host
        self.token = token or secrets.token_urlsafe(6)
        with guarded_server_start(host):
            self.server = viser.ViserServer(host=host, port=port, label="fuzzynav", verbose=False)
        self.port = self.server.get_port()
        self.sessions: dict = {}  # client id -> ViewerServer
        self.teachers: set[int] = set()
        self.locked = False  # the teacher has locked the students' controls
        # what every tab's world makes the server keep, counted together
        self.budget = MemoryBudget()
        self._lock = threading.Lock()
        self._queue: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._builder = threading.Thread(
            target=self._build_loop, name="fuzzynav-classroom", daemon=True
        )
        self._builder.start()
        self._overview = threading.Thread(
            target=self._overview_loop, name="fuzzynav-classroom-overview", daemon=True
        )
        self._overview.start()
        self.server.on_client_connect(lambda client: self._queue.put(("connect", client)))
        self.server.on_client_disconnect(self._on_disconnect)

    def _on_disconnect(self, client) -> None:
        with self._lock:
            view = self.sessions.get(client.client_id)
        if view is not None:
            view.render.halt()  # no more frames for a closed tab; its world ends below
        self._queue.put(("disconnect", client))

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in ("", "0.0.0.0") else self.host
        return f"http://{'[' + host + ']' if ':' in host else host}:{self.port}"

    def _build_loop(self) -> None:
        while not self._stop.is_set():
            try:
                kind, client = self._queue.get(timeout=0.2)
            except queue.Empty:
                continue
            try:
                if kind == "connect":
                    self._open_with_retries(client)
                else:
                    self._close(client.client_id)
            except Exception as exc:  # one tab's trouble must not end the class
                traceback.print_exc()
                print(f"fuzzynav classroom: tab {client.client_id}: {exc}", flush=True)

    def _open_with_retries(self, client) -> None:
        """Build a tab's world; a failed build is cleared away and tried again, and a
        tab whose world cannot be built is told so on its page."""
        for attempt in range(1, BUILD_ATTEMPTS + 1):
            try:
                self._open(client)
                return
            except Exception as exc:
                traceback.print_exc()
                print(
                    f"fuzzynav classroom: tab {client.client_id}: building its world failed "
                    f"(attempt {attempt} of {BUILD_ATTEMPTS}): {type(exc).__name__}: {exc}",
                    flush=True,
                )
                self._close(client.client_id)
                self._clear_page(client)
                failure = exc
        try:
            client.add_notification(
                "fuzzynav: this tab has no world",
                f"Building this tab's world failed {BUILD_ATTEMPTS} times "
                f"({type(failure).__name__}: {failure}). Reload the page to try again, "
                "and tell the teacher.",
                color="red",
                with_close_button=True,
            )
        except Exception:  # the tab went away meanwhile
            traceback.print_exc()

    @staticmethod
    def _clear_page(client) -> None:
        """What a failed build put on a tab's page goes, so a retry starts clean."""
        try:
            client.gui.reset()
            client.scene.reset()
        except Exception:  # the tab went away meanwhile
            traceback.print_exc()

    def _open(self, client) -> None:
        from fuzzynav.app.viewer.server import ClientSurface, ViewerServer

        if client.client_id not in self.server.get_clients():
            return  # gone before its turn
        view = ViewerServer(
            self.make_app(), surface=ClientSurface(self.server, client), budget=self.budget
        )
        try:  # a tab is a session once its panel is whole, Teacher folder and all
            self._add_teacher_folder(view, client.client_id)
        except BaseException:
            view.stop()  # (not registered yet: a retry would not stop it)
            raise
        with self._lock:
            view.locked = self.locked  # a tab that joins a locked class is locked
            self.sessions[client.client_id] = view
        if client.client_id not in self.server.get_clients():  # left while being built
            self._close(client.client_id)

    def _close(self, client_id: int) -> None:
        with self._lock:
            view = self.sessions.pop(client_id, None)
            self.teachers.discard(client_id)
        if view is not None:
            view.stop()

    def _add_teacher_folder(self, view, client_id: int) -> None:
        gui = view.server.gui
        # Last in the panel whatever else the tab holds: viser numbers the components of
        # the whole server with one counter (1, 2, 3, ...), which passed the folder's
        # order of 1000 after a few tabs, and the folder jumped above the clock.
        with gui.add_folder("Teacher", expand_by_default=False, order=TEACHER_ORDER):
            box = gui.add_text("Teacher's token", "", hint="printed by fuzzynav serve --classroom")
            # Never readable on the projected page: the box shows discs (viser's text box
            # has no password kind), and it is emptied once the token is taken.
            # (viser labels the box with <label for=uuid> beside it: the row that holds
            # that label holds the box.)
            gui.add_html(
                f"<style>div:has(> div > p > label[for='{handle_uuid(box)}']) input"
                "{-webkit-text-security:disc;text-security:disc}</style>"
            )
            push = gui.add_button(
                "Push my world's setup to the class",
                visible=False,
                hint="Every tab restarts in this tab's scenario, layout, settings and Editor",
            )
            lock = gui.add_checkbox(
                "Lock the students' controls",
                self.locked,
                visible=False,
                hint="Every other tab's buttons, boxes and drags are refused until unticked",
            )
            overview = gui.add_html("", visible=False)

        def on_token(event) -> None:
            if event.client is None:
                return
            if secrets.compare_digest(str(event.value), self.token):
                with self._lock:
                    self.teachers.add(client_id)
                push.visible = True
                lock.visible = True
                overview.visible = True
                box.value = ""  # (a server-side set: on_token sees no client, and returns)
                box.visible = False
                # the class, drawn with this tab's panels (by its render thread)
                view.class_overview = lambda: self._draw_overview(client_id, overview)
                view.app._bump()
                view.tell(
                    event.client, "You are the teacher: you can push to the class.", "success"
                )
            elif event.value:
                view.tell(event.client, "That is not the teacher's token.", "error")

        def on_push(event) -> None:
            if event.client is None:
                return
            try:
                n = self.push_from(client_id)
            except ViewerError as exc:
                view.tell(event.client, str(exc), "error")
                return
            view.tell(event.client, f"Pushed to {n} tab{'s' if n != 1 else ''}.", "success")

        def on_lock(event) -> None:
            if event.client is None:
                return
            if client_id not in self.teachers:
                raise ViewerError("only the teacher's tab can lock the class")
            n = self.lock_class(bool(event.value), client_id)
            state = "locked" if event.value else "unlocked"
            view.tell(event.client, f"Controls {state} in {n} tab{'s' if n != 1 else ''}.", "info")

        # in this tab's order, after its earlier presses (ViewerServer.guarded); the
        # Teacher folder answers even in a locked tab (the teacher may sit at one)
        box.on_update(view.guarded(on_token, always=True))
        push.on_click(view.guarded(on_push, always=True))
        lock.on_update(view.guarded(on_lock, always=True))
        view.teacher_token_box, view.teacher_push = box, push

    def lock_class(self, locked: bool, teacher_id: int | None = None) -> int:
        """Lock (or unlock) every tab's controls but the teacher's; returns how many
        tabs. Tabs that join later take the class's state."""
        with self._lock:
            self.locked = bool(locked)
            others = [v for cid, v in self.sessions.items() if cid != teacher_id]
        for view in others:
            view.locked = self.locked
            view.app._notice(
                ServerLockText.LOCKED if self.locked else ServerLockText.UNLOCKED, "info"
            )
        return len(others)

    def overview_rows(self, teacher_id: int | None = None) -> list[dict]:
        """Every other tab's world as the teacher's overview lists it."""
        with self._lock:
            items = sorted(
                ((cid, v) for cid, v in self.sessions.items() if cid != teacher_id),
                key=lambda item: item[0],
            )
        rows = []
        for number, (_, view) in enumerate(items, 1):
            snap = view.app.snapshot()
            m = snap.metrics or {}
            state = snap.outcome if snap.outcome else "running" if snap.playing else "paused"
            rows.append(
                {
                    "tab": number,
                    "scenario": snap.scenario_label,
                    "controller": snap.controller_label,
                    "time_s": snap.time_s,
                    "state": state,
                    "time_to_target_s": m.get("time_to_target_s"),
                    "min_clearance_m": m.get("min_clearance_m"),
                    "edited": ", ".join(
                        e
                        for e, on in (
                            ("layout", snap.layout_edited),
                            ("rules", snap.controller_label.endswith("(edited)")),
                        )
                        if on
                    ),
                    "locked": view.locked,
                }
            )
        return rows

    def _draw_overview(self, teacher_id: int, element) -> None:
        """The teacher's overview of the class (called by the teacher tab's render
        thread, with its panels)."""
        import html as html_module

        rows = self.overview_rows(teacher_id)

        def num(value, unit):
            return "—" if value is None else f"{value:.2f} {unit}"

        colour = {"reached": "#15803d", "collided": "#b91c1c", "timeout": "#b45309"}

        def result(r) -> str:
            parts = [r["state"]]
            if r["time_to_target_s"] is not None:
                parts.append(num(r["time_to_target_s"], "s"))
            if r["min_clearance_m"] is not None:
                parts.append("clearance " + num(r["min_clearance_m"], "m"))
            return " · ".join(parts)

        body = "".join(
            f"<tr class='fz-class-row'><td>{r['tab']}</td>"
            f"<td>{html_module.escape(r['scenario'])} · {html_module.escape(r['controller'])}"
            f"</td><td style='text-align:right;white-space:nowrap'>{r['time_s']:.1f} s</td>"
            f"<td style='color:{colour.get(r['state'], '#334155')}'>"
            f"{html_module.escape(result(r))}</td>"
            f"<td>{html_module.escape(r['edited']) or '—'}"
            f"{' 🔒' if r['locked'] else ''}</td></tr>"
            for r in rows
        )
        content = (
            "<div class='fz-class' style='font-family:system-ui,sans-serif;font-size:0.78em;"
            "padding:0 14px 0 6px;overflow-x:auto'>"
            f"<b>The class: {len(rows)} other tab{'s' if len(rows) != 1 else ''}"
            f"{' (locked)' if self.locked else ''}</b>"
            "<table style='width:100%;border-collapse:collapse;"
            "font-variant-numeric:tabular-nums'><tr style='text-align:left;color:#475569'>"
            "<th>tab</th><th>world</th><th>t</th><th>state</th><th>edits</th></tr>"
            f"{body}</table></div>"
        )
        if element.content != content:
            element.content = content

    def _overview_loop(self) -> None:
        """Once a second, the teachers' tabs draw their overview again (their render
        threads draw it, with their panels, when their world's version moves)."""
        while not self._stop.wait(1.0):
            with self._lock:
                views = [self.sessions[c] for c in self.teachers if c in self.sessions]
            for view in views:
                view.app._bump()

    def push_from(self, client_id: int) -> int:
        """The teacher's scenario (as edited), settings and Editor (each tab's editors
        its own, holding the teacher's edits, as a lesson brings them) to every other
        tab's world; returns how many tabs took them."""
        with self._lock:
            if client_id not in self.teachers:
                raise ViewerError("only the teacher's tab can push to the class")
            source = self.sessions[client_id].app
            others = [v for cid, v in self.sessions.items() if cid != client_id]
        settings = source.settings()
        for view in others:
            view.app.apply_settings(settings)
        return len(others)

    def stop(self) -> None:
        self._stop.set()
        self._builder.join(timeout=5.0)
        self._overview.join(timeout=5.0)
        with self._lock:
            views = list(self.sessions.values())
            self.sessions.clear()
        for view in views:
            view.stop()
        self.server.stop()
