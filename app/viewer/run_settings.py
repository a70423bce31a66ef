"""What drives the run: the controller (by name, edited, uploaded as a .fis),
fuzzynav's parts, the geometry, the perception, the disturbance and the sensor noise;
and a teacher's settings pushed to a classroom tab's world. A part of
:class:`ViewerApp` (:mod:`.model`), whose state and lock it shares."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from fuzzynav.app.viewer.starter import STARTER_EDITED_LABEL, STARTER_LABEL
from fuzzynav.app.viewer.state import (
    DEFAULT_DISTURBANCE,
    EDITED_LABEL,
    MAX_UPLOAD_BYTES,
    UPLOADED_PREFIX,
    ViewerError,
    safe_display_name,
)
from fuzzynav.world.perception import GEOMETRIES, PERCEPTION_MODES, Perception
from fuzzynav.world.scenario import (
    Disturbance,
    load_scenario,
    scenario_names,
)
from fuzzynav.world.sensors import RangeSensorArray, SensorConfig
from fuzzynav.world.simulation import Simulation


class RunSettings:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app

    def controller_options(self) -> list[str]:
        app = self.app
        from fuzzynav.controller.registry import controller_names

        options = list(controller_names())
        options.append(STARTER_LABEL)  # a lesson's first system
        for editor in (app.paper_edit, app.starter_edit):
            if editor is not None and editor.edited:
                options.append(editor.edited_label)
        if app.uploaded_label:
            options.append(app.uploaded_label)
        return options

    def set_controller(self, name: str) -> None:
        """Swap the controller by name; the run goes on from where it is."""
        app = self.app
        from fuzzynav.app.viewer.starter import starter_controller

        if app.uploaded_label and name == app.uploaded_label:
            inner = app.uploaded_controller
        elif name == STARTER_LABEL:
            inner = starter_controller()
        elif name == EDITED_LABEL and app.paper_edit is not None:
            inner = app.paper_edit.controller()
        elif name == STARTER_EDITED_LABEL and app.starter_edit is not None:
            inner = app.starter_edit.controller()
        else:
            try:
                inner = app._make_named_controller(name, app.geometry)
            except ViewerError:
                raise
            except Exception as exc:
                raise ViewerError(f"controller {name!r} could not be built: {exc}") from None
        self._install_controller(inner, name)

    def set_controller_object(self, controller, label: str) -> None:
        """Drive with a ready-made controller object (tests, notebooks)."""
        self._install_controller(controller, label)

    def _install_controller(self, inner, label: str, quiet: bool = False) -> None:
        app = self.app
        with app.lock:
            inner.reset()
            if hasattr(inner, "set_parts_off"):
                inner.set_parts_off(app.parts_off)
            app.controller.inner = inner
            app.controller.name = label
            app.controller_label = label
            if app.what_if is not None and app.inference.what_if_system() is None:
                app.what_if = None  # nothing to try inputs on
            app.driver._restart_if_finished_locked()
            app.results._note_change_locked()
            if app.playing:
                self._answer_again_locked()
            else:
                app.driver._resense_locked()
            if not quiet:
                app._notice(f"Controller: {label}.", "info")
            else:
                app._bump()

    def _answer_again_locked(self) -> None:
        """What the panels show must be the controller now driving: a stateless one
        (a plain fuzzy system) is asked again at the last inputs; one with a memory
        (fuzzynav) would be disturbed by an extra call, so its answer is unknown
        until the next step."""
        app = self.app
        c = app.controller
        app._probe = None
        if not np.isfinite(c.last_inputs[0]):
            return
        inner = c.inner
        if getattr(inner, "fis", None) is not None and not hasattr(inner, "teaching_view"):
            c.last_output = np.asarray(inner(c.last_inputs), dtype=float).reshape(2)
        elif not app.playing:
            # Paused, any other controller (fuzzynav, with a memory; baseline; p) is
            # asked through a copy of itself: its answer and its inference are shown
            # and the controller that drives is not disturbed by the call.
            import copy

            try:
                probe = copy.deepcopy(inner)
                if getattr(probe, "needs_ranges", False):
                    out = probe(c.last_inputs.copy(), ranges_m=app.sim.sensors.ranges_m.copy())
                else:
                    out = probe(c.last_inputs.copy())
                c.last_output = np.asarray(out, dtype=float).reshape(2)
                if hasattr(probe, "teaching_view"):
                    app._probe = probe
            except Exception:
                c.last_output = np.full(2, np.nan)
        else:
            c.last_output = np.full(2, np.nan)

    def upload_fis(self, content: bytes, filename: str = "controller.fis") -> str:
        """Build a controller from an uploaded MATLAB ``.fis`` and drive with it.

        The bytes go to a private temporary file (the browser's file name is only
        shown, never opened). A file that cannot be used raises :class:`ViewerError`
        and the running controller and world are kept.
        """
        app = self.app
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
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        label = UPLOADED_PREFIX + display
        app.uploaded_controller = controller
        app.uploaded_label = label
        self._install_controller(controller, label)
        return label

    @staticmethod
    def part_options():
        """fuzzynav's parts that can be switched off (name, what switching it off does)."""
        from fuzzynav.controller.navigator.parts import load_parts

        return load_parts()

    def set_part(self, name: str, on: bool) -> None:
        """Switch one of fuzzynav's parts on or off; the robot drives on without a reset.
        The choice is kept for fuzzynav when another controller drives meanwhile."""
        app = self.app
        known = [p.name for p in self.part_options()]
        if name not in known:
            raise ViewerError(f"fuzzynav has no part {name!r} (parts: {', '.join(known)})")
        with app.lock:
            off = set(app.parts_off) - {name} if on else set(app.parts_off) | {name}
            app.parts_off = tuple(n for n in known if n in off)
            inner = app.controller.inner
            if hasattr(inner, "set_parts_off"):
                inner.set_parts_off(app.parts_off)
                app.driver._restart_if_finished_locked()
                app.results._note_change_locked()
                app._notice(f"fuzzynav: {name} {'on' if on else 'off'}.", "info")
            else:
                app._notice(
                    f"fuzzynav's {name} will be {'on' if on else 'off'} when fuzzynav drives.",
                    "info",
                )

    def set_geometry(self, geometry: str) -> None:
        """The Husky's footprint or the paper's point robot (inputs centre to centre);
        the run restarts, and the paper controller takes that geometry's rule base."""
        app = self.app
        if geometry not in GEOMETRIES:
            raise ViewerError(f"geometry = {geometry!r}: choose one of {', '.join(GEOMETRIES)}")
        with app.lock:
            if geometry == app.geometry:
                return
            sim = app.sim
            mode = sim.perception.mode
            note = ""
            if geometry == "paper" and mode != "ideal":
                mode, note = "ideal", " (ideal perception: the point robot has no sonars)"
            app.geometry = geometry
            app.sim = Simulation(
                sim.scenario,
                app.controller,
                perception=mode,
                control_period_s=sim.control_period_s,
                seed=app.seed,
                sensor_config=sim.sensors.config,
                geometry=geometry,
            )
            if app.controller_label == "paper":
                app.controller.inner = app._make_named_controller("paper", geometry)
            app.paper_edit = None  # the editor edits this geometry's rule base
            app.driver._reset_locked(app.editing._layout_scenario())
            app._notice(f"Geometry: {geometry}{note}.", "info")

    def set_perception(self, mode: str) -> None:
        app = self.app
        if mode not in PERCEPTION_MODES:
            raise ViewerError(f"perception = {mode!r}: choose one of {', '.join(PERCEPTION_MODES)}")
        if app.geometry == "paper" and mode != "ideal":
            raise ViewerError(
                "the paper's geometry is a point robot with exact inputs: ideal perception "
                "only (switch the geometry to husky for the sonars)"
            )
        with app.lock:
            app.sim.perception = Perception(
                mode,
                app.sim.sensors,
                geometry=app.geometry,
                field_of_view_rad=app.sim.scenario.field_of_view_rad,
            )
            app.driver._restart_if_finished_locked()
            app.results._note_change_locked()
            app.driver._resense_locked()
            app._bump()

    def set_disturbance(self, on: bool) -> None:
        app = self.app
        with app.lock:
            app.disturbance_on = bool(on)
            self._apply_disturbance_locked()
            app.results._note_change_locked()
            app.driver._resense_locked()
            app._bump()

    def disturbance_in_use(self) -> Disturbance:
        app = self.app
        return app.sim.scenario.disturbance or DEFAULT_DISTURBANCE

    def _apply_disturbance_locked(self) -> None:
        app = self.app
        app.sim.disturbance = self.disturbance_in_use() if app.disturbance_on else None

    def set_noise(self, std_m) -> None:
        """Sensor noise standard deviation (m); the sensors are rebuilt, the world kept."""
        app = self.app
        std_m = app._check_noise(std_m)
        with app.lock:
            sim = app.sim
            config = SensorConfig(
                mounts=sim.sensors.config.mounts,
                beam_width_rad=sim.sensors.config.beam_width_rad,
                rays_per_beam=sim.sensors.config.rays_per_beam,
                min_range_m=sim.sensors.config.min_range_m,
                max_range_m=sim.sensors.config.max_range_m,
                noise_std_m=std_m,
                update_rate_hz=sim.sensors.config.update_rate_hz,
            )
            sensors = RangeSensorArray(config, seed=app.seed)
            sim.sensors = sensors
            sim.perception = Perception(
                sim.perception.mode,
                sensors,
                geometry=app.geometry,
                field_of_view_rad=sim.scenario.field_of_view_rad,
            )
            app.noise_std_m = std_m
            app.results._note_change_locked()
            app.driver._resense_locked()
            app._bump()

    def settings(self) -> dict:
        """What a teacher pushes to the class (``--classroom``): the scenario with its
        layout as edited, the controller (by name, or its rule base when edited or
        uploaded), the Editor's edits (:func:`.lesson.editor_states`), the perception,
        geometry, disturbance, noise, parts and speed."""
        app = self.app
        from fuzzynav.app.viewer.lesson import editor_states

        with app.lock:
            inner = app.controller.inner
            fis = getattr(inner, "fis", None)
            edited = (EDITED_LABEL, STARTER_EDITED_LABEL, app.uploaded_label)
            named = (
                app.controller_label in self.controller_options()
                and app.controller_label not in edited
            )
            return {
                "scenario_label": app.scenario_label,
                "scenario": app.editing._layout_scenario(),
                "base_scenario": app.base_scenario,
                "controller": app.controller_label,
                "fis": None if named else fis,
                "editors": editor_states(app),
                "perception": app.sim.perception.mode,
                "geometry": app.geometry,
                "disturbance_on": app.disturbance_on,
                "noise_std_m": app.noise_std_m,
                "parts_off": app.parts_off,
                "speed": app.speed,
            }

    def apply_settings(self, settings: dict) -> None:
        """Take a teacher's :meth:`settings` (or a lesson's): this world restarts in them,
        paused at t = 0, its Editor holding editors of its own with exactly the edits of
        ``settings["editors"]`` (a system not among them afresh), as a lesson opened does."""
        app = self.app
        from fuzzynav.app.viewer.lesson import (
            apply_entry_locked,
            fresh_editors,
            install_editors_locked,
        )

        editors = fresh_editors(settings.get("editors") or {}, settings["geometry"])
        app.driver.pause()
        if settings["geometry"] != app.geometry:
            self.set_geometry(settings["geometry"])
        label = settings["scenario_label"]
        # The teacher's scenario as loaded, then the teacher's edits on it: the students'
        # status then says "layout edited" when the teacher's did, and their
        # Restore goes back to the scenario as loaded.
        base = settings.get("base_scenario", settings["scenario"])
        with app.lock:
            if label in scenario_names() and base == load_scenario(label):
                app.editing.forget_uploaded(label)  # the shipped file as it is
            else:  # the teacher's scenario (uploaded) under the teacher's name
                app.editing.keep_uploaded(label, base)
        app.editing.load_scenario(label)
        with app.lock:
            if settings["scenario"] != base:
                app.driver._reset_locked(settings["scenario"])
            install_editors_locked(app, editors)
            apply_entry_locked(app, settings)
        app.driver.set_speed(settings["speed"])
        app._notice("The teacher set this world up.", "info")
