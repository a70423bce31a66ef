"""The Inference tab: MATLAB's rule viewer for the controller at the step shown (the
term plots, the rule table, the aggregated sets and centroids, from :mod:`.views`), the
rule-firing strip of the run, and what-if mode (inputs dragged or typed by hand)."""

from __future__ import annotations

import html
import math
import time

import numpy as np

from fuzzynav.app.viewer import views
from fuzzynav.app.viewer.compat_viser import handle_uuid
from fuzzynav.app.viewer.drawing import NONE_SENSED
from fuzzynav.app.viewer.model import Snapshot, ViewerError
from fuzzynav.app.viewer.status import set_html

WHAT_IF_INPUTS = ("d_t", "d_o", "phi_t", "phi_o")  # the what-if sliders, in this order
TIMELINE_PERIOD_S = 2.0  # the rule-firing strip is redrawn at most this often while playing


STEPWISE_HINT = (
    "Take the inference shown apart: fuzzification, the rules' AND, implication, "
    "aggregation, defuzzification, one stage at a time (the run pauses)"
)


class InferencePanel:
    """The Inference tab of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self._system_key = None
        self._system_count = 0
        self._uid = "fz0"
        self.last_inference = None
        self._ranges_for = None  # the rule base the what-if sliders' ranges are from
        self._timeline_key = None
        self._next_timeline = 0.0

    def build(self) -> None:
        gui = self.view.server.gui
        self.defs_html = gui.add_html("", order=0.0)
        self.firing_only_cb = gui.add_checkbox(
            "Firing rules only",
            False,
            hint="Show only the rules whose strength is above zero",
            order=0.5,
        )
        self.firing_only_cb.on_update(self.view.guarded(lambda e: self.redraw()))
        self._build_what_if()
        self._build_stepwise()
        self.stage_html = gui.add_html("", order=0.9)
        self.inference_html = gui.add_html("", order=1.0)
        # Under the inference (above it, it pushed the rule grid off screen).
        self.timeline_html = gui.add_html("", order=1.2)

    def _build_what_if(self) -> None:
        """What-if mode: pause, drag or type an input's value, and the whole inference (rules,
        clipped sets, aggregate, centroids, the surface's dot) follows; the robot stays."""
        gui = self.view.server.gui
        with gui.add_folder("What-if", expand_by_default=False, order=0.6):
            self.what_if_cb = gui.add_checkbox(
                "What-if mode",
                False,
                hint="Pause and try inputs by hand; untick to go on where the run was",
            )
            self.what_if_cb.on_update(self.view.guarded(self._on_what_if))
            self.what_if_boxes = []
            self._what_if_labels = []  # each box's own label (a "none sensed" is added)
            for k, (name, lo, hi, unit) in enumerate(
                (
                    ("d_t", 0.0, 20.0, "m"),
                    ("d_o", 0.0, 10.0, "m"),
                    ("phi_t", -math.pi, math.pi, "rad"),
                    ("phi_o", -math.pi, math.pi, "rad"),
                )
            ):
                # A slider per input: drag it (a real drag control) or type into its box.
                self._what_if_labels.append(f"{name} ({unit})")
                box = gui.add_slider(
                    self._what_if_labels[-1],
                    min=round(lo, 2),
                    max=round(hi, 2),
                    step=0.01,
                    initial_value=0.0,
                    disabled=True,
                    hint=f"drag, or type a value (d_o, phi_o: {NONE_SENSED} until you do)",
                )
                box.on_update(
                    self.view.guarded(lambda e, k=k: self.app.set_what_if_input(k, e.value))
                )
                self.what_if_boxes.append(box)

    def _build_stepwise(self) -> None:
        """One inference step by step: Next walks the moment shown through
        fuzzification, AND, implication, aggregation and defuzzification (the run
        pauses, so the moment stays); Back goes a stage back; Off leaves."""
        gui = self.view.server.gui
        self.stage = 0  # 0: off; 1..N_STAGES: the stage shown
        with gui.add_folder("Step by step", expand_by_default=False, order=0.7):
            self.stage_buttons = gui.add_button_group(
                "Inference", ("◀ Back", "Next ▶", "Off"), hint=STEPWISE_HINT
            )
            self.stage_buttons.on_click(self.view.guarded(self._on_stage))

    def _on_stage(self, event) -> None:
        from fuzzynav.app.viewer.stepwise import N_STAGES

        if event.value == "Off":
            self.stage = 0
        elif event.value == "Next ▶":
            if self.stage == 0:
                self.app.pause()  # the moment stays while it is taken apart
            self.stage = min(self.stage + 1, N_STAGES)
        else:
            self.stage = max(self.stage - 1, 0)
        self.redraw()

    def _on_what_if(self, event) -> None:
        if event.value:
            try:
                self.app.start_what_if()
            except ViewerError:
                self.what_if_cb.value = False
                raise
        else:
            self.app.stop_what_if()

    def redraw(self) -> None:
        self.last_inference = None
        self.app._bump()

    def _fit_what_if_ranges(self) -> None:
        """Each what-if slider spans its input's range in the rule base now driving (the
        one :meth:`ViewerApp.set_what_if_input` checks against), rounded inwards to the
        slider's 0.01 steps: a value the slider or its box offers is never refused
        (the d_t box once refused 50 as "between -1.13 and 30", its slider ran 0-20)."""
        fis = self.app.what_if_system()
        if fis is None or id(fis) == self._ranges_for:
            return
        self._ranges_for = id(fis)
        for box, var in zip(self.what_if_boxes, fis.inputs):
            lo, hi = (float(v) for v in var.range)
            lo, hi = math.ceil(lo * 100 - 1e-9) / 100, math.floor(hi * 100 + 1e-9) / 100
            if (box.min, box.max) != (lo, hi) and lo < hi:
                box.min, box.max = lo, hi
                if math.isfinite(box.value) and not lo <= box.value <= hi:
                    box.value = min(max(box.value, lo), hi)

    def sync(self, snap: Snapshot) -> None:
        """What-if mode's box and numbers as the world has them: the inputs tried, or
        (off, paused) the inputs of the moment shown, which What-if would start from. An
        input not sensed (d_o, phi_o: NaN) holds no number and its label says so, as the
        term plots do."""
        self._fit_what_if_ranges()
        on = snap.what_if is not None
        if self.what_if_cb.value != on:
            self.what_if_cb.value = on
        fis = self.app.what_if_system()
        if getattr(self, "_read_for", (None,))[0] != id(fis):
            read = self.app.inference.read_inputs(fis) if fis is not None else range(4)
            self._read_for = (id(fis), tuple(read))
        read = self._read_for[1]
        tried = snap.what_if if on else None if snap.playing else snap.inputs
        for k, box in enumerate(self.what_if_boxes):
            if box.visible != (k in read):  # only the inputs the driving system reads
                box.visible = k in read
            if box.disabled == on:
                box.disabled = not on
            if tried is None:
                continue
            sensed = math.isfinite(tried[k])
            label = self._what_if_labels[k] + ("" if sensed else f": {NONE_SENSED}")
            if box.label != label:
                box.label = label
            if not sensed:
                if not math.isnan(box.value):
                    box.value = math.nan  # (the page's box shows no number)
                continue
            shown = min(max(round(float(tried[k]), 2), box.min), box.max)
            if not abs(box.value - shown) <= 5e-3:
                box.value = shown

    def _system_uid(self, fis, labels, output_labels) -> str:
        """An id prefix for this system's SVG definitions (new when the system changes)."""
        key = id(fis)
        if key != self._system_key:
            self._system_key = key
            self._system_count += 1
            self._uid = f"fz{self._system_count}"
            self.defs_html.content = views.defs_html(fis, self._uid, labels, output_labels)
        return self._uid

    @staticmethod
    def _output_weights(info) -> dict | None:
        """fuzzynav's blocks: the weight its arbitration gives each output now (alpha to
        the avoidance block, 1 - alpha to the goal block); None for a plain system."""
        state = info.get("state") or {}
        try:
            alpha = float(state["avoidance weight alpha"])
        except (KeyError, TypeError, ValueError):
            return None
        return {
            name: (alpha if name.startswith("avoid") else 1.0 - alpha)
            for name in info["output_names"]
        }

    def draw_timeline(self, snap: Snapshot) -> None:
        """The rule-firing strip of this run, with a cursor at the time shown (the live
        end, or the time slider's step). Redrawn every TIMELINE_PERIOD_S while playing."""
        import base64

        now = time.perf_counter()
        key = (snap.run_id, snap.controller_label, round(snap.time_s, 2))
        if key == self._timeline_key or (snap.playing and now < self._next_timeline):
            return
        self._timeline_key = key
        self._next_timeline = now + TIMELINE_PERIOD_S
        line = self.app.firing_timeline()
        if line is None:
            set_html(self.timeline_html, "")
            return
        times, strengths = line
        png = base64.b64encode(views.timeline_png(times, strengths)).decode()
        t0, t1 = float(times[0]), float(times[-1])
        where = 100.0 * (snap.time_s - t0) / (t1 - t0) if t1 > t0 else 100.0
        n = int(np.asarray(strengths).shape[1]) if np.ndim(strengths) == 2 else 1
        # 4 px a rule (40 rules: 160 px), rule numbers at the left every 5 rules.
        height = max(60, 4 * n)
        ticks = "".join(
            f"<span style='position:absolute;right:2px;top:{100.0 * (k - 0.5) / n:.2f}%;"
            f"transform:translateY(-50%);line-height:1'>{k}</span>"
            for k in ([1] + list(range(5, n + 1, 5)) if n > 1 else [1])
        )
        set_html(
            self.timeline_html,
            "<div class='fz-timeline' style='font-family:system-ui,sans-serif;font-size:0.8em;"
            "padding:0 6px'><b>Rules over this run</b> (a row per rule, numbered at the left; "
            "orange: firing)<div style='display:flex;margin-top:2px'>"
            f"<div style='position:relative;width:20px;height:{height}px;font-size:0.85em;"
            f"color:#475569'>{ticks}</div><div style='position:relative;flex:1'>"
            f"<img class='fz-timeline-img' src='data:image/png;base64,{png}' "
            f"style='width:100%;height:{height}px;"
            "display:block;image-rendering:pixelated;border:1px solid #cbd5e1'/>"
            f"<div class='fz-timeline-cursor' style='position:absolute;top:0;bottom:0;"
            f"left:{min(max(where, 0.0), 100.0):.1f}%;width:2px;background:#0f172a'></div></div>"
            "</div><div style='display:flex;justify-content:space-between;color:#475569;"
            f"padding-left:20px'><span>{t0:.1f} s</span><span>{t1:.1f} s</span></div></div>",
        )

    def draw(self, snap: Snapshot) -> None:
        info = self.app.teaching()
        if info is None:
            set_html(self.stage_html, "")
            fis = self.app.fuzzy_system()
            if fis is None:
                text = (
                    f"The controller <b>{html.escape(snap.controller_label)}</b> has no "
                    "fuzzy rules to show. Choose a fuzzy controller (paper, fuzzynav) or "
                    "upload a .fis file."
                )
            else:
                text = "Press <b>Play</b> or <b>Step</b>: the rules that fire appear here."
            set_html(
                self.inference_html,
                f"<div style='font-size:0.9em;color:#475569;padding:0 6px'>{text}</div>",
            )
            return
        fis = info["fis"]
        only_firing = bool(self.firing_only_cb.value)
        what_if = snap.what_if is not None
        key = (
            id(fis),
            tuple(np.round(info["inputs"], 6)),
            self.view.presentation,
            only_firing,
            what_if,
            self.stage,
        )
        if key == self.last_inference:
            return
        self.last_inference = key
        labels = list(info["input_names"])
        notes = {}
        if info.get("state") is not None and "phi_t" in labels:
            # fuzzynav's goal block is fed the planner's bearing, not the target's.
            labels[labels.index("phi_t")] = "phi_plan"
            notes["phi_plan"] = (
                "the bearing fuzzynav's planner steers to, fed to its goal block "
                "(not the target bearing φ_t of the status line)"
            )
        drag = None
        if what_if:  # each input's plot drags its what-if slider (not fuzzynav's phi_plan)
            drag = {
                i: (handle_uuid(box), box.min, box.max)
                for i, name in enumerate(labels)
                if name in WHAT_IF_INPUTS
                for box in (self.what_if_boxes[WHAT_IF_INPUTS.index(name)],)
            }
        uid = self._system_uid(fis, labels, info["output_names"])
        inf = views.infer(fis, info["inputs"], labels, info["output_names"])
        if self.stage:
            from fuzzynav.app.viewer.stepwise import stage_html

            set_html(self.stage_html, stage_html(inf, self.stage))
        else:
            set_html(self.stage_html, "")
        set_html(
            self.inference_html,
            views.inference_html(
                inf,
                uid=uid,
                large=self.view.presentation,
                crisp=info["state"],
                only_firing=only_firing,
                weights=self._output_weights(info),
                notes=notes,
                drag=drag,
            ),
        )

    # -- control surfaces ---------------------------------------------------------------
