"""The scenario and the edits to it: the scenario list, loading and uploading, the
layout as dragged (target, obstacles added, moved and removed) and what it means for
the run (a blocked target, an obstacle on the robot), and the paper controller's
membership editor. A part of :class:`ViewerApp` (:mod:`.model`), whose state and lock
it shares."""

from __future__ import annotations

import dataclasses
import math
import re
import threading

import numpy as np

from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.app.viewer.budget import (
    ADDED_OBSTACLE_BYTES,
    MAX_KEPT_SCENARIOS,
    MAX_LAYOUT_OBSTACLES,
    scenario_charge,
)
from fuzzynav.app.viewer.state import (
    MAX_UPLOAD_BYTES,
    NEW_OBSTACLE_RADIUS_M,
    UPLOADED_PREFIX,
    ViewerError,
    safe_display_name,
)
from fuzzynav.world.geometry import rectangle_circles_clearance
from fuzzynav.world.scenario import (
    ObstacleSpec,
    Scenario,
    ScenarioError,
    load_scenario,
    loads_scenario,
    scenario_names,
    target_blocker,
)


class ScenarioEditing:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app
        self._build_lock = threading.Lock()  # the page's rule edits, built off its thread
        self._build_wanted = None  # (editor, action) of the last edit not built yet
        self._building = False

    def scenario_options(self) -> list[str]:
        app = self.app
        options = list(scenario_names())
        if app.scenario_label not in options:
            options.append(app.scenario_label)
        for name in app.uploaded_scenarios:
            if name not in options:
                options.append(name)
        return options

    def load_scenario(self, name: str) -> None:
        """Switch to a shipped scenario (by name) or one uploaded before; pauses at t = 0."""
        app = self.app
        if name in app.uploaded_scenarios:
            scenario = app.uploaded_scenarios[name]
        elif name == app.scenario_label:
            scenario = app.base_scenario
        elif name in scenario_names():
            try:
                scenario = load_scenario(name)
            except ScenarioError as exc:
                raise ViewerError(str(exc)) from None
        else:
            raise ViewerError(
                f"scenario {name!r}: unknown (choose from {', '.join(self.scenario_options())})"
            )
        with app.lock:
            app.playing = False
            other = name != app.scenario_label
            app.base_scenario = scenario
            app.scenario_label = name
            app.disturbance_on = scenario.disturbance is not None
            app.driver._reset_locked(scenario)
            if other:  # the last run's trail and numbers belong to another arena
                app.ghost = None
                app.ghost_id += 1
            app._notice(f"Loaded {scenario.name}.", "info")

    def upload_scenario(self, content: bytes, filename: str = "scenario.toml") -> str:
        """Validate an uploaded TOML scenario and switch to it; returns its label.

        A bad file raises :class:`ViewerError` naming the key and value; the running
        world is left as it was.
        """
        app = self.app
        label = UPLOADED_PREFIX + safe_display_name(filename, "scenario.toml")
        if len(content) > MAX_UPLOAD_BYTES:
            raise ViewerError(f"{label}: {len(content)} bytes is too large for a scenario file")
        try:  # bounded: nesting, numbers, counts (world/scenario.py)
            scenario = loads_scenario(
                bytes(content), source=label, footprint_m=app.sim.arena.footprint_m
            )
        except ScenarioError as exc:
            raise ViewerError(str(exc)) from None
        from fuzzynav.world.simulation import check_run_size

        try:  # the run's log within the memory budget, as `fuzzynav run` checks
            check_run_size(scenario.duration_s, app.sim.control_period_s, len(scenario.obstacles))
        except ValueError as exc:
            raise ViewerError(f"{label}: {exc}") from None
        self.keep_uploaded(label, scenario)
        self.load_scenario(label)
        return label

    def keep_uploaded(self, label: str, scenario: Scenario) -> None:
        """Keep an uploaded scenario for the dropdown: the last
        :data:`~.budget.MAX_KEPT_SCENARIOS`, the oldest dropped (never the one loaded),
        charged to the world's account (400 uploads kept 182 MB and 400 entries)."""
        app = self.app
        with app.lock:
            kept = dict(app.uploaded_scenarios)
            kept.pop(label, None)  # (the same name again: the newest now)
            kept[label] = scenario
            while len(kept) > MAX_KEPT_SCENARIOS:
                oldest = next(k for k in kept if k not in (app.scenario_label, label))
                del kept[oldest]
            charge = sum(scenario_charge(s) for s in kept.values())
            if not app.account.resize("scenarios", charge):
                raise ViewerError(f"{label}: not kept, the server's memory budget is spent")
            app.uploaded_scenarios = kept

    def forget_uploaded(self, label: str) -> None:
        app = self.app
        with app.lock:
            app.uploaded_scenarios.pop(label, None)
            charge = sum(scenario_charge(s) for s in app.uploaded_scenarios.values())
            app.account.resize("scenarios", charge)

    def charge_layout_locked(self) -> None:
        """What the layout's obstacles are charged, as it is now."""
        app = self.app
        app.account.resize("obstacles", ADDED_OBSTACLE_BYTES * len(app._layout), force=True)

    def restore_layout(self) -> None:
        """Undo every drag, addition and removal: the scenario as loaded, at t = 0."""
        app = self.app
        with app.lock:
            app.playing = False
            app.disturbance_on = app.base_scenario.disturbance is not None
            app.driver._reset_locked(app.base_scenario)

    def _layout_scenario(self) -> Scenario:
        """The scenario as edited: obstacles and target where the user put them."""
        app = self.app
        return app.base_scenario.replace(
            target=tuple(app._target), obstacles=tuple(spec for _, spec in app._layout)
        )

    @property
    def layout_edited(self) -> bool:
        app = self.app
        return self._layout_scenario() != app.base_scenario

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
        app = self.app
        with app.lock:
            for k, (i, _) in enumerate(app._layout):
                if i == obstacle_id:
                    return k + 1
        return obstacle_id + 1

    @staticmethod
    def plain_names(text: str) -> str:
        """``obstacles[k]`` (the scenario file's name) as the page says it: obstacle k+1
        (:func:`~fuzzynav.app.figures.style.obstacle_label`)."""
        # "static obstacle obstacles[1]" (the file's wording) reads "static obstacle 2",
        # not "static obstacle obstacle 2"
        return re.sub(
            r"(?:\bobstacle\s+)?obstacles\[(\d+)\]",
            lambda m: obstacle_label(int(m.group(1))),
            text,
        )

    def check_target(self) -> str | None:
        """After an edit (a drag ended, an obstacle added): tell the user when the target
        can no longer be reached, and when it can again. Returns the warning, if any."""
        app = self.app
        with app.lock:
            layout = self._layout_scenario()
            blocked = target_blocker(
                layout.target,
                layout.tolerance_m,
                layout.obstacles,
                0.5 * app.sim.arena.footprint_m[1],
            )
            if blocked is not None:
                text = self.plain_names(f"The target {blocked[1]}: the robot cannot get there.")
                app._target_warning = text
                app._notice(text, "warning")
                return text
            # A finished run restarts from the start on Play: judge the start, not where
            # the last run stopped (it may have stopped against that very obstacle).
            finished = app.sim.done
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
                app._target_warning = text
                app._notice(text, "warning")
                return text
            if app._target_warning is not None:
                app._target_warning = None
                app._notice("The target can be reached again.", "info")
            return None

    def obstacles_on_robot(self, at_start: bool = False) -> list[int]:
        """Ids of the obstacles that overlap the robot's footprint where it stands (or,
        ``at_start``, where the next run starts, with the obstacles of the layout).

        The gaps are :func:`world.geometry.rectangle_circles_clearance`'s, footprint to
        surface; the paper's geometry judges its 25 cm centre to centre, so there the
        obstacles count as points (radius 0)."""
        app = self.app
        with app.lock:
            arena = app.sim.arena
            if at_start:
                sc = app.sim.scenario
                robot_xy, heading = sc.start, sc.heading_rad
                ids = [i for i, _ in app._layout]
                centres = np.array([spec.position for _, spec in app._layout], dtype=float)
                radii = np.array([spec.radius_m for _, spec in app._layout], dtype=float)
            else:
                x, y, heading = arena.pose
                robot_xy = (x, y)
                centres, radii, ids = arena.obstacle_arrays()
            if not ids:
                return []
            if app.geometry == "paper":
                radii = np.zeros_like(radii)
            gaps = rectangle_circles_clearance(
                robot_xy, heading, *arena.footprint_m, centres.reshape(-1, 2), radii
            )
            return [i for i, gap in zip(ids, gaps.tolist()) if gap <= 0.0]

    def editor_kind(self) -> str:
        """Which system the Editor edits: ``starter`` while the starter (or its edit)
        drives, else ``paper`` (the paper controller, edited from whatever drives)."""
        from fuzzynav.app.viewer.starter import STARTER_EDITED_LABEL, STARTER_LABEL

        label = self.app.controller_label
        return "starter" if label in (STARTER_LABEL, STARTER_EDITED_LABEL) else "paper"

    def editor(self, kind: str | None = None):
        """The editor of the system that drives (:meth:`editor_kind`), or of ``kind``
        (built on first use)."""
        app = self.app
        from fuzzynav.app.viewer.editor import PaperEditor, StarterEditor

        with app.lock:
            kind = kind or self.editor_kind()
            if kind == "starter":
                if app.starter_edit is None:
                    app.starter_edit = StarterEditor(app.geometry)
                return app.starter_edit
            if app.paper_edit is None:
                app.paper_edit = PaperEditor(app.geometry)
            return app.paper_edit

    def _drive_edited(self, editor, controller, what: str) -> None:
        """Drive with ``editor``'s edited system at once and say so."""
        self.app.setup._install_controller(controller, editor.edited_label, quiet=True)
        self.app._notice(f"Controller: {editor.edited_label} ({what}).", "info")

    def set_membership_parameter(self, name: str, value) -> None:
        """Change one membership parameter of the system that drives (the starter's
        while it drives, else the paper controller's) and drive with the edited system at
        once (the run goes on)."""
        editor = self.editor()
        try:
            controller = editor.set(name, value)
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
        self._drive_edited(editor, controller, f"{name} = {editor.value(name):.2f}")

    def set_inference_choice(self, field: str, value: str) -> None:
        """Change one of the edited system's inference choices (AND, implication,
        aggregation, defuzzification) and drive with it at once."""
        editor = self.editor()
        try:
            controller = editor.set_choice(field, value)
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
        self._drive_edited(editor, controller, f"{field} {value}")

    def edit_rules(
        self, action: str, number: int | None = None, text: str = "", wait: bool = True
    ) -> None:
        """Change the rules of the system that drives: ``set`` rule ``number`` to
        ``text``, ``add`` ``text`` as a new rule, ``remove`` rule ``number``, ``undo`` the
        last rule edit; the robot drives with the edited system at once (``wait``), or as
        soon as a thread of its own has built it (the page's edits: an edit then costs
        the same at any size, and quick edits are built together)."""
        editor = self.editor()
        try:
            if action == "set":
                editor.set_rule(number, text, build=False)
            elif action == "add":
                editor.add_rule(text, build=False)
            elif action == "remove":
                editor.remove_rule(number, build=False)
            elif action == "undo":
                editor.undo_rule_edit(build=False)
            else:
                raise ValueError(f"rule edit {action!r}: set, add, remove or undo")
        except (TypeError, ValueError) as exc:
            raise ViewerError(str(exc)) from None
        if wait:
            self._drive_built(editor, action)
            return
        with self._build_lock:
            self._build_wanted = (editor, action)
            if self._building:
                return
            self._building = True
        threading.Thread(target=self._build_loop, name="fuzzynav-rules", daemon=True).start()

    def _drive_built(self, editor, action: str) -> None:
        try:
            controller = editor.build()
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
        n = len(controller.fis.rules)
        self._drive_edited(editor, controller, f"rule edit: {action}, {n} rules")

    def _build_loop(self) -> None:
        """Build the edited rules, off the world's lock, until no edit waits."""
        while True:
            with self._build_lock:
                wanted, self._build_wanted = self._build_wanted, None
                if wanted is None:
                    self._building = False
                    return
            try:
                self._drive_built(*wanted)
            except ViewerError as exc:
                self.app._notice(str(exc), "error")

    def reset_membership_editor(self) -> None:
        """Back to the shipped system the Editor edits (and its numbers)."""
        editor = self.editor()
        controller = editor.reset()
        self.app.setup._install_controller(controller, editor.label)

    def edited_fis_text(self) -> str:
        """The edited system as a MATLAB .fis file (text). ViewerError when its rules
        read NONE as the paper's text does, which a .fis cannot say (its TOML holds it)."""
        editor = self.editor()
        unsensed = editor.build().fis.unsensed_none
        if unsensed:
            raise ViewerError(
                f"Download .fis: {editor.label}'s rules read NONE for {', '.join(unsensed)} "
                "as 'sensed nothing' (the paper's text), which a .fis cannot say (MATLAB "
                "reads NONE as 'takes no part', and would drive otherwise): Download .toml "
                "saves the rule base whole"
            )
        return editor.fis_text()

    def move_target(self, xy) -> None:
        app = self.app
        x, y = self._check_xy(xy)
        with app.lock:
            app.sim.arena.move_target((x, y))
            app._target = (x, y)
            self._note_unreplayed_locked("the target moved")
            # A controller that doubts target readings which move the target (fuzzynav,
            # against disturbed inputs) is told that this move is meant.
            new_target = getattr(app.controller.inner, "new_target", None)
            if new_target is not None:
                new_target()
            app.driver._resense_locked()
            app._bump()

    def move_obstacle(self, obstacle_id: int, xy) -> None:
        """Put an obstacle at ``xy`` now; a moving one keeps its velocity from there."""
        app = self.app
        x, y = self._check_xy(xy)
        with app.lock:
            arena = app.sim.arena
            if obstacle_id not in arena.obstacles:
                raise ViewerError("that obstacle does not exist (any more)")
            before = arena.obstacles[obstacle_id].position_at(arena.time_s)
            arena.move_obstacle(obstacle_id, (x, y))
            self._note_unreplayed_locked(
                f"{obstacle_label(self.obstacle_number(obstacle_id) - 1)} moved", obstacle_id
            )
            # The layout (what a reset restarts from) shifts that obstacle's whole path.
            delta = np.array((x, y)) - before
            for k, (i, spec) in enumerate(app._layout):
                if i == obstacle_id:
                    moved = tuple(float(v) for v in np.asarray(spec.position) + delta)
                    app._layout[k] = (i, dataclasses.replace(spec, position=moved))
            app.driver._resense_locked()
            app._bump()

    def _note_unreplayed_locked(self, what: str, obstacle_id: int | None = None) -> None:
        """A change of the layout during a run: a lesson replays the run from the layout
        as it is now, so it cannot replay this one (it says so when opened); an obstacle
        put down keeps the time, to be named if the robot then hits it."""
        app = self.app
        if app.sim.time_s > 0.0:
            if not app._unreplayed or not app._unreplayed[-1].startswith(what):
                app._unreplayed.append(f"{what} at {app.sim.time_s:.2f} s")
            if obstacle_id is not None:
                app._drops[obstacle_id] = app.sim.time_s

    def suggest_obstacle_position(self) -> tuple[float, float]:
        """Where a new obstacle is most instructive: on the way from the robot to the target."""
        app = self.app
        with app.lock:
            x, y, heading = app.sim.arena.pose
            tx, ty = app.sim.arena.target
            centres, radii, _ = app.sim.arena.obstacle_arrays()
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
        app = self.app
        if xy is None:
            xy = self.suggest_obstacle_position()
        x, y = self._check_xy(xy)
        radius_m = float(radius_m)
        if not (math.isfinite(radius_m) and 0.02 <= radius_m <= 5.0):
            raise ViewerError(f"radius {radius_m!r} m: must be between 0.02 and 5 m")
        spec = ObstacleSpec((x, y), radius_m)
        with app.lock:
            self._check_room_locked()
            obstacle_id = app.sim.arena.add_obstacle(spec)
            self._note_unreplayed_locked("an obstacle added", obstacle_id)
            app._layout.append((obstacle_id, spec))
            self.charge_layout_locked()
            app.layout_id += 1
            app.driver._resense_locked()
            app._bump()
        self.check_target()
        return obstacle_id

    def _check_room_locked(self) -> None:
        """Refuse an Add past the cap: :data:`~.budget.MAX_LAYOUT_OBSTACLES`, the run's
        log within its budget (as an upload is checked), the server's memory budget
        (1,500 Adds took 464 MB, and after 3,000 a Pause took 43 s)."""
        app = self.app
        n = len(app._layout)
        if n >= MAX_LAYOUT_OBSTACLES:
            raise ViewerError(
                f"Obstacle: Add: the layout has {n} obstacles, and Add goes up to "
                f"{MAX_LAYOUT_OBSTACLES}; remove one first"
            )
        from fuzzynav.world.simulation import check_run_size

        try:
            check_run_size(app.sim.scenario.duration_s, app.sim.control_period_s, n + 1)
        except ValueError as exc:
            raise ViewerError(
                f"Obstacle: Add: {n + 1} obstacles are too many here: {exc}"
            ) from None
        if not app.account.resize("obstacles", ADDED_OBSTACLE_BYTES * (n + 1)):
            raise ViewerError("Obstacle: Add: the server's memory budget is spent")

    def remove_obstacle(self, obstacle_id: int | None = None) -> int:
        """Remove an obstacle (the newest when no id is given); returns its id."""
        app = self.app
        with app.lock:
            arena = app.sim.arena
            if obstacle_id is None:
                if not arena.obstacles:
                    raise ViewerError("there is no obstacle to remove")
                obstacle_id = max(arena.obstacles)
            if obstacle_id not in arena.obstacles:
                raise ViewerError("that obstacle does not exist (any more)")
            arena.remove_obstacle(obstacle_id)
            self._note_unreplayed_locked("an obstacle removed")
            app._layout = [(i, s) for i, s in app._layout if i != obstacle_id]
            self.charge_layout_locked()
            app.layout_id += 1
            app.driver._resense_locked()
            app._bump()
        self.check_target()
        return obstacle_id
