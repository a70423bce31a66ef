"""The interactive browser viewer: watch the fuzzy-controlled Husky drive, and push the world around.

``fuzzynav serve [SCENARIO]`` (and ``fuzzynav demo``, which is ``serve s1``) starts a viser
server on 127.0.0.1 and prints its URL. The page shows, seen from above:

- the arena: a ground grid with metre marks, the obstacles as cylinders (static grey-blue,
  moving orange), the target, the robot's trail;
- the Husky as a yellow box (its real 0.99 x 0.67 m footprint) with a heading arrow, the
  25 cm safe-distance ring around it (it turns red when an obstacle is inside), and its
  three ultrasonic beams coloured by what they read (red = close, green = far, grey =
  no echo);
- a handle on every obstacle and on the target, constrained to the ground plane: dragging
  one moves it in the world at once, and the robot reacts on its next control step.

Around the scene: play / pause / step / reset, the speed (0.1x to 10x real time), the
scenario, add / remove obstacle, the controller (whatever ``controller_names()`` offers,
or an uploaded MATLAB ``.fis``), the perception (ideal or ultrasonic), the disturbance and
the sensor noise; live plots of the controller's inputs and the wheel voltages; a
teaching panel with the rules that fire now (and how strongly) and the aggregated output
membership functions with their centroids; and, when a run ends, its outcome and the
paper's Table 4 metrics.

Structure: :class:`ViewerApp` (this module) owns the simulation and its thread and has a
method for every user action; it knows nothing about viser and is tested without a
browser. :mod:`app.viewer.server` builds the viser scene and GUI and calls those methods.
Every tab sees the same world; closing a tab does not stop the simulation; Ctrl-C stops
the server and frees its port. Nothing the browser sends is ever used as a path: uploads
are read from memory (a ``.fis`` goes through a private temporary file).
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fuzzynav.world.perception import GEOMETRIES, PERCEPTION_MODES, Perception
from fuzzynav.world.scenario import (
    Disturbance,
    ObstacleSpec,
    Scenario,
    ScenarioError,
    check_layout,
    load_scenario,
    loads_scenario,
    scenario_names,
    target_blocker,
)
from fuzzynav.world.sensors import RangeSensorArray, SensorConfig
from fuzzynav.world.simulation import Simulation

SPEED_RANGE = (0.1, 10.0)
NOISE_RANGE_M = (0.0, 0.3)
MAX_UPLOAD_BYTES = 512 * 1024
PLOT_WINDOW_S = 30.0
SAFE_DISTANCE_M = 0.25
# A scenario without a disturbance of its own gets the paper's sin(2t) (amplitude 1)
# for as long as the disturbance switch is on.
DEFAULT_DISTURBANCE = Disturbance(
    amplitude=1.0, angular_frequency_rad_s=2.0, start_s=0.0, stop_s=math.inf
)
NEW_OBSTACLE_RADIUS_M = 0.25
UPLOADED_PREFIX = "uploaded: "
EDITED_LABEL = "paper (edited)"


class ViewerError(ValueError):
    """A user action that cannot be done; the message is shown in the page."""


def safe_display_name(name: str, default: str = "upload") -> str:
    """A browser-sent file name reduced to something safe to *show* (never to open)."""
    base = re.split(r"[\\/]", str(name or ""))[-1]
    base = re.sub(r"[^A-Za-z0-9._ -]", "_", base).strip(" .")
    return (base or default)[:60]


class _ObservedController:
    """Wraps the controller: records what it was given and what it answered.

    The simulation sees the wrapped controller's attributes (``needs_ranges``, ``fis``,
    ...) through ``__getattr__``. The recorded wall-clock time of each call is what the
    drag-latency benchmark measures against.
    """

    def __init__(self, inner, on_call=None, name: str = ""):
        self.inner = inner
        self.name = name  # what recordings call the controller
        self.on_call = on_call
        self.last_inputs = np.full(4, np.nan)
        self.last_output = np.full(2, np.nan)
        self.last_call_wall_s = 0.0

    def reset(self):
        self.inner.reset()

    def __call__(self, inputs, **kwargs):
        out = self.inner(inputs, **kwargs)
        self.last_inputs = np.array(inputs, dtype=float)
        self.last_output = np.asarray(out, dtype=float).reshape(2)
        self.last_call_wall_s = time.perf_counter()
        if self.on_call is not None:
            self.on_call(self.last_inputs, self.last_call_wall_s)
        return out

    def __getattr__(self, name):
        # Only reached for attributes this wrapper lacks (fis, needs_ranges, name, ...).
        return getattr(self.inner, name)


class _Ring:
    """Fixed-capacity ring of rows (time plus values) for the live plots."""

    def __init__(self, capacity: int, width: int):
        self.data = np.full((capacity, width), np.nan)
        self.n = 0
        self.capacity = capacity

    def append(self, row) -> None:
        self.data[self.n % self.capacity] = row
        self.n += 1

    def clear(self) -> None:
        self.n = 0

    def ordered(self) -> np.ndarray:
        if self.n <= self.capacity:
            return self.data[: self.n].copy()
        k = self.n % self.capacity
        return np.concatenate([self.data[k:], self.data[:k]])


@dataclass
class ObstacleView:
    id: int
    xy: tuple[float, float]
    radius_m: float
    is_static: bool
    velocity: tuple[float, float]


@dataclass
class Ghost:
    """The previous run, kept on screen when the next starts: its trail, what drove it
    (scenario, controller, perception, parts) and its metrics."""

    trail: np.ndarray
    label: str
    metrics: dict


@dataclass
class HistoryStep:
    """A control step as the time slider shows it again."""

    time_s: float
    pose: tuple
    input_pose: tuple
    inputs: np.ndarray
    output: np.ndarray
    target: tuple
    obstacles: dict  # id -> (x, y)
    trail_length: int
    block: tuple | None = None  # fuzzynav: (what its blocks were fed, its crisp parts)


@dataclass
class Snapshot:
    """What the scene needs to draw one frame (copied under the lock)."""

    version: int
    run_id: int
    layout_id: int
    time_s: float
    playing: bool
    speed: float
    outcome: str | None
    pose: tuple[float, float, float]
    footprint_m: tuple[float, float]
    target: tuple[float, float]
    tolerance_m: float
    obstacles: list[ObstacleView]
    beams: list[tuple[tuple[float, float], float]]  # (origin, direction) per sensor
    ranges_m: np.ndarray
    beam_width_rad: float
    max_range_m: float
    inputs: np.ndarray
    voltages_v: np.ndarray
    nearest_clearance_m: float
    trail_length: int
    scenario_label: str
    controller_label: str
    perception: str
    geometry: str
    disturbance_on: bool
    noise_std_m: float
    message: str
    message_level: str
    layout_edited: bool = False
    metrics: dict | None = None
    # A controller that shows its memory (fuzzynav): remembered echoes (world frame, as
    # the robot places them) and the bearing it steers to (world frame, rad).
    memory_xy: np.ndarray | None = None
    steer_heading_rad: float = math.nan
    # fuzzynav's parts switched off (assets/rules/fuzzynav_parts.toml), and whether the
    # controller driving has such parts at all.
    parts_off: tuple[str, ...] = ()
    has_parts: bool = False
    ghost: Ghost | None = None
    ghost_id: int = 0
    run_label: str = ""
    # The disturbance switched on (in words, "" when off), and whether it was added to
    # the inputs the controller was last given (inside its time window).
    disturbance_text: str = ""
    inputs_disturbed: bool = False
    obstacle_numbers: dict = field(default_factory=dict)  # id -> the number shown
    what_if: np.ndarray | None = None  # the inputs tried in what-if mode, or None
    input_pose: tuple | None = None  # the pose the inputs were read at
    history: bool = False  # showing a recorded step (the time slider), not the live world
    history_span: tuple = (0.0, 0.0)  # the recorded times of this run
    extra: dict = field(default_factory=dict)


class ViewerApp:
    """The simulation behind the viewer, driven from a thread of its own.

    Every public method is safe to call from any thread (the GUI callbacks run on
    viser's thread pool). A method that cannot do what is asked raises
    :class:`ViewerError` and leaves the world as it was.

    Parameters
    ----------
    scenario : str, Path or Scenario
        Shipped name (``s1``), a TOML path given on the command line, or a Scenario.
    controller : str or None
        A name from ``controller_names()``; default ``paper`` when present, else the first.
    perception, noise_std_m, seed, control_period_s
        As for :class:`world.simulation.Simulation`.
    rrd_path : str or Path, optional
        Record every run to a rerun file (``--rrd``): the first run to this path, later
        runs (after a reset) to ``<stem>-run2.rrd``, ``<stem>-run3.rrd``... Each file is
        completed when its run ends or is reset, and when the viewer stops.
    """

    def __init__(
        self,
        scenario="s1",
        controller: str | None = None,
        *,
        perception: str = "ideal",
        noise_std_m: float = 0.0,
        seed: int | None = 0,
        control_period_s: float = 0.02,
        rrd_path=None,
        geometry: str = "husky",
    ):
        from fuzzynav.controller.registry import controller_names

        self.lock = threading.RLock()
        self.seed = seed
        self.rrd_path = Path(rrd_path) if rrd_path is not None else None
        self._recorder = None
        self.recorded_files: list[Path] = []
        self._changed = threading.Condition(self.lock)
        self.version = 0
        self.run_id = 0
        self.layout_id = 0
        self.playing = False
        self.speed = 1.0
        self.message, self.message_level = "", "info"
        self._listeners: list = []
        self.uploaded_controller = None
        self.uploaded_label: str | None = None
        self.uploaded_scenarios: dict[str, Scenario] = {}
        self.parts_off: tuple[str, ...] = ()
        self.ghost: Ghost | None = None
        self.ghost_id = 0
        self._trail = None
        self.run_label = ""
        self._run_changes: list = []
        self.paper_edit = None  # the membership editor (PaperEditor), built on first use
        self.what_if: np.ndarray | None = None  # what-if mode: the inputs tried
        self.history_index: int | None = None  # the time slider's step, or None (live)
        self._history: list[HistoryStep] = []
        self._resume_after_what_if = False

        if geometry not in GEOMETRIES:
            raise ViewerError(f"geometry = {geometry!r}: choose one of {', '.join(GEOMETRIES)}")
        if geometry == "paper" and perception != "ideal":
            raise ViewerError("the paper's geometry takes ideal perception only")
        self.geometry = geometry
        scenario_obj, label = self._resolve_scenario(scenario)
        names = controller_names()
        if controller is None:
            controller = "paper" if "paper" in names else names[0]
        inner = self._make_named_controller(controller, geometry)
        self.controller_label = controller
        self.noise_std_m = self._check_noise(noise_std_m)
        if perception not in PERCEPTION_MODES:
            raise ViewerError(f"perception = {perception!r}: choose one of {PERCEPTION_MODES}")
        self.controller = _ObservedController(inner, self._on_controller_call, controller)
        self.sim = Simulation(
            scenario_obj,
            self.controller,
            perception=perception,
            control_period_s=control_period_s,
            seed=seed,
            sensor_config=SensorConfig(noise_std_m=self.noise_std_m),
            geometry=geometry,
        )
        self.scenario_label = label
        self.base_scenario = scenario_obj
        self.disturbance_on = scenario_obj.disturbance is not None
        self._input_watchers: list = []
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self.steps_taken = 0
        with self.lock:
            self._reset_locked(scenario_obj)

    # -- construction helpers ----------------------------------------------------------

    @staticmethod
    def _resolve_scenario(scenario) -> tuple[Scenario, str]:
        if isinstance(scenario, Scenario):
            return scenario, scenario.name
        text = str(scenario)
        sc = load_scenario(text)
        label = text if text in scenario_names() else Path(text).stem
        return sc, label

    @staticmethod
    def _make_named_controller(name: str, geometry: str = "husky"):
        from fuzzynav.controller.registry import controller_names, make_controller

        if name not in controller_names():
            raise ViewerError(
                f"controller {name!r} is not available (available: {', '.join(controller_names())})"
            )
        return make_controller(name, geometry=geometry)

    @staticmethod
    def _check_noise(std) -> float:
        try:
            std = float(std)
        except (TypeError, ValueError):
            raise ViewerError(f"sensor noise = {std!r}: must be a number of metres") from None
        if not (math.isfinite(std) and NOISE_RANGE_M[0] <= std <= NOISE_RANGE_M[1]):
            raise ViewerError(
                f"sensor noise = {std!r} m: must be between "
                f"{NOISE_RANGE_M[0]} and {NOISE_RANGE_M[1]} m"
            )
        return std

    # -- the simulation thread ---------------------------------------------------------

    def start(self) -> ViewerApp:
        """Start the simulation thread (it idles until :meth:`play`)."""
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="fuzzynav-sim", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the simulation thread and complete the recording, if any."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        with self.lock:
            self._close_recorder_locked()

    # -- recording (--rrd) -------------------------------------------------------------

    def _record_locked(self) -> None:
        if self.rrd_path is None:
            return
        try:
            if self._recorder is None:
                from fuzzynav.app.recordings.record import LiveRecorder

                path = self._next_recording_path()
                try:
                    self._recorder = LiveRecorder(path)
                except BaseException:
                    if path != self.rrd_path and path.exists() and path.stat().st_size == 0:
                        path.unlink()  # our reservation, never written
                    raise
                self.recorded_files.append(path)
            self._recorder.update(self.sim)
        except Exception as exc:  # a full disk must not stop the simulation
            self._recorder = None
            self.rrd_path = None
            self._notice(f"Recording stopped: {exc}", "warning")

    def _next_recording_path(self) -> Path:
        """The file of the next run: ``--rrd`` itself first, then ``<stem>-runK.rrd``
        with the first K whose file does not exist, reserved at once (created empty,
        exclusively), so that a second ``serve --rrd`` on the same path never takes,
        nor overwrites, this one's runs (issue 26)."""
        if not self.recorded_files:
            return self.rrd_path
        suffix = self.rrd_path.suffix or ".rrd"
        k = len(self.recorded_files) + 1
        while True:
            path = self.rrd_path.with_name(f"{self.rrd_path.stem}-run{k}{suffix}")
            try:
                os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
                return path
            except FileExistsError:
                k += 1

    def _close_recorder_locked(self) -> None:
        recorder, self._recorder = self._recorder, None
        if recorder is not None:
            try:
                recorder.close(self.sim)
            except Exception as exc:
                self._notice(f"Recording could not be completed: {exc}", "warning")

    def _anchor(self) -> None:
        """Pace from here: sim time advances speed x wall time from this instant."""
        self._anchor_wall = time.perf_counter()
        self._anchor_sim = self.sim.time_s

    def _run(self) -> None:
        dt = self.sim.control_period_s
        while not self._stop.is_set():
            with self.lock:
                active = self.playing and not self.sim.done
                if active:
                    target = (
                        self._anchor_sim + (time.perf_counter() - self._anchor_wall) * self.speed
                    )
                    if target - self.sim.time_s > 0.25 * max(self.speed, 1.0):
                        # Fell behind (slow machine, debugger): drop the backlog, not the pace.
                        self._anchor()
                        target = self.sim.time_s + dt
            if not active:
                self._wake.wait(0.05)
                self._wake.clear()
                continue
            stepped = 0
            while not self._stop.is_set():
                with self.lock:
                    if not self.playing or self.sim.done or self.sim.time_s + 0.5 * dt > target:
                        break
                    self._step_locked()
                    stepped += 1
                if stepped >= 200:
                    break
            with self.lock:
                if not self.playing or self.sim.done:
                    continue
                due = self._anchor_wall + (self.sim.time_s + dt - self._anchor_sim) / self.speed
            delay = due - time.perf_counter()
            if delay > 0:
                self._wake.wait(min(delay, 0.05))
                self._wake.clear()

    def _step_locked(self) -> None:
        sim = self.sim
        self._input_pose = tuple(sim.arena.pose)  # where the controller reads its inputs
        try:
            outcome = sim.step()
        except Exception as exc:  # a controller that fails must not kill the thread
            self.playing = False
            self._notice(f"The simulation stopped: {exc}", "error")
            return
        self.steps_taken += 1
        self._record_locked()
        x, y, _ = sim.arena.pose
        last = self._trail[-1]
        if (x - last[0]) ** 2 + (y - last[1]) ** 2 > 0.02**2:
            self._trail.append((x, y))
        c = self.controller
        limit = sim.voltage_limit_v
        applied = np.clip(c.last_output, -limit, limit)
        self._signals.append((sim.time_s - sim.control_period_s, *c.last_inputs, *applied))
        self._record_history_locked()
        if outcome is not None:
            self.playing = False
            self._finish_locked()
        self._bump()

    def _record_history_locked(self) -> None:
        """One entry per control step, for the time slider: what the scene and the
        inference view need to show that step again (fuzzynav's blocks: what they were
        fed and its crisp parts)."""
        sim, c = self.sim, self.controller
        arena = sim.arena
        view = getattr(c.inner, "teaching_view", None)
        seen = view() if view is not None else None
        centres, _, ids = arena.obstacle_arrays()  # (cached by the arena for this step)
        self._history.append(
            HistoryStep(
                time_s=sim.time_s,
                pose=tuple(arena.pose),
                input_pose=self._input_pose,
                inputs=c.last_inputs.copy(),
                output=c.last_output.copy(),
                target=tuple(float(v) for v in arena.target),
                obstacles=dict(zip(ids, map(tuple, centres.tolist()))),
                trail_length=len(self._trail),
                block=None if seen is None else (seen[1].copy(), dict(seen[2])),
            )
        )

    # -- run history (the time slider) -----------------------------------------------

    def history_times(self) -> tuple[float, float]:
        """(first, last) time of the recorded steps of this run (0, 0 before any)."""
        with self.lock:
            if not self._history:
                return 0.0, 0.0
            return self._history[0].time_s, self._history[-1].time_s

    def view_history(self, time_s) -> float | None:
        """Show the run as it was at ``time_s`` (the recorded step nearest to it): the
        scene, the inputs and the inference of that step; the run pauses there, and
        Play, Step or :meth:`leave_history` go back to where it is. None leaves it.
        Returns the time shown."""
        if time_s is None:
            self.leave_history()
            return None
        try:
            time_s = float(time_s)
        except (TypeError, ValueError):
            raise ViewerError(f"time {time_s!r}: must be a number of seconds") from None
        with self.lock:
            if not self._history:
                raise ViewerError("nothing recorded yet: press Play or Step first")
            times = np.array([h.time_s for h in self._history])
            k = int(np.argmin(np.abs(times - time_s)))
            self.playing = False
            self.what_if = None
            self.history_index = k
            self._bump()
            return float(times[k])

    def firing_timeline(self):
        """(times (n,), strengths (n, n_rules)) of this run's recorded steps, for the
        rule-firing strip; None without a rule base or before the first step."""
        with self.lock:
            steps = list(self._history)
            fis = self.fuzzy_system()
            teaching = hasattr(self.controller.inner, "teaching_view")
        if fis is None or not steps:
            return None
        if teaching:
            rows = [h for h in steps if h.block is not None]
            X = np.array([h.block[0] for h in rows], dtype=float)
        else:
            rows = [h for h in steps if np.isfinite(h.inputs[0])]
            X = np.array([h.inputs[: fis.n_inputs] for h in rows], dtype=float)
        if not rows or X.ndim != 2 or X.shape[1] != fis.n_inputs:
            return None  # (recorded with another controller: nothing to show)
        return np.array([h.time_s for h in rows]), np.asarray(fis.firing_strengths(X))

    def leave_history(self) -> None:
        with self.lock:
            if self.history_index is not None:
                self.history_index = None
                self._bump()

    def _finish_locked(self) -> None:
        self._close_recorder_locked()
        try:
            result = self.sim.result()
        except Exception as exc:  # metrics must never take the viewer down
            self._notice(f"metrics could not be computed: {exc}", "warning")
            return
        self.metrics = dict(result.metrics)
        self.metrics["collisions"] = len(result.collisions)
        text = {
            "reached": "reached the target",
            "collided": "collided with an obstacle",
            "timeout": "ran out of time",
        }.get(result.outcome, result.outcome)
        level = "success" if result.outcome == "reached" else "warning"
        self._notice(f"Run ended at t = {self.sim.time_s:.2f} s: the robot {text}.", level)

    def _on_controller_call(self, inputs, wall_s) -> None:
        for watcher in list(self._input_watchers):
            watcher(inputs, wall_s)

    def add_input_watcher(self, func) -> None:
        """``func(inputs, wall_time_s)`` after every controller call (benchmarks)."""
        self._input_watchers.append(func)

    def remove_input_watcher(self, func) -> None:
        self._input_watchers.remove(func)

    # -- notification ------------------------------------------------------------------

    def _bump(self) -> None:
        with self.lock:
            self.version += 1
            self._changed.notify_all()

    def _notice(self, text: str, level: str = "info") -> None:
        with self.lock:
            self.message, self.message_level = text, level
            self._bump()
        for listener in list(self._listeners):
            try:
                listener(text, level)
            except Exception:
                pass

    def on_message(self, func) -> None:
        """``func(text, level)`` whenever the app has something to tell the user."""
        self._listeners.append(func)

    def wait_for(self, predicate, timeout: float = 10.0) -> bool:
        """Block until ``predicate(app)`` is true (checked at every change); for tests."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while not predicate(self):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._changed.wait(min(remaining, 0.1))
        return True

    # -- run control -------------------------------------------------------------------

    def play(self) -> None:
        with self.lock:
            self.what_if = None  # Play leaves what-if mode ...
            self.history_index = None  # ... and the time slider's past
            if self.sim.done:
                self._reset_locked(self._layout_scenario())
            self.playing = True
            self._anchor()
            self._bump()
        self._wake.set()

    def pause(self) -> None:
        with self.lock:
            self.playing = False
            self._bump()

    def toggle(self) -> None:
        if self.playing:
            self.pause()
        else:
            self.play()

    def step_once(self) -> None:
        """Pause and advance exactly one control period."""
        with self.lock:
            self.what_if = None
            self.history_index = None
            self.playing = False
            if self.sim.done:
                self._reset_locked(self._layout_scenario())
            self._step_locked()

    def reset(self) -> None:
        """Back to the start, with the layout as it is now (drags, added obstacles kept)."""
        with self.lock:
            self.playing = False
            layout = self._layout_scenario()
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
                self._notice(
                    self.plain_names(f"Note: {exc.key} {exc.reason}; {consequence}."), "warning"
                )

    def _settings(self) -> list[str]:
        """What drives the run now, in words: controller (and fuzzynav's parts off),
        perception, disturbance, sensor noise."""
        controller = self.controller_label
        if self.parts_off and hasattr(self.controller.inner, "set_parts_off"):
            controller += " without " + " and ".join(self.parts_off)
        parts = [controller, self.sim.perception.mode]
        if self.disturbance_on:
            parts.append(self.disturbance_text())
        if self.noise_std_m > 0:
            parts.append(f"noise σ {self.noise_std_m:.2f} m")
        return parts

    def disturbance_text(self) -> str:
        d = self.disturbance_in_use()
        window = (
            ""
            if d.start_s <= 0 and not math.isfinite(d.stop_s)
            else f" for {d.start_s:g}-{d.stop_s:g} s"
        )
        return f"disturbed by {d.amplitude:g}·sin({d.angular_frequency_rad_s:g}t){window}"

    def _run_label(self) -> str:
        return " · ".join([self.scenario_label, *self._settings()])

    def _note_change_locked(self) -> None:
        """After a change of what drives (controller, parts, perception, disturbance,
        noise): a run not started yet is labelled afresh; a run under way keeps what it
        started with, and the change is added with its time ("from 3.2 s: ...")."""
        settings = self._settings()
        if self.sim.time_s <= 0.0 or not self._run_changes:
            self._run_changes = [(0.0, settings)]
            self.run_label = self._run_label()
            return
        if settings == self._run_changes[-1][1]:
            return
        self._run_changes.append((self.sim.time_s, settings))
        first = self._run_changes[0][1]
        later = [f"from {t:.1f} s: {' · '.join(p)}" for t, p in self._run_changes[1:]]
        if len(later) > 3:
            later = later[:1] + ["…"] + later[-2:]
        self.run_label = " · ".join([self.scenario_label, *first]) + "; " + "; ".join(later)

    def _partial_metrics(self) -> dict:
        """What can be said of a run stopped before its end: its time and path so far."""
        trail = np.asarray(self._trail, dtype=float)
        length = float(np.sum(np.linalg.norm(np.diff(trail, axis=0), axis=1)))
        return {
            "outcome": f"stopped at t = {self.sim.time_s:.1f} s",
            "path_length_m": length,
        }

    def _restart_if_finished_locked(self) -> None:
        """After a change of controller, perception or part: a finished run's outcome
        belonged to what drove it, so a finished run restarts (and becomes the ghost)."""
        if self.sim.done:
            self._reset_locked(self._layout_scenario())

    def set_speed(self, factor) -> None:
        try:
            factor = float(factor)
        except (TypeError, ValueError):
            raise ViewerError(f"speed = {factor!r}: must be a number") from None
        if not (math.isfinite(factor) and SPEED_RANGE[0] - 1e-9 <= factor <= SPEED_RANGE[1] + 1e-9):
            raise ViewerError(
                f"speed = {factor!r}: must be between {SPEED_RANGE[0]} and "
                f"{SPEED_RANGE[1]} times real time"
            )
        with self.lock:
            self.speed = factor
            self._anchor()
            self._bump()
        self._wake.set()

    def _reset_locked(self, scenario: Scenario) -> None:
        self._close_recorder_locked()
        if getattr(self, "_trail", None) is not None and len(self._trail) > 1:
            # The run that ends here stays on screen as a ghost, its numbers beside the next.
            self.ghost = Ghost(
                trail=np.array(self._trail, dtype=float),
                label=self.run_label,
                metrics=dict(self.metrics) if self.metrics else self._partial_metrics(),
            )
            self.ghost_id += 1
        # A new run: what was said about the last one (its outcome) no longer holds.
        self.message, self.message_level = "", "info"
        self.what_if = None
        self.history_index = None
        self._history = []
        self.sim.reset(seed=self.seed, scenario=scenario)
        self._apply_disturbance_locked()
        self._layout = [
            (obstacle_id, spec)
            for obstacle_id, spec in zip(self.sim.arena.obstacles, scenario.obstacles)
        ]
        self._target = tuple(scenario.target)
        self._target_warning = None
        self._trail = [tuple(self.sim.arena.pose[:2])]
        capacity = int(PLOT_WINDOW_S / self.sim.control_period_s) + 1
        self._signals = _Ring(capacity, 7)
        self.controller.last_inputs = np.full(4, np.nan)
        self.controller.last_output = np.full(2, np.nan)
        if self.noise_std_m == 0.0:
            # What the controller will read at the start, shown before the first step
            # (not with sensor noise: a read would draw from the run's noise stream).
            try:
                self.controller.last_inputs = np.asarray(self.sim.sense()[0], dtype=float)
                self._answer_again_locked()
            except Exception:
                self.controller.last_inputs = np.full(4, np.nan)
                self.controller.last_output = np.full(2, np.nan)
        self._input_pose = tuple(self.sim.arena.pose)
        self.metrics = None
        self.run_label = self._run_label()
        self._run_changes = [(0.0, self._settings())]
        self.run_id += 1
        self.layout_id += 1
        self._anchor()
        self._bump()

    # -- scenario and layout -----------------------------------------------------------

    def scenario_options(self) -> list[str]:
        options = list(scenario_names())
        if self.scenario_label not in options:
            options.append(self.scenario_label)
        for name in self.uploaded_scenarios:
            if name not in options:
                options.append(name)
        return options

    def load_scenario(self, name: str) -> None:
        """Switch to a shipped scenario (by name) or one uploaded before; pauses at t = 0."""
        if name in self.uploaded_scenarios:
            scenario = self.uploaded_scenarios[name]
        elif name == self.scenario_label:
            scenario = self.base_scenario
        elif name in scenario_names():
            try:
                scenario = load_scenario(name)
            except ScenarioError as exc:
                raise ViewerError(str(exc)) from None
        else:
            raise ViewerError(
                f"scenario {name!r}: unknown (choose from {', '.join(self.scenario_options())})"
            )
        with self.lock:
            self.playing = False
            other = name != self.scenario_label
            self.base_scenario = scenario
            self.scenario_label = name
            self.disturbance_on = scenario.disturbance is not None
            self._reset_locked(scenario)
            if other:  # the last run's trail and numbers belong to another arena
                self.ghost = None
                self.ghost_id += 1
            self._notice(f"Loaded {scenario.name}.", "info")

    def upload_scenario(self, content: bytes, filename: str = "scenario.toml") -> str:
        """Validate an uploaded TOML scenario and switch to it; returns its label.

        A bad file raises :class:`ViewerError` naming the key and value; the running
        world is left as it was.
        """
        label = UPLOADED_PREFIX + safe_display_name(filename, "scenario.toml")
        if len(content) > MAX_UPLOAD_BYTES:
            raise ViewerError(f"{label}: {len(content)} bytes is too large for a scenario file")
        try:  # bounded: nesting, numbers, counts (world/scenario.py)
            scenario = loads_scenario(
                bytes(content), source=label, footprint_m=self.sim.arena.footprint_m
            )
        except ScenarioError as exc:
            raise ViewerError(str(exc)) from None
        from fuzzynav.world.simulation import check_run_size

        try:  # the run's log within the memory budget, as `fuzzynav run` checks (issue 26)
            check_run_size(scenario.duration_s, self.sim.control_period_s, len(scenario.obstacles))
        except ValueError as exc:
            raise ViewerError(f"{label}: {exc}") from None
        self.uploaded_scenarios[label] = scenario
        self.load_scenario(label)
        return label

    def restore_layout(self) -> None:
        """Undo every drag, addition and removal: the scenario as loaded, at t = 0."""
        with self.lock:
            self.playing = False
            self.disturbance_on = self.base_scenario.disturbance is not None
            self._reset_locked(self.base_scenario)

    def _layout_scenario(self) -> Scenario:
        """The scenario as edited: obstacles and target where the user put them."""
        return self.base_scenario.replace(
            target=tuple(self._target), obstacles=tuple(spec for _, spec in self._layout)
        )

    @property
    def layout_edited(self) -> bool:
        return self._layout_scenario() != self.base_scenario

    def _check_xy(self, xy) -> tuple[float, float]:
        try:
            x, y = (float(v) for v in list(xy)[:2])
        except (TypeError, ValueError):
            raise ViewerError(f"position {xy!r}: must be two numbers") from None
        if not (math.isfinite(x) and math.isfinite(y)) or max(abs(x), abs(y)) > 1000:
            raise ViewerError(f"position {xy!r}: must be finite and within 1 km")
        return x, y

    def obstacle_number(self, obstacle_id: int) -> int:
        """The number the page gives an obstacle (its label in the arena, its name in
        messages): its place in the layout, from 1 (``obstacles[k]`` of the scenario
        file is obstacle k + 1)."""
        with self.lock:
            for k, (i, _) in enumerate(self._layout):
                if i == obstacle_id:
                    return k + 1
        return obstacle_id + 1

    @staticmethod
    def plain_names(text: str) -> str:
        """``obstacles[k]`` (the scenario file's name) as the page says it: obstacle k+1."""
        return re.sub(r"obstacles\[(\d+)\]", lambda m: f"obstacle {int(m.group(1)) + 1}", text)

    def check_target(self) -> str | None:
        """After an edit (a drag ended, an obstacle added): tell the user when the target
        can no longer be reached, and when it can again. Returns the warning, if any."""
        with self.lock:
            layout = self._layout_scenario()
            blocked = target_blocker(
                layout.target,
                layout.tolerance_m,
                layout.obstacles,
                0.5 * self.sim.arena.footprint_m[1],
            )
            if blocked is not None:
                text = self.plain_names(f"The target {blocked[1]}: the robot cannot get there.")
                self._target_warning = text
                self._notice(text, "warning")
                return text
            # A finished run restarts from the start on Play: judge the start, not where
            # the last run stopped (it may have stopped against that very obstacle).
            finished = self.sim.done
            on_robot = self.obstacles_on_robot(at_start=finished)
            if on_robot:
                names = ", ".join(str(self.obstacle_number(i)) for i in on_robot)
                text = (
                    f"Obstacle {names} is on the robot's start: the next run will end in a "
                    "collision at once. Drag it off the start."
                    if finished
                    else f"Obstacle {names} is on the robot: Play will end in a collision "
                    "at once. Drag it off the robot."
                )
                self._target_warning = text
                self._notice(text, "warning")
                return text
            if self._target_warning is not None:
                self._target_warning = None
                self._notice("The target can be reached again.", "info")
            return None

    def obstacles_on_robot(self, at_start: bool = False) -> list[int]:
        """Ids of the obstacles that overlap the robot's footprint where it stands (or,
        ``at_start``, where the next run starts, with the obstacles of the layout)."""
        with self.lock:
            arena = self.sim.arena
            if at_start:
                return self._obstacles_on_start_locked()
            clearances = arena.clearances()
            if self.geometry == "paper":  # the 25 cm are judged centre to centre there
                clearances = clearances + np.array(arena._scene().radii, dtype=float)
            ids = list(arena.obstacles)
            return [i for i, c in zip(ids, np.asarray(clearances).tolist()) if c <= 0.0]

    def _obstacles_on_start_locked(self) -> list[int]:
        sc = self.sim.scenario
        x, y = sc.start
        heading = sc.heading_rad
        length, width = self.sim.arena.footprint_m
        c, s = math.cos(heading), math.sin(heading)
        out = []
        for obstacle_id, spec in self._layout:
            dx, dy = spec.position[0] - x, spec.position[1] - y
            lx, ly = c * dx + s * dy, -s * dx + c * dy
            gap = math.hypot(max(abs(lx) - 0.5 * length, 0.0), max(abs(ly) - 0.5 * width, 0.0))
            if self.geometry != "paper":
                gap -= spec.radius_m
            if gap <= 0.0:
                out.append(obstacle_id)
        return out

    # -- the paper controller's membership editor ----------------------------------

    def editor(self):
        """The membership editor of the paper controller (built on first use)."""
        from fuzzynav.app.viewer.editor import PaperEditor

        with self.lock:
            if self.paper_edit is None:
                self.paper_edit = PaperEditor(self.geometry)
            return self.paper_edit

    def set_membership_parameter(self, name: str, value) -> None:
        """Change one of the paper controller's membership parameters and drive with the
        edited system at once (the run goes on)."""
        editor = self.editor()
        try:
            controller = editor.set(name, value)
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
        self._install_controller(controller, EDITED_LABEL, quiet=True)

    def set_inference_choice(self, field: str, value: str) -> None:
        """Change one of the paper controller's inference choices (issue 27: AND,
        implication, aggregation, defuzzification) and drive with it at once."""
        try:
            controller = self.editor().set_choice(field, value)
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
        self._install_controller(controller, EDITED_LABEL, quiet=True)

    def reset_membership_editor(self) -> None:
        """Back to the shipped paper controller (and its parameters in the editor)."""
        editor = self.editor()
        controller = editor.reset()
        self._install_controller(controller, "paper")

    def edited_fis_text(self) -> str:
        """The edited paper system as a MATLAB .fis file (text)."""
        return self.editor().fis_text()

    def move_target(self, xy) -> None:
        x, y = self._check_xy(xy)
        with self.lock:
            self.sim.arena.move_target((x, y))
            self._target = (x, y)
            # A controller that doubts target readings which move the target (fuzzynav,
            # against disturbed inputs) is told that this move is meant.
            new_target = getattr(self.controller.inner, "new_target", None)
            if new_target is not None:
                new_target()
            self._bump()

    def move_obstacle(self, obstacle_id: int, xy) -> None:
        """Put an obstacle at ``xy`` now; a moving one keeps its velocity from there."""
        x, y = self._check_xy(xy)
        with self.lock:
            arena = self.sim.arena
            if obstacle_id not in arena.obstacles:
                raise ViewerError("that obstacle does not exist (any more)")
            before = arena.obstacles[obstacle_id].position_at(arena.time_s)
            arena.move_obstacle(obstacle_id, (x, y))
            # The layout (what a reset restarts from) shifts that obstacle's whole path.
            delta = np.array((x, y)) - before
            for k, (i, spec) in enumerate(self._layout):
                if i == obstacle_id:
                    moved = tuple(float(v) for v in np.asarray(spec.position) + delta)
                    self._layout[k] = (
                        i,
                        ObstacleSpec(moved, spec.radius_m, spec.velocity, spec.acceleration),
                    )
            self._bump()

    def suggest_obstacle_position(self) -> tuple[float, float]:
        """Where a new obstacle is most instructive: on the way from the robot to the target."""
        with self.lock:
            x, y, heading = self.sim.arena.pose
            tx, ty = self.sim.arena.target
            centres, radii, _ = self.sim.arena.obstacle_arrays()
        for frac in (0.5, 0.35, 0.65, 0.2, 0.8):
            px, py = x + frac * (tx - x), y + frac * (ty - y)
            if math.hypot(px - x, py - y) < 1.2 or math.hypot(px - tx, py - ty) < 0.8:
                continue
            if all(
                math.hypot(px - c[0], py - c[1]) > r + NEW_OBSTACLE_RADIUS_M + 0.3
                for c, r in zip(centres.tolist(), radii.tolist())
            ):
                return (round(px, 2), round(py, 2))
        # No free spot on the way: 2.5 m ahead of the robot, a little to its left.
        return (
            round(x + 2.5 * math.cos(heading + 0.3), 2),
            round(y + 2.5 * math.sin(heading + 0.3), 2),
        )

    def add_obstacle(self, xy=None, radius_m: float = NEW_OBSTACLE_RADIUS_M) -> int:
        """Add a static obstacle (at a useful spot unless ``xy`` is given); returns its id."""
        if xy is None:
            xy = self.suggest_obstacle_position()
        x, y = self._check_xy(xy)
        radius_m = float(radius_m)
        if not (math.isfinite(radius_m) and 0.02 <= radius_m <= 5.0):
            raise ViewerError(f"radius {radius_m!r} m: must be between 0.02 and 5 m")
        spec = ObstacleSpec((x, y), radius_m)
        with self.lock:
            obstacle_id = self.sim.arena.add_obstacle(spec)
            self._layout.append((obstacle_id, spec))
            self.layout_id += 1
            self._bump()
        self.check_target()
        return obstacle_id

    def remove_obstacle(self, obstacle_id: int | None = None) -> int:
        """Remove an obstacle (the newest when no id is given); returns its id."""
        with self.lock:
            arena = self.sim.arena
            if obstacle_id is None:
                if not arena.obstacles:
                    raise ViewerError("there is no obstacle to remove")
                obstacle_id = max(arena.obstacles)
            if obstacle_id not in arena.obstacles:
                raise ViewerError("that obstacle does not exist (any more)")
            arena.remove_obstacle(obstacle_id)
            self._layout = [(i, s) for i, s in self._layout if i != obstacle_id]
            self.layout_id += 1
            self._bump()
        self.check_target()
        return obstacle_id

    # -- controller, perception, disturbance, noise ------------------------------------

    def controller_options(self) -> list[str]:
        from fuzzynav.controller.registry import controller_names

        options = list(controller_names())
        if self.paper_edit is not None and self.paper_edit.edited:
            options.append(EDITED_LABEL)
        if self.uploaded_label:
            options.append(self.uploaded_label)
        return options

    def set_controller(self, name: str) -> None:
        """Swap the controller by name; the run goes on from where it is."""
        if self.uploaded_label and name == self.uploaded_label:
            inner = self.uploaded_controller
        elif name == EDITED_LABEL and self.paper_edit is not None:
            inner = self.paper_edit.controller()
        else:
            try:
                inner = self._make_named_controller(name, self.geometry)
            except ViewerError:
                raise
            except Exception as exc:
                raise ViewerError(f"controller {name!r} could not be built: {exc}") from None
        self._install_controller(inner, name)

    def set_controller_object(self, controller, label: str) -> None:
        """Drive with a ready-made controller object (tests, notebooks)."""
        self._install_controller(controller, label)

    def _install_controller(self, inner, label: str, quiet: bool = False) -> None:
        with self.lock:
            inner.reset()
            if hasattr(inner, "set_parts_off"):
                inner.set_parts_off(self.parts_off)
            self.controller.inner = inner
            self.controller.name = label
            self.controller_label = label
            if self.what_if is not None and self.what_if_system() is None:
                self.what_if = None  # nothing to try inputs on
            self._restart_if_finished_locked()
            self._note_change_locked()
            self._answer_again_locked()
            if not quiet:
                self._notice(f"Controller: {label}.", "info")
            else:
                self._bump()

    def _answer_again_locked(self) -> None:
        """What the panels show must be the controller now driving: a stateless one
        (a plain fuzzy system) is asked again at the last inputs; one with a memory
        (fuzzynav) would be disturbed by an extra call, so its answer is unknown
        until the next step."""
        c = self.controller
        if not np.isfinite(c.last_inputs[0]):
            return
        inner = c.inner
        if getattr(inner, "fis", None) is not None and not hasattr(inner, "teaching_view"):
            c.last_output = np.asarray(inner(c.last_inputs), dtype=float).reshape(2)
        else:
            c.last_output = np.full(2, np.nan)

    def upload_fis(self, content: bytes, filename: str = "controller.fis") -> str:
        """Build a controller from an uploaded MATLAB ``.fis`` and drive with it.

        The bytes go to a private temporary file (the browser's file name is only
        shown, never opened). A file that cannot be used raises :class:`ViewerError`
        and the running controller and world are kept.
        """
        from fuzzynav.controller.registry import make_controller

        display = safe_display_name(filename, "controller.fis")
        if len(content) > MAX_UPLOAD_BYTES:
            raise ViewerError(f"{display}: {len(content)} bytes is too large for a .fis file")
        fd, tmp = tempfile.mkstemp(prefix="fuzzynav-upload-", suffix=".fis")
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(bytes(content))
            try:
                controller = make_controller(fis_path=tmp)
            except ModuleNotFoundError as exc:
                raise ViewerError(
                    f"{display}: .fis files cannot be loaded in this build ({exc.name} is missing)"
                ) from None
            except Exception as exc:
                text = str(exc).replace(tmp, display).replace(Path(tmp).name, display)
                raise ViewerError(f"{display} was refused: {text}") from None
        finally:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        label = UPLOADED_PREFIX + display
        self.uploaded_controller = controller
        self.uploaded_label = label
        self._install_controller(controller, label)
        return label

    @staticmethod
    def part_options():
        """fuzzynav's parts that can be switched off (name, what switching it off does)."""
        from fuzzynav.controller.fuzzynav_parts import load_parts

        return load_parts()

    def set_part(self, name: str, on: bool) -> None:
        """Switch one of fuzzynav's parts on or off; the robot drives on without a reset.
        The choice is kept for fuzzynav when another controller drives meanwhile."""
        known = [p.name for p in self.part_options()]
        if name not in known:
            raise ViewerError(f"fuzzynav has no part {name!r} (parts: {', '.join(known)})")
        with self.lock:
            off = set(self.parts_off) - {name} if on else set(self.parts_off) | {name}
            self.parts_off = tuple(n for n in known if n in off)
            inner = self.controller.inner
            if hasattr(inner, "set_parts_off"):
                inner.set_parts_off(self.parts_off)
                self._restart_if_finished_locked()
                self._note_change_locked()
                self._notice(f"fuzzynav: {name} {'on' if on else 'off'}.", "info")
            else:
                self._notice(
                    f"fuzzynav's {name} will be {'on' if on else 'off'} when fuzzynav drives.",
                    "info",
                )

    def set_geometry(self, geometry: str) -> None:
        """The Husky's footprint or the paper's point robot (inputs centre to centre);
        the run restarts, and the paper controller takes that geometry's rule base."""
        if geometry not in GEOMETRIES:
            raise ViewerError(f"geometry = {geometry!r}: choose one of {', '.join(GEOMETRIES)}")
        with self.lock:
            if geometry == self.geometry:
                return
            sim = self.sim
            mode = sim.perception.mode
            note = ""
            if geometry == "paper" and mode != "ideal":
                mode, note = "ideal", " (ideal perception: the point robot has no sonars)"
            self.geometry = geometry
            self.sim = Simulation(
                sim.scenario,
                self.controller,
                perception=mode,
                control_period_s=sim.control_period_s,
                seed=self.seed,
                sensor_config=sim.sensors.config,
                geometry=geometry,
            )
            if self.controller_label == "paper":
                self.controller.inner = self._make_named_controller("paper", geometry)
            self.paper_edit = None  # the editor edits this geometry's rule base
            self._reset_locked(self._layout_scenario())
            self._notice(f"Geometry: {geometry}{note}.", "info")

    def set_perception(self, mode: str) -> None:
        if mode not in PERCEPTION_MODES:
            raise ViewerError(f"perception = {mode!r}: choose one of {', '.join(PERCEPTION_MODES)}")
        if self.geometry == "paper" and mode != "ideal":
            raise ViewerError(
                "the paper's geometry is a point robot with exact inputs: ideal perception "
                "only (switch the geometry to husky for the sonars)"
            )
        with self.lock:
            self.sim.perception = Perception(mode, self.sim.sensors, geometry=self.geometry)
            self._restart_if_finished_locked()
            self._note_change_locked()
            self._bump()

    def set_disturbance(self, on: bool) -> None:
        with self.lock:
            self.disturbance_on = bool(on)
            self._apply_disturbance_locked()
            self._note_change_locked()
            self._bump()

    def disturbance_in_use(self) -> Disturbance:
        return self.sim.scenario.disturbance or DEFAULT_DISTURBANCE

    def _apply_disturbance_locked(self) -> None:
        self.sim.disturbance = self.disturbance_in_use() if self.disturbance_on else None

    def set_noise(self, std_m) -> None:
        """Sensor noise standard deviation (m); the sensors are rebuilt, the world kept."""
        std_m = self._check_noise(std_m)
        with self.lock:
            sim = self.sim
            config = SensorConfig(
                mounts=sim.sensors.config.mounts,
                beam_width_rad=sim.sensors.config.beam_width_rad,
                rays_per_beam=sim.sensors.config.rays_per_beam,
                min_range_m=sim.sensors.config.min_range_m,
                max_range_m=sim.sensors.config.max_range_m,
                noise_std_m=std_m,
                update_rate_hz=sim.sensors.config.update_rate_hz,
            )
            sensors = RangeSensorArray(config, seed=self.seed)
            sim.sensors = sensors
            sim.perception = Perception(sim.perception.mode, sensors, geometry=self.geometry)
            self.noise_std_m = std_m
            self._note_change_locked()
            self._bump()

    # -- reading -----------------------------------------------------------------------

    def snapshot(self) -> Snapshot:
        with self.lock:
            snap = self._live_snapshot_locked()
            snap.history_span = (
                (self._history[0].time_s, self._history[-1].time_s) if self._history else (0.0, 0.0)
            )
            k = self.history_index
            if k is None or k >= len(self._history):
                return snap
            h = self._history[k]
            limit = self.sim.voltage_limit_v
            snap.history = True
            snap.time_s = h.time_s
            snap.pose = h.pose
            snap.input_pose = h.input_pose
            snap.inputs = h.inputs.copy()
            snap.voltages_v = np.clip(h.output, -limit, limit)
            snap.target = h.target
            snap.obstacles = [
                ObstacleView(o.id, h.obstacles.get(o.id, o.xy), o.radius_m, o.is_static, o.velocity)
                for o in snap.obstacles
            ]
            snap.memory_xy, snap.steer_heading_rad = None, math.nan
            return snap

    def _live_snapshot_locked(self) -> Snapshot:
        with self.lock:  # (held already: an RLock)
            sim = self.sim
            arena = sim.arena
            t = arena.time_s
            obstacles = [
                ObstacleView(
                    o.id,
                    tuple(float(v) for v in o.position_at(t)),
                    o.radius_m,
                    o.is_static,
                    tuple(float(v) for v in o.velocity_at(t)),
                )
                for o in arena.obstacles.values()
            ]
            clearances = arena.clearances()
            memory_xy, steer = self._memory_view(arena.pose)
            return Snapshot(
                version=self.version,
                run_id=self.run_id,
                layout_id=self.layout_id,
                time_s=t,
                playing=self.playing,
                speed=self.speed,
                outcome=sim.outcome,
                pose=tuple(arena.pose),
                footprint_m=arena.footprint_m,
                target=tuple(float(v) for v in arena.target),
                tolerance_m=sim.scenario.tolerance_m,
                obstacles=obstacles,
                beams=sim.sensors.beam_geometry(arena.pose),
                ranges_m=np.array(sim.sensors.ranges_m, dtype=float),
                beam_width_rad=sim.sensors.config.beam_width_rad,
                max_range_m=sim.sensors.config.max_range_m,
                inputs=self.controller.last_inputs.copy(),
                voltages_v=np.clip(
                    self.controller.last_output, -sim.voltage_limit_v, sim.voltage_limit_v
                ),
                nearest_clearance_m=float(clearances.min()) if len(clearances) else math.inf,
                trail_length=len(self._trail),
                scenario_label=self.scenario_label,
                controller_label=self.controller_label,
                perception=sim.perception.mode,
                geometry=self.geometry,
                disturbance_on=self.disturbance_on,
                noise_std_m=self.noise_std_m,
                message=self.message,
                message_level=self.message_level,
                layout_edited=self.layout_edited,
                metrics=dict(self.metrics) if self.metrics else None,
                memory_xy=memory_xy,
                steer_heading_rad=steer,
                parts_off=self.parts_off,
                has_parts=hasattr(self.controller.inner, "set_parts_off"),
                ghost=self.ghost,
                ghost_id=self.ghost_id,
                run_label=self.run_label,
                disturbance_text=self.disturbance_text() if self.disturbance_on else "",
                inputs_disturbed=self._inputs_disturbed_locked(),
                obstacle_numbers={i: k + 1 for k, (i, _) in enumerate(self._layout)},
                what_if=None if self.what_if is None else self.what_if.copy(),
                input_pose=self._input_pose,
            )

    def _inputs_disturbed_locked(self) -> bool:
        d = self.sim.disturbance
        if d is None or not np.isfinite(self.controller.last_inputs[0]):
            return False
        t = self.sim.time_s - self.sim.control_period_s  # when the last inputs were read
        return d.start_s <= t < d.stop_s

    def trail_since(self, start: int) -> tuple[int, np.ndarray]:
        """(run id, trail points from index ``start`` on)."""
        with self.lock:
            return self.run_id, np.array(self._trail[start:], dtype=float).reshape(-1, 2)

    def signals(self) -> np.ndarray:
        """The last ``PLOT_WINDOW_S`` of (t, d_t, d_o, phi_t, phi_o, v_left, v_right)."""
        with self.lock:
            return self._signals.ordered()

    def _memory_view(self, pose):
        """(points (n, 2) in the world, steering heading) of a controller that shows its
        memory (``teaching_points``), placed from its own frame by the true pose; else
        (None, nan). Called under the lock."""
        view = getattr(self.controller.inner, "teaching_points", None)
        if view is None:
            return None, math.nan
        points, bearing = view()
        x, y, heading = pose
        c, s = math.cos(heading), math.sin(heading)
        world = np.column_stack(
            [x + c * points[:, 0] - s * points[:, 1], y + s * points[:, 0] + c * points[:, 1]]
        )
        return world, heading + bearing

    def fuzzy_system(self):
        """The controller's FuzzySystem, or None when it has none (``p``); for fuzzynav,
        its two blocks as one system."""
        inner = self.controller.inner
        fis = getattr(inner, "fis", None)
        if fis is None and hasattr(inner, "teaching_view"):
            fis = getattr(inner, "merged", None)
        return fis

    # -- classroom mode: a teacher's settings pushed to every tab's world -------------

    def settings(self) -> dict:
        """What a teacher pushes to the class (``--classroom``): the scenario with its
        layout as edited, the controller (by name, or its rule base when edited or
        uploaded), the perception, geometry, disturbance, noise, parts and speed."""
        with self.lock:
            inner = self.controller.inner
            fis = getattr(inner, "fis", None)
            named = self.controller_label in self.controller_options() and not (
                self.controller_label == EDITED_LABEL
                or self.controller_label == self.uploaded_label
            )
            return {
                "scenario_label": self.scenario_label,
                "scenario": self._layout_scenario(),
                "controller": self.controller_label,
                "fis": None if named else fis,
                "perception": self.sim.perception.mode,
                "geometry": self.geometry,
                "disturbance_on": self.disturbance_on,
                "noise_std_m": self.noise_std_m,
                "parts_off": self.parts_off,
                "speed": self.speed,
            }

    def apply_settings(self, settings: dict) -> None:
        """Take a teacher's :meth:`settings`: this world restarts in them, paused at t = 0."""
        from fuzzynav.controller.fis_controller import FisController

        self.pause()
        if settings["geometry"] != self.geometry:
            self.set_geometry(settings["geometry"])
        label = settings["scenario_label"]
        with self.lock:
            if label in scenario_names() and settings["scenario"] == load_scenario(label):
                self.uploaded_scenarios.pop(label, None)  # the shipped file as it is
            else:  # the teacher's layout (edited, or uploaded) under the teacher's name
                self.uploaded_scenarios[label] = settings["scenario"]
        self.load_scenario(label)
        for name in [p.name for p in self.part_options()]:
            if (name in settings["parts_off"]) != (name in self.parts_off):
                self.set_part(name, name not in settings["parts_off"])
        if settings["fis"] is not None:
            self.uploaded_controller = FisController(settings["fis"], name=settings["controller"])
            self.uploaded_label = settings["controller"]
            self._install_controller(self.uploaded_controller, settings["controller"])
        elif settings["controller"] != self.controller_label:
            self.set_controller(settings["controller"])
        if settings["perception"] != self.sim.perception.mode:
            self.set_perception(settings["perception"])
        self.set_disturbance(settings["disturbance_on"])
        self.set_noise(settings["noise_std_m"])
        self.set_speed(settings["speed"])
        self._notice("The teacher set this world up.", "info")

    # -- what-if mode ------------------------------------------------------------------

    def what_if_system(self):
        """The rule base what-if mode works on: a plain system over the four inputs
        (paper, an edited or uploaded one); None for fuzzynav (its blocks read sectors
        and a planned bearing) and for controllers without rules."""
        inner = self.controller.inner
        fis = getattr(inner, "fis", None)
        if fis is None or hasattr(inner, "teaching_view") or fis.n_inputs != 4:
            return None
        return fis

    def start_what_if(self) -> None:
        """Pause and try inputs by hand: the whole inference follows the inputs set
        with :meth:`set_what_if_input`; the robot does not move. :meth:`stop_what_if`
        (or Play, or Step) leaves it, and a run that was playing plays on."""
        with self.lock:
            if self.what_if_system() is None:
                raise ViewerError(
                    f"what-if mode needs a rule base over the four inputs (paper, an edited "
                    f"or uploaded .fis); {self.controller_label} has none"
                )
            if self.what_if is not None:
                return
            self.history_index = None
            self._resume_after_what_if = self.playing
            self.playing = False
            x = self.controller.last_inputs.copy()
            if not np.isfinite(x[0]):
                x = np.asarray(self.sim.sense()[0], dtype=float)
            self.what_if = x
            self._bump()

    def set_what_if_input(self, index: int, value) -> None:
        """Set input ``index`` (0-3: d_t, d_o, phi_t, phi_o) in what-if mode; NaN is
        "not sensed" (d_o, phi_o)."""
        with self.lock:
            if self.what_if is None:
                raise ViewerError("what-if mode is off: switch it on first")
            fis = self.what_if_system()
            if fis is None:
                raise ViewerError("this controller has no rule base over the four inputs")
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ViewerError(f"{value!r}: must be a number") from None
            name = fis.input_names[index]
            if math.isnan(value):
                if index in (0, 2):
                    raise ViewerError(f"{name} is always known: give a number")
            else:
                lo, hi = fis.inputs[index].range
                if not (math.isfinite(value) and lo <= value <= hi):
                    raise ViewerError(f"{name} = {value!r}: must be between {lo:g} and {hi:g}")
            self.what_if[index] = value
            self._bump()

    def stop_what_if(self) -> None:
        with self.lock:
            if self.what_if is None:
                return
            self.what_if = None
            resume = self._resume_after_what_if
            self._bump()
        if resume:
            self.play()

    def teaching(self) -> dict | None:
        """The rule base at the last controller inputs: firing strengths and aggregation.

        None when the controller has no fuzzy system or has not been called yet.
        """
        view = getattr(self.controller.inner, "teaching_view", None)
        state = None
        with self.lock:
            inputs = self.controller.last_inputs.copy()
            k = self.history_index
            if k is not None and k < len(self._history):
                step = self._history[k]
                inputs = step.inputs.copy()
                if view is not None:
                    if step.block is None:
                        return None
                    x, state = step.block
                    return self._teaching_of(self.fuzzy_system(), x, state)
            if view is not None:
                # a controller whose blocks see more than the four inputs (fuzzynav)
                seen = view()
                if seen is None:
                    return None
                fis, x, state = seen
        if view is None:
            fis = self.fuzzy_system()
            what_if = self.what_if
            if what_if is not None and fis is not None:
                inputs = what_if.copy()
            if fis is None or not np.isfinite(inputs[0]):
                return None
            x = inputs[: len(fis.input_names)]
        return self._teaching_of(fis, x, state)

    @staticmethod
    def _teaching_of(fis, x, state) -> dict:
        strengths = np.asarray(fis.firing_strengths(np.asarray([x])))[0]
        grid, membership, centroids = fis.aggregated(x)
        return {
            "inputs": x,
            "input_names": list(fis.input_names),
            "output_names": list(fis.output_names),
            "strengths": strengths,
            "grid": np.asarray(grid),
            "membership": np.asarray(membership),
            "centroids": np.asarray(centroids),
            "fis": fis,
            "state": state,
        }
