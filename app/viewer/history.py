"""The run's history and results: a step recorded per control period for the time
slider and the rule-firing strip, the run's label (what drove it, and what changed
while it ran), its metrics when it ends (or what can be said of it when stopped). A part
of :class:`ViewerApp` (:mod:`.model`), whose state and lock it shares."""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.viewer.state import (
    HistoryStep,
    ViewerError,
)


class RunHistory:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app

    def _record_history_locked(self) -> None:
        """One entry per control step, for the time slider: what the scene and the
        inference view need to show that step again (fuzzynav's blocks: what they were
        fed and its crisp parts)."""
        app = self.app
        sim, c = app.sim, app.controller
        arena = sim.arena
        view = getattr(c.inner, "teaching_view", None)
        seen = view() if view is not None else None
        centres, _, ids = arena.obstacle_arrays()  # (cached by the arena for this step)
        app._history.append(
            HistoryStep(
                time_s=sim.time_s,
                pose=tuple(arena.pose),
                input_pose=app._input_pose,
                inputs=c.last_inputs.copy(),
                output=c.last_output.copy(),
                target=tuple(float(v) for v in arena.target),
                obstacles=dict(zip(ids, map(tuple, centres.tolist()))),
                trail_length=len(app._trail),
                block=None if seen is None else (seen[1].copy(), dict(seen[2])),
            )
        )

    def history_times(self) -> tuple[float, float]:
        """(first, last) time of the recorded steps of this run (0, 0 before any)."""
        app = self.app
        with app.lock:
            if not app._history:
                return 0.0, 0.0
            return app._history[0].time_s, app._history[-1].time_s

    def view_history(self, time_s) -> float | None:
        """Show the run as it was at ``time_s`` (the recorded step nearest to it): the
        scene, the inputs and the inference of that step; the run pauses there, and
        Play, Step or :meth:`leave_history` go back to where it is. None leaves it.
        Returns the time shown."""
        app = self.app
        if time_s is None:
            self.leave_history()
            return None
        try:
            time_s = float(time_s)
        except (TypeError, ValueError):
            raise ViewerError(f"time {time_s!r}: must be a number of seconds") from None
        with app.lock:
            if not app._history:
                raise ViewerError("nothing recorded yet: press Play or Step first")
            times = np.array([h.time_s for h in app._history])
            k = int(np.argmin(np.abs(times - time_s)))
            app.playing = False
            if app.what_if is not None:
                app._end_mode_message_locked("what-if")
            app.what_if = None
            app.history_index = k
            app._bump()
            return float(times[k])

    def firing_timeline(self):
        """(times (n,), strengths (n, n_rules)) of this run's recorded steps, for the
        rule-firing strip; None without a rule base or before the first step."""
        app = self.app
        with app.lock:
            steps = list(app._history)
            fis = app.inference.fuzzy_system()
            teaching = hasattr(app.controller.inner, "teaching_view")
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
        app = self.app
        with app.lock:
            if app.history_index is not None:
                app.history_index = None
                app._end_mode_message_locked("history")
                app._bump()

    def _finish_locked(self) -> None:
        app = self.app
        app.driver._close_recorder_locked()
        try:
            result = app.sim.result()
        except Exception as exc:  # metrics must never take the viewer down
            app._notice(f"metrics could not be computed: {exc}", "warning")
            return
        app.metrics = dict(result.metrics)
        app.metrics["collisions"] = len(result.collisions)
        text = {
            "reached": "reached the target",
            "collided": "collided with an obstacle",
            "timeout": "ran out of time",
        }.get(result.outcome, result.outcome)
        level = "success" if result.outcome == "reached" else "warning"
        app._notice(f"Run ended at t = {app.sim.time_s:.2f} s: the robot {text}.", level)

    def _settings(self) -> list[str]:
        """What drives the run now, in words: controller (and fuzzynav's parts off),
        perception, disturbance, sensor noise."""
        app = self.app
        controller = app.controller_label
        if app.parts_off and hasattr(app.controller.inner, "set_parts_off"):
            controller += " without " + " and ".join(app.parts_off)
        parts = [controller, app.sim.perception.mode]
        if app.disturbance_on:
            parts.append(self.disturbance_text())
        if app.noise_std_m > 0:
            parts.append(f"noise σ {app.noise_std_m:.2f} m")
        return parts

    def disturbance_text(self) -> str:
        app = self.app
        d = app.setup.disturbance_in_use()
        window = (
            ""
            if d.start_s <= 0 and not math.isfinite(d.stop_s)
            else f" for {d.start_s:g}-{d.stop_s:g} s"
        )
        return f"disturbed by {d.amplitude:g}·sin({d.angular_frequency_rad_s:g}t){window}"

    def _run_label(self) -> str:
        app = self.app
        return " · ".join([app.scenario_label, *self._settings()])

    def _note_change_locked(self) -> None:
        """After a change of what drives (controller, parts, perception, disturbance,
        noise): a run not started yet is labelled afresh; a run under way keeps what it
        started with, and the change is added with its time ("from 3.2 s: ...")."""
        app = self.app
        settings = self._settings()
        if app.sim.time_s <= 0.0 or not app._run_changes:
            app._run_changes = [(0.0, settings)]
            app.run_label = self._run_label()
            return
        if settings == app._run_changes[-1][1]:
            return
        app._run_changes.append((app.sim.time_s, settings))
        first = app._run_changes[0][1]
        later = [f"from {t:.1f} s: {' · '.join(p)}" for t, p in app._run_changes[1:]]
        if len(later) > 3:
            later = later[:1] + ["…"] + later[-2:]
        app.run_label = " · ".join([app.scenario_label, *first]) + "; " + "; ".join(later)

    def _partial_metrics(self) -> dict:
        """What can be said of a run stopped before its end: its time and path so far."""
        app = self.app
        trail = np.asarray(app._trail, dtype=float)
        length = float(np.sum(np.linalg.norm(np.diff(trail, axis=0), axis=1)))
        return {
            "outcome": f"stopped at t = {app.sim.time_s:.1f} s",
            "path_length_m": length,
        }
