"""The viser side of the viewer: one :class:`ViewerServer` per world, a coordinator of
parts, each with one job (see :mod:`app.viewer.model` for what the page shows and why):

- :class:`.scene.Scene`: the robot, its beams and inputs, trails, ghost, ground;
- :class:`.handles.DragHandles`: the target and the obstacles, and their drags;
- :class:`.camera.Camera`: each tab's camera, top-down and fitted to its canvas;
- :class:`.controls.ControlPanel`: the right-hand panel, with the
  :class:`.status.StatusLine` (status line, message, Result panel) in it;
- the left-hand panel's tabs: :class:`.inference_panel.InferencePanel`,
  :class:`.surface_panel.SurfacePanel`, :class:`.editor_panel.EditorPanel`,
  :class:`.plots.SignalPlots`;
- :class:`.render.RenderLoop`: the one thread that draws them all.

GUI callbacks only call :class:`app.viewer.model.ViewerApp` methods (through
:meth:`ViewerServer.guarded`); the render thread alone writes the scene.
"""

from __future__ import annotations

import concurrent.futures
import threading
import traceback
import types

import viser

from fuzzynav.app.viewer.camera import Camera
from fuzzynav.app.viewer.controls import ControlPanel
from fuzzynav.app.viewer.editor_panel import EditorPanel
from fuzzynav.app.viewer.guards import install_message_guards, value_sent
from fuzzynav.app.viewer.handles import DragHandles
from fuzzynav.app.viewer.inference_panel import InferencePanel
from fuzzynav.app.viewer.model import MAX_UPLOAD_BYTES, ViewerApp, ViewerError
from fuzzynav.app.viewer.origin_guard import guarded_server_start
from fuzzynav.app.viewer.plots import SignalPlots
from fuzzynav.app.viewer.render import RenderLoop
from fuzzynav.app.viewer.scene import Scene
from fuzzynav.app.viewer.status import StatusLine
from fuzzynav.app.viewer.surface_panel import SurfacePanel

NORMAL_WIDTHS = (400, 330)  # the left and right panels (px)
# Presentation mode's type, for a projector at 1280 x 800: no text under 12 px. The
# SVG views scale with their panel, so their text is set in their own units: the rule
# grid (up to ~460 units drawn in ~420 px), the term and step plots (300-330 units in
# ~420 px).
PRESENTATION_CSS = (
    "<style>"
    ".mantine-Slider-markLabel,.mantine-Button-label,.fz-drag-hint,.fz-drag-hint b,"
    ".fz-surface,.fz-surface div,.fz-surface span,.fz-message,.fz-timeline,.fz-colour-key"
    "{font-size:12.5px!important}"
    ".fz-inference svg text,.fz-stepwise svg text,.fz-term-drag text"
    "{font-size:10px!important}"
    ".fz-inference svg.fz-rule-head-svg text,.fz-inference svg.fz-rules text,"
    ".fz-inference svg.fz-aggregate-svg text,.fz-inference .fz-strengths text,"
    "svg text.fz-rule-no.fz-rule-no{font-size:13.5px!important}"
    "</style>"
)
PRESENTATION_WIDTHS = (440, 300)  # ... in presentation mode: the arena still the largest at 1280


class ClientSurface:
    """One tab's own scene and GUI (viser's client-scoped API), in the shape of the
    server that :class:`ViewerServer` draws on: classroom mode gives every tab a world
    of its own (:mod:`app.viewer.classroom`)."""

    def __init__(self, server, client):
        self._server, self._client = server, client
        self.scene, self.gui = client.scene, client.gui
        self.initial_camera = types.SimpleNamespace()  # the tab's own camera is fitted

    def get_clients(self) -> dict:
        cid = self._client.client_id
        return {cid: self._client} if cid in self._server.get_clients() else {}

    def atomic(self):
        return self._client.atomic()

    def get_port(self) -> int:
        return self._server.get_port()

    def on_client_connect(self, callback) -> None:
        callback(self._client)

    def on_client_disconnect(self, callback) -> None:
        pass  # the classroom server ends the tab's world

    def stop(self) -> None:
        pass  # the server is the classroom's


def _report_errors(future) -> None:
    """A callback's error that escaped :meth:`ViewerServer.guarded` (a failed notice)."""
    if not future.cancelled() and future.exception() is not None:
        traceback.print_exception(future.exception())


class ViewerServer:
    """The viser server showing a :class:`ViewerApp` (which it starts and stops)."""

    def __init__(
        self,
        app: ViewerApp,
        host: str = "127.0.0.1",
        port: int = 8080,
        *,
        surface=None,
        budget=None,
    ):
        self.app = app
        # what the tabs make the server keep, counted together (app/viewer/budget.py):
        # a classroom passes its server's, shared by every tab's world
        if budget is not None:
            app.attach_budget(budget)
        self.host = host
        #: a classroom's teacher has locked this tab's controls: presses and
        #: drags are refused with a word; the teacher's own folder still answers
        self.locked = False
        #: () -> None, drawn with the panels (the classroom's overview, in a teacher's tab)
        self.class_overview = None
        self._worker = None  # the GUI callbacks' thread (guarded)
        self._worker_lock = threading.Lock()
        if surface is None:
            with guarded_server_start(host):  # only its own page may connect (origin_guard)
                self.server = viser.ViserServer(
                    host=host, port=port, label="fuzzynav", verbose=False
                )
        else:  # one tab's own world (classroom mode): its scene and GUI only
            self.server = surface
        self.port = self.server.get_port()
        # only a component's value, finite numbers, uploads refused at their declared
        # size, a few at a time, in the budget and in time
        self.uploads = install_message_guards(
            self.server,
            MAX_UPLOAD_BYTES,
            lambda text: app._notice(text, "warning"),
            account=app.account,
        )
        self.view_3d = False
        self.show_handles = False
        self.presentation = False
        self.camera = Camera(self)
        self.scene = Scene(self)
        self.handles = DragHandles(self)
        self.status_line = StatusLine(self)
        self.controls = ControlPanel(self)
        self.inference = InferencePanel(self)
        self.surface = SurfacePanel(self)
        self.editor = EditorPanel(self)
        self.plots = SignalPlots(self)
        self.render = RenderLoop(self)

        self.server.scene.set_up_direction("+z")
        self.controls.build()
        self._build_left_panel()
        self.scene.build()
        self.server.on_client_connect(self.camera.on_connect)
        self.server.on_client_disconnect(self.camera.on_disconnect)
        app.start()
        self.render.start()

    def _build_left_panel(self) -> None:
        """The teaching tabs, docked left; the control panel docked right."""
        gui = self.server.gui
        panel = gui.add_panel()
        self.left_panel = panel
        with panel.add_tab("Inference", viser.Icon.BRAIN):
            self.inference.build()
        with panel.add_tab("Surface", viser.Icon.GRID_DOTS):
            self.surface.build()
        with panel.add_tab("Editor", viser.Icon.ADJUSTMENTS):
            self.editor.build()
        self.plots.build(panel.add_tab("Signals", viser.Icon.CHART_LINE))
        panel.dock_left()
        panel.set_width(NORMAL_WIDTHS[0])
        main = gui.main_panel
        main.dock_right()
        main.set_width(NORMAL_WIDTHS[1])

    # -- lifecycle ---------------------------------------------------------------------

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in ("", "0.0.0.0") else self.host
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}"

    def stop(self) -> None:
        """Stop rendering, the simulation thread and the server; the port is freed."""
        self.render.stop()
        with self._worker_lock:
            worker, self._worker = self._worker, None
        if worker is not None:
            worker.shutdown(wait=False, cancel_futures=True)
        self.app.stop()
        self.server.stop()

    def scene_hz(self) -> float:
        """Scene updates per second over the last frames (0 when idle)."""
        return self.render.scene_hz()

    # -- what the parts share ----------------------------------------------------------

    def label_scale(self, scale: float) -> float:
        """Arena labels are larger in presentation mode."""
        return scale * (1.6 if self.presentation else 1.0)

    def current_view(self) -> dict:
        """What a lesson file keeps of the page's view."""
        return {
            "presentation": bool(self.presentation),
            "firing_only": bool(self.inference.firing_only_cb.value),
        }

    def apply_view(self, view: dict) -> None:
        """A lesson's view: presentation mode and *Firing rules only* as it had them."""
        if "presentation" in view and bool(view["presentation"]) != self.presentation:
            self.set_presentation(bool(view["presentation"]))
            self.controls.presentation_cb.value = self.presentation
        if "firing_only" in view:
            self.inference.firing_only_cb.value = bool(view["firing_only"])
            self.inference.redraw()

    def set_presentation(self, on: bool) -> None:
        """Large type for a projector: a wide inference panel, a wider control panel,
        the status line and the arena's labels larger, and every tab's camera refitted
        to its narrower canvas (the new shape arrives as a camera message)."""
        self.presentation = on
        for client in self.server.get_clients().values():  # before the canvases change
            self.camera.open_fit_window(client, 10.0)
        left, right = PRESENTATION_WIDTHS if self.presentation else NORMAL_WIDTHS
        self.left_panel.set_width(left)
        self.server.gui.main_panel.set_width(right)
        self.controls.presentation_css.content = PRESENTATION_CSS if on else ""
        with self.server.atomic():
            if self.scene.bounds is not None:
                self.scene.frame_arena(self.scene.bounds)  # the metre marks, at the new size
            self.handles.rescale_labels()
        self.inference.last_inference = None  # redraw with the new type size
        self.status_line.last_metrics_run = -1
        self.app._bump()

    LOCKED_TEXT = "The teacher has locked the controls for now."

    def guarded(self, func, always: bool = False):
        """Run a GUI callback; a refused action becomes a message in the page.

        ``func(event)`` gets ``event.value``: the value the client sent, as the message
        guard kept it (:func:`app.viewer.guards.value_sent`), not the widget's. The render
        thread's sync (:meth:`ControlPanel.sync`) sets a widget back to the world's value
        from another thread at any moment: read in viser's worker thread, and later even
        on its event loop just after viser set it, the widget gave the old value and the
        press was lost (CI, twice: a controller press applied the old controller,
        "Controller: p."). The callbacks then run one at a time, in the order pressed, on
        this world's own worker (a press during a scenario load applies after the load)."""

        def run(event):
            if self.locked and not always:
                self.tell(event.client, self.LOCKED_TEXT, "warning")
                self.app._bump()  # the widgets are drawn back as the world has them
                return
            try:
                func(event)
            except ViewerError as exc:
                self.tell(event.client, str(exc), "error")
            except Exception as exc:  # never let a callback kill the viewer quietly
                self.tell(event.client, f"unexpected error: {type(exc).__name__}: {exc}", "error")

        async def callback(event):
            if event.client is None:  # a value the server itself set (sync), not a user
                return
            sent = types.SimpleNamespace(
                client=event.client,
                client_id=event.client_id,
                target=event.target,
                value=value_sent(event.target),  # as sent, whatever the render thread did
            )
            self._callback_worker().submit(run, sent).add_done_callback(_report_errors)

        return callback

    def _callback_worker(self):
        """This world's one GUI-callback thread (created at the first press)."""
        with self._worker_lock:
            if self._worker is None:
                self._worker = concurrent.futures.ThreadPoolExecutor(
                    max_workers=1, thread_name_prefix="fuzzynav-gui"
                )
            return self._worker

    def tell(self, client, text: str, level: str) -> None:
        self.app._notice(text, level)
        if client is not None:
            colour = {"error": "red", "warning": "yellow", "success": "green"}.get(level, "blue")
            client.add_notification(
                "Refused" if level == "error" else "fuzzynav",
                text,
                color=colour,
                auto_close_seconds=8.0,
            )
