"""The render loop: one thread per :class:`app.viewer.server.ViewerServer` that alone
writes the scene, from :meth:`ViewerApp.snapshot`, at up to ``FRAME_HZ`` while something
changes and not at all while nothing does; the panels (status line, plots, inference,
surface, the inputs on the robot, the result) at ``PANEL_HZ``, the plots at ``PLOT_HZ``.

Threads: the render thread alone owns the frame times (a deque it appends to); what other
threads may read of them is published as one immutable tuple, replaced whole
(:attr:`RenderLoop.frame_window`). A reader that iterated the deque itself raced the
appends ("deque mutated during iteration")."""

from __future__ import annotations

import threading
import time
from collections import deque

from fuzzynav.app.viewer import compat_viser
from fuzzynav.app.viewer.model import Snapshot

FRAME_HZ = 30.0
PANEL_HZ = 4.0  # the status line and the inference view
PLOT_HZ = 2.0  # the signal plots (viser sends their whole window as float64 each time)
#: How often the scene's message buffer is swept of removed nodes' messages. viser keeps
#: a removal message per node name until a tab connects (its own sweep); a scene node's
#: name holds its run, so each Reset or scenario load left three messages an obstacle:
#: 400 uploads of 1,000 obstacles grew the server by 518 MB.
SWEEP_PERIOD_S = 5.0


class RenderLoop:
    """Draws a :class:`app.viewer.server.ViewerServer`'s parts from the app's snapshots."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self._stop = threading.Event()
        self._frame_times: deque[float] = deque(maxlen=120)  # the render thread's own
        #: (frames, first, last): the frame times as the render thread last published
        #: them, one tuple replaced whole (read by any thread without a lock)
        self.frame_window: tuple[int, float, float] = (0, 0.0, 0.0)
        self._last_panel_version = -1
        self._next_plot = 0.0
        self._thread = threading.Thread(target=self._run, name="fuzzynav-render", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def halt(self) -> None:
        """No more frames (without waiting for the thread: a closed classroom tab)."""
        self._stop.set()

    def stop(self) -> None:
        self.halt()
        self._thread.join(timeout=5.0)

    def scene_hz(self) -> float:
        """Scene updates per second over the last frames (0 when idle); safe from any
        thread (it reads only the published :attr:`frame_window`)."""
        frames, first, last = self.frame_window
        if frames < 2 or time.perf_counter() - last > 0.5 or last <= first:
            return 0.0
        return (frames - 1) / (last - first)

    def _frame_drawn(self, started: float) -> None:
        """The render thread's record of a frame: appended, then published whole."""
        times = self._frame_times
        times.append(started)
        self.frame_window = (len(times), times[0], times[-1])

    def _run(self) -> None:
        period = 1.0 / FRAME_HZ
        drawn_version = -1
        next_panels = 0.0
        next_sweep = time.perf_counter() + SWEEP_PERIOD_S
        while not self._stop.is_set():
            started = time.perf_counter()
            if started >= next_sweep:
                next_sweep = started + SWEEP_PERIOD_S
                self.sweep()
            snap = self.app.snapshot()
            if snap.version != drawn_version:
                try:
                    with self.view.server.atomic():
                        self.view.scene.draw(snap)
                except Exception as exc:  # keep rendering whatever one frame did
                    self.app._notice(f"scene update failed: {type(exc).__name__}: {exc}", "warning")
                drawn_version = snap.version
                self._frame_drawn(started)
            if snap.version != self._last_panel_version and (
                started >= next_panels or not snap.playing
            ):
                try:
                    self._draw_panels(snap)
                except Exception as exc:
                    self.app._notice(f"panel update failed: {type(exc).__name__}: {exc}", "warning")
                self._last_panel_version = snap.version
                next_panels = started + 1.0 / PANEL_HZ
            if self._last_panel_version == drawn_version == snap.version and not snap.playing:
                # All drawn and nothing runs: sleep until the app changes.
                with self.app._changed:
                    if self.app.version == snap.version and not self._stop.is_set():
                        self.app._changed.wait(0.25)
                continue
            self._stop.wait(max(0.0, period - (time.perf_counter() - started)))

    def sweep(self) -> None:
        """Drop from the scene's message buffer the removal messages every tab has read,
        and what else targets a removed node (viser's own sweep, which it runs only when
        a tab connects). A classroom tab's scene is its own, with no such buffer."""
        try:
            compat_viser.sweep_scene_buffer(self.view.server)
        except Exception as exc:  # (viser's internals: never stop the drawing)
            self.app._notice(f"scene sweep failed: {type(exc).__name__}: {exc}", "warning")

    def _draw_panels(self, snap: Snapshot) -> None:
        view = self.view
        # What answers a drag first (paused, the page answers at once): the
        # status, the inference, the inputs on the robot; then the rest.
        view.status_line.draw(snap)
        view.inference.sync(snap)
        view.inference.draw(snap)
        with view.server.atomic():
            view.scene.draw_inputs(snap)
        view.controls.sync(snap)
        view.editor.sync()
        now = time.perf_counter()
        if now >= self._next_plot or not snap.playing:
            self._next_plot = now + 1.0 / PLOT_HZ
            view.plots.draw()
        view.inference.draw_timeline(snap)
        view.surface.draw(snap)
        view.status_line.draw_result(snap)
        if view.class_overview is not None:  # a classroom teacher's tab
            view.class_overview()
