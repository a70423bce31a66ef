"""The control panel (the right-hand panel): run buttons, speed, the time slider, the
scenario, the controller and sensing, fuzzynav's parts, the view options, the colour
key, with the status line, the message and the Result panel (:mod:`.status`) in their
places. Its widgets follow the world, whichever tab changed it (:meth:`ControlPanel.sync`).
"""

from __future__ import annotations

import html

import viser

from fuzzynav.app.viewer.lesson import MAX_NOTE_CHARS
from fuzzynav.app.viewer.model import NOISE_RANGE_M, Snapshot, ViewerError
from fuzzynav.world.perception import GEOMETRIES, PERCEPTION_MODES

SPEED_CHOICES = ("0.1", "0.25", "0.5", "1", "3", "10")
HISTORY_STEP_S = 0.02  # the time slider's step: one control period

COLOUR_KEY = [
    ("#dc2626", "beam: echo within 0.25 m (the safe distance)"),
    ("#f59e0b", "beam: echo at about 1 m"),
    ("#16a34a", "beam: echo at 3 m or more"),
    ("#afafaf", "beam: no echo (thin, full range)"),
    ("#2563eb", "trail of this run"),
    ("#94a3b8", "ghost: the previous run's trail"),
    ("#9333ea", "fuzzynav's echo memory (points it remembers)"),
    ("#16a34a", "fuzzynav's planned bearing (thick green line)"),
    ("#d97706", "safe-distance ring (red: an obstacle inside)"),
    ("#64748b", "ideal perception's field of view: obstacles outside it are not sensed"),
    ("#0d9488", "d_t (line to the target) and phi_t (arc from the heading)"),
    ("#c026d3", "d_o (from the footprint's edge) and phi_o (arc from the heading)"),
    ("#606f88", "static obstacle"),
    ("#ea580c", "moving obstacle"),
    ("#dc2626", "target (drag it)"),
]


def colour_key_html() -> str:
    rows = "".join(
        f"<div style='display:flex;align-items:center;gap:6px'><span style='display:inline-block;"
        f"width:22px;height:5px;border-radius:2px;background:{c}'></span>{html.escape(t)}</div>"
        for c, t in COLOUR_KEY
    )
    return f"<div class='fz-colour-key' style='font-size:0.8em;padding:0 6px'>{rows}</div>"


# The keyboard: space plays or pauses, the right arrow steps, R resets. viser
# offers no key events, and its HTML element sets innerHTML, where a <script> never
# runs: an image that cannot load runs its onerror once, which installs one listener on
# the page. A key presses the Run button of that name, so it travels as the button's own
# click (guarded, in order, like a mouse press). Not while typing in a box, nor with
# Ctrl, Alt or Meta (the browser's own shortcuts).
_KEYS_JS = (
    "if(!window.__fzKeys){window.__fzKeys=1;document.addEventListener('keydown',function(e){"
    "var t=e.target,g=(t&&t.tagName)||'';if(/^(INPUT|TEXTAREA|SELECT)$/.test(g)||"
    "(t&&t.isContentEditable)||e.ctrlKey||e.metaKey||e.altKey||e.repeat)return;var n=null;"
    "if(e.key===' '){var s=[].slice.call(document.querySelectorAll('.fz-status span'))"
    ".filter(function(x){return x.textContent.indexOf('\u25cf')===0;})[0];"
    "n=s&&s.textContent.indexOf('running')>=0?'Pause':'Play';}"
    "else if(e.key==='ArrowRight')n='Step';else if(e.key==='r'||e.key==='R')n='Reset';"
    "if(!n)return;var b=[].slice.call(document.querySelectorAll('button')).filter("
    "function(x){return x.textContent.trim()===n;})[0];if(!b)return;e.preventDefault();"
    "e.stopPropagation();b.click();},true);"
    # A slider's arrow keys move the slider only: viser's camera also takes the arrows
    # (and WASDQE) from the document, unless the target is an input box, and a slider's
    # thumb is not one; nudged from the keyboard, the arena turned to a tilted view.
    # Stopped at the body, after the slider (React, under it) has taken the key.
    "document.body.addEventListener('keydown',function(e){var t=e.target;"
    "if(t&&t.closest&&t.closest('[role=slider],.mantine-Slider-root')&&"
    "/^(Arrow|Key[WASDQE]$)/.test(e.code))e.stopPropagation();});}"
)
KEYS_HTML = (
    "<img class='fz-keys' alt='' src='data:,' style='display:none' onerror=\""
    + html.escape(_KEYS_JS, quote=True)
    + '">'
)


def safe_file_name(name: str) -> str:
    """A download's name: letters, digits, dot, dash and underscore only."""
    return "".join(c if c.isalnum() or c in "._-" else "-" for c in name)[:120]


class ControlPanel:
    """The right-hand panel of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self.app = view.app

    def build(self) -> None:
        gui = self.view.server.gui
        gui.configure_theme(
            dark_mode=False,
            show_logo=False,
            show_share_button=False,
            brand_color=(37, 99, 235),
            control_width="large",
        )
        gui.set_panel_label("fuzzynav · fuzzy Husky navigator")
        self._build_run_controls(gui)
        self._build_scenario_folder(gui)
        self._build_controller_folder(gui)
        self._build_lesson_and_view_folders(gui)
        with gui.add_folder("Colour key"):
            gui.add_html(colour_key_html())
        with gui.add_folder("Result"):
            self.view.status_line.add_result(gui)
        # presentation mode's type: nothing under 12 px at 1280 x 800 (a <style> block,
        # empty otherwise)
        self.presentation_css = gui.add_html("")

    def _build_run_controls(self, gui) -> None:
        """The status, Run and Speed buttons, the run's history and the drag hint."""
        app = self.app
        self.view.status_line.add_status(gui)
        self.run_buttons = gui.add_button_group("Run", ("Play", "Pause", "Step", "Reset"))
        self.run_buttons.on_click(self.view.guarded(self._on_run_button))
        # Speeds as choices: a linear slider gave 0.1-1x a tenth of its track.
        self.speed = gui.add_button_group("Speed ×", SPEED_CHOICES)
        self.speed.on_click(self.view.guarded(lambda e: app.set_speed(float(e.value))))
        # Back through the run: the scene, the inputs and the inference of any step.
        self.history_slider = gui.add_slider(
            "Run so far (s)",
            0.0,
            HISTORY_STEP_S,
            HISTORY_STEP_S,
            0.0,
            hint="Drag back through this run: the robot, its inputs and the rules as they "
            "were then (the run pauses; Live, Play or Step go back)",
        )
        self.history_slider.on_update(self.view.guarded(lambda e: app.view_history(e.value)))
        self.history_live = gui.add_button("Live", hint="Back to where the run is now")
        self.history_live.on_click(self.view.guarded(lambda e: app.leave_history()))
        self.view.status_line.add_message(gui)  # below the buttons: never moves them
        # Above the fold at 1280 x 800 (it was the last thing in the panel).
        gui.add_html(
            "<div class='fz-drag-hint' style='font-size:0.8em;color:#475569;padding:0 8px'>"
            "Drag the <b>target</b> or an <b>obstacle</b> by its body; the robot reacts at "
            "once. Scroll to zoom, right-drag to pan. Keys: <b>space</b> play / pause, "
            "<b>→</b> step, <b>R</b> reset.</div>" + KEYS_HTML
        )

    def _build_scenario_folder(self, gui) -> None:
        """Scenario: the choice, obstacles added or removed, the layout restored, an
        upload."""
        app = self.app
        with gui.add_folder("Scenario"):
            self.scenario_dd = gui.add_dropdown(
                "Scenario", app.scenario_options(), initial_value=app.scenario_label
            )
            self.scenario_dd.on_update(self.view.guarded(lambda e: app.load_scenario(e.value)))
            self.obstacle_buttons = gui.add_button_group("Obstacle", ("Add", "Remove newest"))
            self.obstacle_buttons.on_click(self.view.guarded(self._on_obstacle_button))
            self.restore = gui.add_button(
                "Restore scenario layout",
                icon=viser.Icon.RESTORE,
                hint="Undo drags, additions and removals",
            )
            self.restore.on_click(self.view.guarded(lambda e: app.restore_layout()))
            self.scenario_upload = gui.add_upload_button(
                "Upload scenario (.toml)", icon=viser.Icon.UPLOAD, mime_type=".toml"
            )
            self.scenario_upload.on_upload(self.view.guarded(self._on_scenario_upload))

    def _build_controller_folder(self, gui) -> None:
        """Controller and sensing: the controller (or a .fis upload), perception,
        geometry, disturbance, noise, and fuzzynav's parts."""
        app = self.app
        with gui.add_folder("Controller and sensing"):
            self.controller_dd = gui.add_dropdown(
                "Controller",
                app.controller_options(),
                initial_value=app.controller_label,
                hint=paper_rule_base_hint(app.geometry),
            )
            self.controller_dd.on_update(self.view.guarded(lambda e: app.set_controller(e.value)))
            self.fis_upload = gui.add_upload_button(
                "Upload a .fis controller", icon=viser.Icon.UPLOAD, mime_type=".fis"
            )
            self.fis_upload.on_upload(self.view.guarded(self._on_fis_upload))
            self.perception_dd = gui.add_dropdown(
                "Perception",
                PERCEPTION_MODES,
                initial_value=app.sim.perception.mode,
                hint="ideal: exact nearest obstacle; ultrasonic: the three beams",
            )
            self.perception_dd.on_update(self.view.guarded(lambda e: app.set_perception(e.value)))
            self.geometry_dd = gui.add_dropdown(
                "Geometry",
                GEOMETRIES,
                initial_value=app.geometry,
                hint="husky: the real 0.99 x 0.67 m footprint; paper: the paper's point robot, "
                "inputs and distances centre to centre (ideal perception)",
            )
            self.geometry_dd.on_update(self.view.guarded(lambda e: app.set_geometry(e.value)))
            self.disturbance_cb = gui.add_checkbox(
                "Disturbance",
                app.disturbance_on,
                hint="A sin(2t) added to every controller input (scenario 3: 25-35 s)",
            )
            self.disturbance_cb.on_update(self.view.guarded(lambda e: app.set_disturbance(e.value)))
            self.noise = gui.add_slider(
                "Sensor noise σ (m)", NOISE_RANGE_M[0], NOISE_RANGE_M[1], 0.01, app.noise_std_m
            )
            self.noise.on_update(self.view.guarded(self._on_noise))
            # What each part of fuzzynav does, shown by switching it off while it drives
            # (shown while fuzzynav drives; assets/rules/fuzzynav_parts.toml).
            self.parts_folder = gui.add_folder(
                "fuzzynav's parts (untick: off)",
                expand_by_default=False,
                visible=app.snapshot().has_parts,
            )
            self.part_boxes = {}
            with self.parts_folder:
                for part in app.part_options():
                    box = gui.add_checkbox(
                        part.name, part.name not in app.parts_off, hint=f"Off: {part.what}"
                    )
                    box.on_update(
                        self.view.guarded(lambda e, name=part.name: app.set_part(name, e.value))
                    )
                    self.part_boxes[part.name] = box

    def _build_lesson_and_view_folders(self, gui) -> None:
        """Lesson (save, open) and View (handles, 3D, presentation mode)."""
        with gui.add_folder("Lesson", expand_by_default=False):
            # A lesson saved and opened again: scenario, layout, controller
            # and its edits, settings, view and time, in one JSON file.
            self.lesson_save = gui.add_button(
                "Save lesson (.json)",
                icon=viser.Icon.DOWNLOAD,
                hint="The scenario and its layout, the controller and its edits, the "
                "settings, the view and the time, to open again (or fuzzynav serve --lesson)",
            )
            self.lesson_save.on_click(self.view.guarded(self._on_lesson_save))
            self.lesson_open = gui.add_upload_button(
                "Open lesson (.json)", icon=viser.Icon.UPLOAD, mime_type=".json"
            )
            self.lesson_open.on_upload(self.view.guarded(self._on_lesson_open))
            self.lesson_note = gui.add_text(
                "Teacher's note",
                "",
                hint="Saved with the lesson and shown to the class when it is opened "
                f"(at most {MAX_NOTE_CHARS} characters)",
            )
            self.lesson_note.on_update(self.view.guarded(lambda e: self.app.set_note(e.value)))
        with gui.add_folder("View", expand_by_default=False):
            self.handles_cb = gui.add_checkbox(
                "Show drag handles",
                self.view.show_handles,
                hint="Arrows on the target and the obstacles (they also drag by their body)",
            )
            self.handles_cb.on_update(self.view.guarded(self._on_handles))
            self.view_3d_cb = gui.add_checkbox(
                "3D view (tilt with the mouse)",
                self.view.view_3d,
                hint="Off: the camera stays straight above the arena",
            )
            self.view_3d_cb.on_update(self.view.guarded(self._on_view_3d))
            self.presentation_cb = gui.add_checkbox(
                "Presentation mode (large type)",
                self.view.presentation,
                hint="A wide inference panel and large type, for a projector",
            )
            self.presentation_cb.on_update(self.view.guarded(self._on_presentation))

    def sync(self, snap: Snapshot) -> None:
        """Show in every tab what the world is (another tab may have changed it)."""
        app = self.app
        options = tuple(app.scenario_options())
        if tuple(self.scenario_dd.options) != options:
            self.scenario_dd.options = options
        if self.scenario_dd.value != snap.scenario_label:
            self.scenario_dd.value = snap.scenario_label
        options = tuple(app.controller_options())
        if tuple(self.controller_dd.options) != options:
            self.controller_dd.options = options
        if self.controller_dd.value != snap.controller_label and snap.controller_label in options:
            self.controller_dd.value = snap.controller_label
        if self.lesson_note.value != self.app.note:
            self.lesson_note.value = self.app.note
        if self.perception_dd.value != snap.perception:
            self.perception_dd.value = snap.perception
        if self.geometry_dd.value != snap.geometry:
            self.geometry_dd.value = snap.geometry
        if self.disturbance_cb.value != snap.disturbance_on:
            self.disturbance_cb.value = snap.disturbance_on
        if abs(self.noise.value - snap.noise_std_m) > 1e-9:
            self.noise.value = snap.noise_std_m
        if self.parts_folder.visible != snap.has_parts:
            self.parts_folder.visible = snap.has_parts
        for name, box in self.part_boxes.items():
            if box.value != (name not in snap.parts_off):
                box.value = name not in snap.parts_off
        top = max(round(snap.history_span[1], 2), HISTORY_STEP_S)
        if abs(self.history_slider.max - top) > 1e-9:
            self.history_slider.max = top
        shown = min(round(snap.time_s, 2), top)
        if abs(self.history_slider.value - shown) > 0.5 * HISTORY_STEP_S:
            self.history_slider.value = shown
        if self.history_live.disabled == snap.history:
            self.history_live.disabled = not snap.history

    def _on_noise(self, event) -> None:
        try:
            self.app.set_noise(event.value)
        except ViewerError:
            self.noise.value = self.app.noise_std_m  # never leave the box blank or wrong
            raise

    def _on_handles(self, event) -> None:
        self.view.show_handles = bool(event.value)
        self.view.handles.show(self.view.show_handles)

    def _on_view_3d(self, event) -> None:
        self.view.view_3d = bool(event.value)
        if not self.view.view_3d:
            self.view.camera.fit_all()

    def _on_presentation(self, event) -> None:
        self.view.set_presentation(bool(event.value))

    def _on_run_button(self, event) -> None:
        choice = event.value
        {
            "Play": self.app.play,
            "Pause": self.app.pause,
            "Step": self.app.step_once,
            "Reset": self.app.reset,
        }[choice]()

    def _on_obstacle_button(self, event) -> None:
        if event.value == "Add":
            self.app.add_obstacle()
        else:
            self.app.remove_obstacle()

    def _on_fis_upload(self, event) -> None:
        uploaded = event.value
        label = self.app.upload_fis(uploaded.content, uploaded.name)
        self.controller_dd.options = self.app.controller_options()
        self.controller_dd.value = label
        self.view.tell(event.client, f"Driving with {label}.", "success")

    def _on_lesson_save(self, event) -> None:
        if event.client is None:
            return
        text = self.app.lesson_text(self.view.current_view())
        name = f"fuzzynav-lesson-{self.app.scenario_label}-t{self.app.sim.time_s:.0f}s.json"
        event.client.send_file_download(
            safe_file_name(name), text.encode("utf-8"), save_immediately=True
        )

    def _on_lesson_open(self, event) -> None:
        uploaded = event.value
        view = self.app.open_lesson(uploaded.content, uploaded.name, background=True)
        self.scenario_dd.options = self.app.scenario_options()
        self.controller_dd.options = self.app.controller_options()
        self.view.apply_view(view)

    def _on_scenario_upload(self, event) -> None:
        uploaded = event.value
        label = self.app.upload_scenario(uploaded.content, uploaded.name)
        self.scenario_dd.options = self.app.scenario_options()
        self.scenario_dd.value = label


def paper_rule_base_hint(geometry: str) -> str:
    """Which rule base ``paper`` drives in this world: the paper's controller
    in its own geometry, its twin fitted for the Husky's body in the Husky's."""
    from fuzzynav.controller.paper import RULE_BASE_NAMES, RULES_BY_GEOMETRY

    return (
        f"paper: {RULE_BASE_NAMES[geometry]} (rules/{RULES_BY_GEOMETRY[geometry].name}); "
        "the others as --controller describes them"
    )
