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
browser. :mod:`app.viewer_ui` builds the viser scene and GUI and calls those methods.
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
        self.paper_edit = None  # the membership editor (PaperEditor), built on first use

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
                from fuzzynav.app.recording import LiveRecorder

                k = len(self.recorded_files) + 1
                path = (
                    self.rrd_path
                    if k == 1
                    else self.rrd_path.with_name(
                        f"{self.rrd_path.stem}-run{k}{self.rrd_path.suffix or '.rrd'}"
                    )
                )
                self._recorder = LiveRecorder(path)
                self.recorded_files.append(path)
            self._recorder.update(self.sim)
        except Exception as exc:  # a full disk must not stop the simulation
            self._recorder = None
            self.rrd_path = None
            self._notice(f"Recording stopped: {exc}", "warning")

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
        if outcome is not None:
            self.playing = False
            self._finish_locked()
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
                self._notice(f"Note: {exc.key} {exc.reason}; {consequence}.", "warning")

    def _run_label(self) -> str:
        parts = [self.scenario_label, self.controller_label, self.sim.perception.mode]
        if self.parts_off and hasattr(self.controller.inner, "set_parts_off"):
            parts.append("without " + " and ".join(self.parts_off))
        return " · ".join(parts)

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
                label=self._run_label(),
                metrics=dict(self.metrics) if self.metrics else self._partial_metrics(),
            )
            self.ghost_id += 1
        # A new run: what was said about the last one (its outcome) no longer holds.
        self.message, self.message_level = "", "info"
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
        self.metrics = None
        self.run_label = self._run_label()
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
            self.base_scenario = scenario
            self.scenario_label = name
            self.disturbance_on = scenario.disturbance is not None
            self._reset_locked(scenario)
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
                text = f"The target {blocked[1]}: the robot cannot get there."
                self._target_warning = text
                self._notice(text, "warning")
                return text
            on_robot = self.obstacles_on_robot()
            if on_robot:
                text = (
                    f"Obstacle {', '.join(str(i) for i in on_robot)} is on the robot: "
                    "Play will end in a collision at once. Drag it off the robot."
                )
                self._target_warning = text
                self._notice(text, "warning")
                return text
            if self._target_warning is not None:
                self._target_warning = None
                self._notice("The target can be reached again.", "info")
            return None

    def obstacles_on_robot(self) -> list[int]:
        """Ids of the obstacles that overlap the robot's footprint where it stands."""
        with self.lock:
            arena = self.sim.arena
            clearances = arena.clearances()
            if self.geometry == "paper":  # the 25 cm are judged centre to centre there
                clearances = clearances + np.array(arena._scene().radii, dtype=float)
            ids = list(arena.obstacles)
            return [i for i, c in zip(ids, np.asarray(clearances).tolist()) if c <= 0.0]

    # -- the paper controller's membership editor ----------------------------------

    def editor(self):
        """The membership editor of the paper controller (built on first use)."""
        from fuzzynav.app.viewer_editor import PaperEditor

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
                raise ViewerError(f"obstacle {obstacle_id} does not exist (any more)")
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
                raise ViewerError(f"obstacle {obstacle_id} does not exist (any more)")
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
            self._restart_if_finished_locked()
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
            self._bump()

    def set_disturbance(self, on: bool) -> None:
        with self.lock:
            self.disturbance_on = bool(on)
            self._apply_disturbance_locked()
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
            self._bump()

    # -- reading -----------------------------------------------------------------------

    def snapshot(self) -> Snapshot:
        with self.lock:
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
            )

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

    def teaching(self) -> dict | None:
        """The rule base at the last controller inputs: firing strengths and aggregation.

        None when the controller has no fuzzy system or has not been called yet.
        """
        view = getattr(self.controller.inner, "teaching_view", None)
        state = None
        with self.lock:
            inputs = self.controller.last_inputs.copy()
            if view is not None:
                # a controller whose blocks see more than the four inputs (fuzzynav)
                seen = view()
                if seen is None:
                    return None
                fis, x, state = seen
        if view is None:
            fis = self.fuzzy_system()
            if fis is None or not np.isfinite(inputs[0]):
                return None
            x = inputs[: len(fis.input_names)]
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
