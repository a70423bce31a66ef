"""The run and its simulation thread: play, pause, step, reset and the speed; the
thread that paces the simulation against the wall clock; the step (trail, plots, the
run's history); the ``--rrd`` recording of each run. A part of :class:`ViewerApp`
(:mod:`.model`), whose state and lock it shares."""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time
from pathlib import Path

import numpy as np

from fuzzynav.app.viewer.budget import RecordingBudget
from fuzzynav.app.viewer.state import (
    PLOT_WINDOW_S,
    SPEED_RANGE,
    Ghost,
    ViewerError,
    _Ring,
    _Trail,
)
from fuzzynav.world.scenario import (
    Scenario,
    ScenarioError,
    check_layout,
)

#: The columns of the live signal rows (one row a step, the last ``PLOT_WINDOW_S`` kept)
#: that the Signals tab plots: :func:`signal_row`'s, named by the live plots of
#: ``app.recordings.series.PLOTS`` (``LiveLine.column``). A new live value is a name
#: here and its value in :func:`signal_row`.
SIGNAL_COLUMNS = ("t", "d_t", "d_o", "phi_t", "phi_o", "v_left", "v_right")


def signal_row(sim, controller) -> tuple:
    """The live signal row of the step just taken (:data:`SIGNAL_COLUMNS`): the time
    the controller read its inputs, the inputs, the voltages after the limit.

    Parameters
    ----------
    sim : world.simulation.Simulation
        The simulation, after its step.
    controller
        The controller that drove the step (its ``last_inputs``, ``last_output``).
    """
    limit = sim.voltage_limit_v
    applied = np.clip(controller.last_output, -limit, limit)
    return (sim.time_s - sim.control_period_s, *controller.last_inputs, *applied)


class RunDriver:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app
        # the lock on ``.<name>.serving`` while this server holds --rrd (_hold_rrd_path)
        self._serving_fd: int | None = None
        self._serving_marker: Path | None = None
        # serve --rrd's disk: runs a minute and bytes a session
        self.recording_budget = RecordingBudget()
        self._unrecorded_run = -1  # the run not recorded (the budget said no)
        self._size_checked = -math.inf  # wall time the recording's size was last read

    def start(self):
        """Start the simulation thread (it idles until :meth:`play`)."""
        app = self.app
        if app._thread is None:
            app._stop.clear()
            app._thread = threading.Thread(target=self._run, name="fuzzynav-sim", daemon=True)
            app._thread.start()
        return app

    def stop(self) -> None:
        """Stop the simulation thread and complete the recording, if any."""
        app = self.app
        app._stop.set()
        app._wake.set()
        if app._thread is not None:
            app._thread.join(timeout=5.0)
            app._thread = None
        with app.lock:
            self._close_recorder_locked()
            self._release_rrd_path()
            app.account.close()  # (the world ends: what it held leaves the budget)

    def _record_locked(self) -> None:
        app = self.app
        if app.rrd_path is None or self._unrecorded_run == app.run_id:
            return
        budget = self.recording_budget
        if app._recorder is None:
            why = budget.why_not()
            if why is not None:
                self._unrecorded_run = app.run_id
                app._notice(f"Not recorded: {why}.", "warning")
                return
        try:
            if app._recorder is None:
                from fuzzynav.app.recordings.record import LiveRecorder

                path = self._next_recording_path()
                try:
                    app._recorder = LiveRecorder(path)
                except BaseException:
                    if path != app.rrd_path and path.exists() and path.stat().st_size == 0:
                        path.unlink()  # our reservation, never written
                    raise
                app.recorded_files.append(path)
                budget.started()
            app._recorder.update(app.sim)
            if budget.full(self._recording_size()):
                self._close_recorder_locked()
                self._unrecorded_run = app.run_id
                app._notice(
                    f"Recording stopped at t = {app.sim.time_s:.2f} s: {budget.why_not()}.",
                    "warning",
                )
        except Exception as exc:  # a full disk must not stop the simulation
            app._recorder = None
            app.rrd_path = None
            app._notice(f"Recording stopped: {exc}", "warning")

    def _next_recording_path(self) -> Path:
        """The file of the next run: ``--rrd`` itself first, then ``<stem>-runK.rrd``
        with the first K whose file does not exist, reserved at once (created empty,
        exclusively), so that a second ``serve --rrd`` on the same path never takes,
        nor overwrites, this one's runs. ``--rrd`` itself only while this
        server holds it (:meth:`_hold_rrd_path`): a second server on the same path
        while the first runs numbers its first run too."""
        app = self.app
        if not app.recorded_files and self._hold_rrd_path():
            return app.rrd_path
        suffix = app.rrd_path.suffix or ".rrd"
        k = len(app.recorded_files) + 1
        while True:
            path = app.rrd_path.with_name(f"{app.rrd_path.stem}-run{k}{suffix}")
            try:
                os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
                return path
            except FileExistsError:
                k += 1

    def _hold_rrd_path(self) -> bool:
        """Whether this server holds ``--rrd`` itself: an OS advisory lock (``flock``)
        on ``.<name>.serving`` beside it, taken at the first run and kept until the
        viewer stops, which removes the file (the lock goes with the process however it
        ends; after a crash the empty file stays, free). False when another server
        holds it; True where there is no ``flock`` (Windows: the first run then
        replaces the path, as before)."""
        app = self.app
        if self._serving_fd is not None:
            return True
        try:
            import fcntl
        except ImportError:
            return True
        marker = app.rrd_path.with_name(f".{app.rrd_path.name}.serving")
        while True:
            fd = os.open(marker, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                return False
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(marker))
            except FileNotFoundError:
                same = False
            if same:  # (else its holder removed it as it stopped: take the new one)
                self._serving_fd, self._serving_marker = fd, marker
                return True
            os.close(fd)

    def _release_rrd_path(self) -> None:
        fd, self._serving_fd = self._serving_fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self._serving_marker)  # still locked: nobody holds it now
            os.close(fd)  # the lock with it

    def _recording_size(self) -> int:
        """Bytes of the recording being written, read at most once a second (0 else)."""
        now = time.monotonic()
        if now - self._size_checked < 1.0:
            return 0
        self._size_checked = now
        recorder = self.app._recorder
        return recorder.bytes_written() if recorder is not None else 0

    def _close_recorder_locked(self) -> None:
        app = self.app
        recorder, app._recorder = app._recorder, None
        if recorder is not None:
            try:
                recorder.close(app.sim)
            except Exception as exc:
                app._notice(f"Recording could not be completed: {exc}", "warning")
            for path in (recorder.path, getattr(recorder, "kept_partial", None)):
                with contextlib.suppress(OSError):  # what it wrote counts in the session's bytes
                    self.recording_budget.written += os.stat(path).st_size if path else 0

    def _anchor(self) -> None:
        """Pace from here: sim time advances speed x wall time from this instant."""
        app = self.app
        app._anchor_wall = time.perf_counter()
        app._anchor_sim = app.sim.time_s

    def _run(self) -> None:
        app = self.app
        dt = app.sim.control_period_s
        while not app._stop.is_set():
            with app.lock:
                active = app.playing and not app.sim.done
                if active:
                    target = app._anchor_sim + (time.perf_counter() - app._anchor_wall) * app.speed
                    if target - app.sim.time_s > 0.25 * max(app.speed, 1.0):
                        # Fell behind (slow machine, debugger): drop the backlog, not the pace.
                        self._anchor()
                        target = app.sim.time_s + dt
            if not active:
                app._wake.wait(0.05)
                app._wake.clear()
                continue
            stepped = 0
            while not app._stop.is_set():
                with app.lock:
                    if not app.playing or app.sim.done or app.sim.time_s + 0.5 * dt > target:
                        break
                    self._step_locked()
                    stepped += 1
                if stepped >= 200:
                    break
            with app.lock:
                if not app.playing or app.sim.done:
                    continue
                due = app._anchor_wall + (app.sim.time_s + dt - app._anchor_sim) / app.speed
            delay = due - time.perf_counter()
            if delay > 0:
                app._wake.wait(min(delay, 0.05))
                app._wake.clear()

    def _step_locked(self) -> None:
        app = self.app
        sim = app.sim
        app._input_pose = tuple(sim.arena.pose)  # where the controller reads its inputs
        app._probe = None  # the driving controller answers again
        try:
            outcome = sim.step()
        except Exception as exc:  # a controller that fails must not kill the thread
            app.playing = False
            app._notice(f"The simulation stopped: {exc}", "error")
            return
        self._record_locked()
        x, y, _ = sim.arena.pose
        last = app._trail[-1]
        if (x - last[0]) ** 2 + (y - last[1]) ** 2 > 0.02**2:
            app._trail.append((x, y))
        app._signals.append(signal_row(sim, app.controller))
        app.results._record_history_locked()
        if outcome is not None:
            app.playing = False
            app.results._finish_locked()
        app._bump()

    def _on_controller_call(self, inputs, wall_s) -> None:
        app = self.app
        for watcher in list(app._input_watchers):
            watcher(inputs, wall_s)

    def add_input_watcher(self, func) -> None:
        """``func(inputs, wall_time_s)`` after every controller call (benchmarks)."""
        app = self.app
        app._input_watchers.append(func)

    def play(self) -> None:
        app = self.app
        with app.lock:
            self._end_modes_locked()
            app.what_if = None  # Play leaves what-if mode ...
            app.history_index = None  # ... and the time slider's past
            if app.sim.done:
                self._reset_locked(app.editing._layout_scenario())
            app.playing = True
            self._anchor()
            app._bump()
        app._wake.set()

    def _end_modes_locked(self) -> None:
        """Play and Step leave what-if mode and the time slider's past, and what was
        refused in them goes with them."""
        app = self.app
        if app.what_if is not None:
            app._end_mode_message_locked("what-if")
        if app.history_index is not None:
            app._end_mode_message_locked("history")

    def pause(self) -> None:
        app = self.app
        with app.lock:
            app.playing = False
            app._bump()

    def step_once(self) -> None:
        """Pause and advance exactly one control period."""
        app = self.app
        with app.lock:
            self._end_modes_locked()
            app.what_if = None
            app.history_index = None
            app.playing = False
            if app.sim.done:
                self._reset_locked(app.editing._layout_scenario())
            self._step_locked()

    def reset(self) -> None:
        """Back to the start, with the layout as it is now (drags, added obstacles kept)."""
        app = self.app
        with app.lock:
            app.playing = False
            layout = app.editing._layout_scenario()
            self._reset_locked(layout)
            try:
                check_layout(layout)
            except ScenarioError as exc:
                consequence = (
                    "the robot cannot reach it"
                    if exc.key == "target.position"
                    else "the run will collide at once"
                    if "footprint" in exc.reason
                    else "the run goes ahead"
                )
                app._notice(
                    app.editing.plain_names(f"Note: {exc.key} {exc.reason}; {consequence}."),
                    "warning",
                )

    def set_speed(self, factor) -> None:
        app = self.app
        try:
            factor = float(factor)
        except (TypeError, ValueError):
            raise ViewerError(f"speed = {factor!r}: must be a number") from None
        if not (math.isfinite(factor) and SPEED_RANGE[0] - 1e-9 <= factor <= SPEED_RANGE[1] + 1e-9):
            raise ViewerError(
                f"speed = {factor!r}: must be between {SPEED_RANGE[0]} and "
                f"{SPEED_RANGE[1]} times real time"
            )
        with app.lock:
            app.speed = factor
            self._anchor()
            app._bump()
        app._wake.set()

    def _reset_locked(self, scenario: Scenario) -> None:
        app = self.app
        self._close_recorder_locked()
        if getattr(app, "_trail", None) is not None and len(app._trail) > 1:
            # The run that ends here stays on screen as a ghost, its numbers beside the next.
            app.ghost = Ghost(
                trail=np.array(app._trail, dtype=float),
                label=app.run_label,
                metrics=dict(app.metrics) if app.metrics else app.results._partial_metrics(),
            )
            app.ghost_id += 1
        # A new run: what was said about the last one (its outcome) no longer holds.
        app.message, app.message_level = "", "info"
        app.what_if = None
        app.history_index = None
        app._history.close()
        app.sim.reset(seed=app.seed, scenario=scenario)
        app.setup._apply_disturbance_locked()
        app._layout = [
            (obstacle_id, spec)
            for obstacle_id, spec in zip(app.sim.arena.obstacles, scenario.obstacles)
        ]
        app.editing.charge_layout_locked()
        app._target = tuple(scenario.target)
        app._target_warning = None
        app._trail = _Trail(app.sim.arena.pose[:2])
        capacity = int(PLOT_WINDOW_S / app.sim.control_period_s) + 1
        app._signals = _Ring(capacity, len(SIGNAL_COLUMNS))
        app.controller.last_inputs = np.full(4, np.nan)
        app.controller.last_output = np.full(2, np.nan)
        if app.noise_std_m == 0.0:
            # What the controller will read at the start, shown before the first step
            # (not with sensor noise: a read would draw from the run's noise stream).
            try:
                app.controller.last_inputs = np.asarray(app.sim.sense()[0], dtype=float)
                app.setup._answer_again_locked()
            except Exception:
                app.controller.last_inputs = np.full(4, np.nan)
                app.controller.last_output = np.full(2, np.nan)
        app._input_pose = tuple(app.sim.arena.pose)
        app.metrics = None
        app.run_label = app.results._run_label()
        app._run_changes = [(0.0, app.results._settings())]
        app._timeline = [app.results.timeline_entry_locked()]  # what a lesson replays
        app._unreplayed = []  # what a lesson cannot replay (drags during the run)
        app._drops = {}  # obstacle id -> when it was last put down during the run
        app.run_id += 1
        app.layout_id += 1
        self._anchor()
        app._bump()

    def _resense_locked(self) -> None:
        """Paused, or after the run's end: read the world again as it stands now (the
        beams, the four inputs, from the robot where it is) and ask a stateless
        controller again, so that every drag, switch and edit shows at once, with no
        Step. While the run plays the next step does it anyway.

        The read leaves the run as it was: the sensors' noise stream and their update
        cadence are put back afterwards (the next step draws the same noise it would
        have drawn); only the held readings are the fresh ones, as the world now is."""
        app = self.app
        if app.playing and not app.sim.done:
            return
        sim = app.sim
        sensors = sim.sensors
        rng = getattr(sensors, "_rng", None)
        rng_state = rng.bit_generator.state if rng is not None else None
        has_cadence = hasattr(sensors, "_next_update_s")
        cadence = sensors._next_update_s if has_cadence else None
        try:
            if has_cadence:
                sensors._next_update_s = -math.inf  # a read now, not the held one
            inputs = np.asarray(sim.sense()[0], dtype=float)
        except Exception:
            return  # (a broken perception: the panels keep what they had)
        finally:
            if rng_state is not None:
                rng.bit_generator.state = rng_state
            if has_cadence:
                sensors._next_update_s = cadence
        app.controller.last_inputs = inputs
        app._input_pose = tuple(sim.arena.pose)
        app.setup._answer_again_locked()

    def _restart_if_finished_locked(self) -> None:
        """After a change of controller, perception or part: a finished run's outcome
        belonged to what drove it, so a finished run restarts (and becomes the ghost)."""
        app = self.app
        if app.sim.done:
            self._reset_locked(app.editing._layout_scenario())
