"""The status line (time, state, the run's settings, the controller's inputs and
voltages), the message below the run buttons, and the Result panel (the run's metrics
beside the previous run's and the paper's Table 4)."""

from __future__ import annotations

import html
import math

from fuzzynav.app.published import published_table4
from fuzzynav.app.viewer.model import Snapshot


def _fmt(value, unit: str = "", digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return f"{value:.{digits}f}{(' ' + unit) if unit else ''}"
    return str(value)


def set_html(element, content: str) -> None:
    """Send an HTML element only when its text changes."""
    if element.content != content:
        element.content = content


class StatusLine:
    """The status line, the message and the Result panel of one
    :class:`app.viewer.server.ViewerServer` (the control panel places them)."""

    RESULT_PENDING = (
        "<div style='color:#64748b;font-size:0.85em'>The outcome and the "
        "paper's Table 4 metrics appear here when a run ends.</div>"
    )

    def __init__(self, view):
        self.view = view
        self.last_metrics_run = -1

    def add_status(self, gui) -> None:
        self.status = gui.add_html(self._status_html(self.view.app.snapshot()))

    def add_message(self, gui) -> None:
        # Messages below the buttons, so that one appearing never moves them.
        self.message_html = gui.add_html("")

    def add_result(self, gui) -> None:
        self.result = gui.add_html(self.RESULT_PENDING)

    def draw(self, snap: Snapshot) -> None:
        set_html(self.status, self._status_html(snap))
        set_html(self.message_html, self._message_html(snap))

    def draw_result(self, snap: Snapshot) -> None:
        key = (snap.run_id, snap.metrics is not None, snap.ghost_id)
        if self.last_metrics_run != key:
            self.last_metrics_run = key
            self.result.content = self._metrics_html(snap)

    @staticmethod
    def _message_html(snap: Snapshot) -> str:
        if not snap.message:
            return ""
        colour = {"error": "#b91c1c", "warning": "#b45309", "success": "#15803d"}.get(
            snap.message_level, "#334155"
        )
        return (
            f"<div class='fz-message' style='margin:0 6px;padding:4px 6px;border-radius:4px;"
            f"background:{colour}14;color:{colour};font-size:0.85em'>"
            f"{html.escape(snap.message)}</div>"
        )

    def _status_html(self, snap: Snapshot) -> str:
        state = (
            "what-if (paused)"
            if snap.what_if is not None
            else "looking back (paused)"
            if snap.history
            else "running"
            if snap.playing
            else {
                "reached": "reached the target",
                "collided": "collided",
                "timeout": "timed out",
            }.get(snap.outcome, "paused")
        )
        colour = {
            "running": "#16a34a",
            "reached the target": "#16a34a",
            "collided": "#dc2626",
            "timed out": "#d97706",
        }.get(state, "#64748b")
        d_t, d_o, phi_t, phi_o = snap.inputs
        v_l, v_r = snap.voltages_v
        # A disturbed input is marked (the disturbance is added to every input).
        mark = (
            "<sup title='includes the disturbance' style='color:#b45309'>~</sup>"
            if snap.inputs_disturbed
            else ""
        )
        extras = ""
        if snap.disturbance_text:
            extras += f" · <span style='color:#b45309'>{html.escape(snap.disturbance_text)}</span>"
        if snap.noise_std_m > 0:
            extras += f" · noise σ {snap.noise_std_m:.2f} m"
        if snap.layout_edited:
            extras += " · layout edited"
        big = self.view.presentation
        return (
            # The time and the state wrap onto two lines where one is too narrow
            # ("looking back (paused" was cut at the panel's edge), and keep clear of
            # the panel's scrollbar.
            "<div class='fz-status' style='font-family:system-ui,sans-serif;line-height:1.35;"
            f"padding:0 14px 0 8px;font-size:{'1.3em' if big else '1em'}'>"
            "<div style='display:flex;flex-wrap:wrap;column-gap:10px;"
            "justify-content:space-between;align-items:baseline'>"
            f"<span class='fz-time' style='font-size:1.6em;font-weight:600;"
            "font-variant-numeric:tabular-nums;white-space:nowrap'>"
            f"t = {snap.time_s:.2f} s</span>"
            f"<span class='fz-state' style='font-weight:600;color:{colour};white-space:nowrap'>"
            f"● {state}</span></div>"
            f"<div style='font-size:0.85em;color:#475569'>{html.escape(snap.scenario_label)} · "
            f"{html.escape(snap.controller_label)}{self._rule_base_note(snap)}"
            f"{self._parts_note(snap)} · {snap.perception}"
            f" · ×{snap.speed:g}{extras}</div>"
            "<table style='width:100%;font-size:0.85em;margin-top:4px;"
            "font-variant-numeric:tabular-nums;white-space:nowrap'><tr>"
            f"<td>d<sub>t</sub> {_fmt(d_t, 'm')}{mark}</td><td>d<sub>o</sub> "
            f"{_fmt(d_o, 'm') + mark if math.isfinite(d_o) else 'none'}</td>"
            f"<td>V<sub>L</sub> {_fmt(v_l, 'V', 1)}</td></tr><tr>"
            f"<td>φ<sub>t</sub> {_fmt(phi_t, 'rad')}{mark}</td><td>φ<sub>o</sub> "
            f"{_fmt(phi_o, 'rad') + mark if math.isfinite(phi_o) else 'none'}</td>"
            f"<td>V<sub>R</sub> {_fmt(v_r, 'V', 1)}</td></tr></table></div>"
        )

    def _rule_base_note(self, snap: Snapshot) -> str:
        """Which of the paper's rule bases drives (docs/paper-controller.md): its twin in
        the Husky's world, the paper-geometry fit in the paper's."""
        if snap.controller_label != "paper":
            return ""
        from fuzzynav.controller.paper import RULE_BASE_SHORT

        return html.escape(f" ({RULE_BASE_SHORT[self.view.app.geometry]})")

    @staticmethod
    def _parts_note(snap: Snapshot) -> str:
        if not (snap.has_parts and snap.parts_off):
            return ""
        off = snap.parts_off
        return html.escape(
            f" (without {' and '.join(off)})" if len(off) <= 2 else f" ({len(off)} parts off)"
        )

    def _metrics_html(self, snap: Snapshot) -> str:
        if snap.metrics is None and snap.ghost is None:
            return self.RESULT_PENDING
        m = snap.metrics or {"outcome": "running" if snap.playing else "not finished"}
        ghost = snap.ghost.metrics if snap.ghost is not None else None
        paper = None if snap.layout_edited else published_table4("paper", snap.scenario_label)
        colour = "#15803d" if m.get("outcome") == "reached" else "#b91c1c"
        rows = [
            ("Outcome", m.get("outcome"), None, ""),
            ("Time to target", m.get("time_to_target_s"), None, "s"),
            ("Path length", m.get("path_length_m"), "path_length_m", "m"),
            ("MAD from the line", m.get("mad_m"), "mad_m", "m"),
            ("RMSE from the line", m.get("rmse_m"), "rmse_m", "m"),
            ("Min centre distance", m.get("min_center_distance_m"), "min_center_distance_m", "m"),
            ("Min clearance (footprint)", m.get("min_clearance_m"), None, "m"),
            ("Max |voltage|", m.get("max_abs_voltage_v"), None, "V"),
        ]
        head = (
            "<tr><th style='text-align:left'>metric</th><th style='text-align:right'>this run</th>"
            + ("<th style='text-align:right;color:#64748b'>previous</th>" if ghost else "")
            + ("<th style='text-align:right'>paper</th>" if paper else "")
            + "</tr>"
        )
        body = []
        for label, value, key, unit in rows:
            shown = (
                f"<b style='color:{colour}'>{html.escape(str(value))}</b>"
                if label == "Outcome"
                else _fmt(value, unit, 3)
            )
            paper_cell = (
                (
                    f"<td style='text-align:right;color:#64748b;white-space:nowrap'>"
                    f"{_fmt(paper.get(key), unit, 3) if key else ''}</td>"
                )
                if paper
                else ""
            )
            ghost_cell = ""
            if ghost:
                g = ghost.get(
                    key
                    or {
                        "Outcome": "outcome",
                        "Time to target": "time_to_target_s",
                        "Min clearance (footprint)": "min_clearance_m",
                        "Max |voltage|": "max_abs_voltage_v",
                    }.get(label, "")
                )
                ghost_cell = (
                    "<td style='text-align:right;color:#64748b;white-space:nowrap'>"
                    f"{html.escape(str(g)) if label == 'Outcome' and g else _fmt(g, unit, 3)}</td>"
                )
            body.append(
                f"<tr><td>{label}</td><td style='text-align:right;white-space:nowrap'>{shown}</td>"
                f"{ghost_cell}"
                f"{paper_cell}</tr>"
            )
        note = (
            "<div style='color:#64748b;font-size:0.8em'>"
            + (
                f"Previous run (grey trail): {html.escape(snap.ghost.label)}. "
                if snap.ghost is not None
                else ""
            )
            + f"This run: {html.escape(snap.run_label)}. "
            "Paper: Table 4, proposed method. "
            "MAD and RMSE are distances from the straight start–target line.</div>"
        )
        return (
            "<table style='width:100%;font-size:"
            f"{'1.1em' if self.view.presentation else '0.85em'};font-variant-numeric:tabular-nums'>"
            + head
            + "".join(body)
            + "</table>"
            + note
        )
