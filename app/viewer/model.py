"""The interactive browser viewer's app model: the world, the run, what every press does.

``fuzzynav serve [SCENARIO]`` (and ``fuzzynav demo``, which is ``serve s1``) starts a viser
server on 127.0.0.1 and prints its URL; what the page shows and does is docs/viewer.md.

:class:`ViewerApp` (this module) owns the simulation and its thread and has a
method for every user action; it knows nothing about viser and is tested without a
browser. It holds the state and the lock; its parts do the work, one job each:
:mod:`.driver` (the run and its thread), :mod:`.history` (the run's history and
results), :mod:`.editing` (the scenario and its edits), :mod:`.run_settings` (what
drives), :mod:`.teaching` (the inference shown, what-if mode), :mod:`.reading` (the
snapshot); :mod:`.state` holds the records they share. :mod:`app.viewer.server` builds the viser scene and GUI and calls those methods.
Every tab sees the same world; closing a tab does not stop the simulation; Ctrl-C stops
the server and frees its port. Nothing the browser sends is ever used as a path: uploads
are read from memory (a ``.fis`` goes through a private temporary file).
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from pathlib import Path

import numpy as np

from fuzzynav.app.viewer.budget import MemoryBudget
from fuzzynav.app.viewer.driver import RunDriver
from fuzzynav.app.viewer.editing import ScenarioEditing
from fuzzynav.app.viewer.history import RunHistory, StepHistory
from fuzzynav.app.viewer.reading import Reading
from fuzzynav.app.viewer.run_settings import RunSettings
from fuzzynav.app.viewer.state import (
    MAX_UPLOAD_BYTES,
    NEW_OBSTACLE_RADIUS_M,
    NOISE_RANGE_M,
    SAFE_DISTANCE_M,
    UPLOADED_PREFIX,
    Ghost,
    Snapshot,
    ViewerError,
    _ObservedController,
    safe_display_name,
)
from fuzzynav.app.viewer.teaching import Teaching
from fuzzynav.world.perception import GEOMETRIES, PERCEPTION_MODES
from fuzzynav.world.scenario import Disturbance, Scenario, load_scenario, scenario_names
from fuzzynav.world.sensors import SensorConfig
from fuzzynav.world.simulation import Simulation

# The records and limits live in .state; they are offered here too (callers import
# them from the model).
__all__ = [
    "MAX_UPLOAD_BYTES",
    "NOISE_RANGE_M",
    "SAFE_DISTANCE_M",
    "UPLOADED_PREFIX",
    "Snapshot",
    "ViewerApp",
    "ViewerError",
    "safe_display_name",
]


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
        runs (after a reset) to ``<stem>-run2.rrd``, ``<stem>-run3.rrd``... (the first
        free number; every run while another viewer holds the path). Each file is
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
        # what this world's tabs make the server keep, in the server's budget (one of
        # its own until a server attaches it to the server's: attach_budget)
        self.budget = MemoryBudget()
        self.account = self.budget.account()
        self.driver = RunDriver(self)
        self.results = RunHistory(self)
        self.editing = ScenarioEditing(self)
        self.setup = RunSettings(self)
        self.inference = Teaching(self)
        self.reading = Reading(self)
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
        self.paper_edit = None  # the paper's editor (PaperEditor), built on first use
        self.starter_edit = None  # the starter's editor (StarterEditor), likewise
        self.note = ""  # the teacher's note, saved with a lesson
        # paused: a copy of a controller with a memory, asked at the inputs read now
        # (its answer and inference shown; the driving controller is not called)
        self._probe = None
        self.what_if: np.ndarray | None = None  # what-if mode: the inputs tried
        self.history_index: int | None = None  # the time slider's step, or None (live)
        self._history = StepHistory(self.account)
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
        self.controller = _ObservedController(inner, self.driver._on_controller_call, controller)
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
        with self.lock:
            self.driver._reset_locked(scenario_obj)

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

    def attach_budget(self, budget: MemoryBudget) -> None:
        """Count this world in ``budget`` (its server's, shared by a classroom's tabs):
        what it holds now moves there."""
        with self.lock:
            if budget is self.budget:
                return
            old, self.account = self.account, budget.account()
            for kind in ("history", "scenarios", "obstacles"):
                self.account.resize(kind, old.held(kind))
            old.close()
            self.budget = budget
            self._history.account = self.account

    # -- notification ------------------------------------------------------------------

    def _bump(self) -> None:
        with self.lock:
            self.version += 1
            self._changed.notify_all()

    def _notice(self, text: str, level: str = "info") -> None:
        with self.lock:
            self.message, self.message_level = text, level
            # said while trying inputs or looking back: it goes when that mode ends
            self._message_mode = (
                "what-if"
                if self.what_if is not None
                else "history"
                if self.history_index is not None
                else None
            )
            self._bump()
        for listener in list(self._listeners):
            with contextlib.suppress(Exception):
                listener(text, level)

    def _end_mode_message_locked(self, mode: str) -> None:
        """What-if mode or the time slider's past ended: a warning or an error said in
        it (a refused value) goes with it."""
        if (
            self.message
            and getattr(self, "_message_mode", None) == mode
            and self.message_level in ("error", "warning")
        ):
            self.message, self.message_level = "", "info"
            self._message_mode = None

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

    # -- what the parts do: one method per user action, done by a part -----------------

    # -- RunDriver (:mod:`.driver`) ----------------------------------------------------

    def start(self) -> ViewerApp:
        return self.driver.start()

    def stop(self) -> None:
        return self.driver.stop()

    def add_input_watcher(self, func) -> None:
        return self.driver.add_input_watcher(func)

    def play(self) -> None:
        return self.driver.play()

    def pause(self) -> None:
        return self.driver.pause()

    def step_once(self) -> None:
        return self.driver.step_once()

    def reset(self) -> None:
        return self.driver.reset()

    def set_speed(self, factor) -> None:
        return self.driver.set_speed(factor)

    # -- RunHistory (:mod:`.history`) --------------------------------------------------

    def history_times(self) -> tuple[float, float]:
        return self.results.history_times()

    def view_history(self, time_s) -> float | None:
        return self.results.view_history(time_s)

    def firing_timeline(self):
        return self.results.firing_timeline()

    def leave_history(self) -> None:
        return self.results.leave_history()

    def disturbance_text(self) -> str:
        return self.results.disturbance_text()

    # -- ScenarioEditing (:mod:`.editing`) ---------------------------------------------

    def scenario_options(self) -> list[str]:
        return self.editing.scenario_options()

    def load_scenario(self, name: str) -> None:
        return self.editing.load_scenario(name)

    def upload_scenario(self, content: bytes, filename: str = "scenario.toml") -> str:
        return self.editing.upload_scenario(content, filename)

    def restore_layout(self) -> None:
        return self.editing.restore_layout()

    @property
    def layout_edited(self) -> bool:
        return self.editing.layout_edited

    def obstacle_number(self, obstacle_id: int) -> int:
        return self.editing.obstacle_number(obstacle_id)

    def plain_names(self, text: str) -> str:
        return self.editing.plain_names(text)

    def check_target(self) -> str | None:
        return self.editing.check_target()

    def obstacles_on_robot(self, at_start: bool = False) -> list[int]:
        return self.editing.obstacles_on_robot(at_start)

    def editor(self, kind: str | None = None):
        return self.editing.editor(kind)

    def editor_kind(self) -> str:
        return self.editing.editor_kind()

    def set_membership_parameter(self, name: str, value) -> None:
        return self.editing.set_membership_parameter(name, value)

    def set_inference_choice(self, field: str, value: str) -> None:
        return self.editing.set_inference_choice(field, value)

    def edit_rules(
        self, action: str, number: int | None = None, text: str = "", wait: bool = True
    ) -> None:
        return self.editing.edit_rules(action, number, text, wait)

    def reset_membership_editor(self) -> None:
        return self.editing.reset_membership_editor()

    def edited_fis_text(self) -> str:
        return self.editing.edited_fis_text()

    def move_target(self, xy) -> None:
        return self.editing.move_target(xy)

    def move_obstacle(self, obstacle_id: int, xy) -> None:
        return self.editing.move_obstacle(obstacle_id, xy)

    def add_obstacle(self, xy=None, radius_m: float = NEW_OBSTACLE_RADIUS_M) -> int:
        return self.editing.add_obstacle(xy, radius_m)

    def remove_obstacle(self, obstacle_id: int | None = None) -> int:
        return self.editing.remove_obstacle(obstacle_id)

    # -- RunSettings (:mod:`.run_settings`) --------------------------------------------

    def controller_options(self) -> list[str]:
        return self.setup.controller_options()

    def set_controller(self, name: str) -> None:
        return self.setup.set_controller(name)

    def set_controller_object(self, controller, label: str) -> None:
        return self.setup.set_controller_object(controller, label)

    def upload_fis(self, content: bytes, filename: str = "controller.fis") -> str:
        return self.setup.upload_fis(content, filename)

    def part_options(self):
        return self.setup.part_options()

    def set_part(self, name: str, on: bool) -> None:
        return self.setup.set_part(name, on)

    def set_geometry(self, geometry: str) -> None:
        return self.setup.set_geometry(geometry)

    def set_perception(self, mode: str) -> None:
        return self.setup.set_perception(mode)

    def set_disturbance(self, on: bool) -> None:
        return self.setup.set_disturbance(on)

    def disturbance_in_use(self) -> Disturbance:
        return self.setup.disturbance_in_use()

    def set_noise(self, std_m) -> None:
        return self.setup.set_noise(std_m)

    def settings(self) -> dict:
        return self.setup.settings()

    def apply_settings(self, settings: dict) -> None:
        return self.setup.apply_settings(settings)

    # -- Teaching (:mod:`.teaching`) ---------------------------------------------------

    def fuzzy_system(self):
        return self.inference.fuzzy_system()

    def what_if_system(self):
        return self.inference.what_if_system()

    def start_what_if(self) -> None:
        return self.inference.start_what_if()

    def set_what_if_input(self, index: int, value) -> None:
        return self.inference.set_what_if_input(index, value)

    def stop_what_if(self) -> None:
        return self.inference.stop_what_if()

    def teaching(self) -> dict | None:
        return self.inference.teaching()

    # -- Lessons (:mod:`.lesson`) ------------------------------------------------------

    def lesson_text(self, view: dict | None = None) -> str:
        """This world as a lesson file (JSON): scenario, layout, controller, settings,
        ``view`` and time."""
        from fuzzynav.app.viewer.lesson import dumps_lesson

        return dumps_lesson(self, view)

    def set_note(self, text) -> None:
        """The teacher's note, saved with the lesson and shown when it is opened."""
        from fuzzynav.app.viewer.lesson import MAX_NOTE_CHARS

        text = str(text)
        if len(text) > MAX_NOTE_CHARS:
            raise ViewerError(f"Teacher's note: {len(text)} characters, at most {MAX_NOTE_CHARS}")
        with self.lock:
            self.note = text
            self._bump()

    def open_lesson(self, content, source: str = "lesson.json", background: bool = False) -> dict:
        """Open a lesson file's content; returns its view (presentation, firing only).
        With ``background`` its run is replayed on a thread of its own."""
        from fuzzynav.app.viewer.lesson import open_lesson

        return open_lesson(self, content, source, background)

    # -- Reading (:mod:`.reading`) -----------------------------------------------------

    def snapshot(self) -> Snapshot:
        return self.reading.snapshot()

    def trail_since(self, start: int) -> tuple[int, np.ndarray]:
        return self.reading.trail_since(start)

    def signals(self) -> np.ndarray:
        return self.reading.signals()
