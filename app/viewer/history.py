"""The run's history and results: a step recorded per control period for the time
slider and the rule-firing strip, the run's label (what drove it, and what changed
while it ran), its metrics when it ends (or what can be said of it when stopped). A part
of :class:`ViewerApp` (:mod:`.model`), whose state and lock it shares."""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping

import numpy as np

from fuzzynav.app.viewer.budget import HISTORY_BYTES
from fuzzynav.app.viewer.state import (
    HistoryStep,
    ViewerError,
)

#: What a recorded step holds besides its obstacles' positions and fuzzynav's blocks
#: (the step, its tuples, arrays and floats, its place in the lists): measured 0.7 kB
#: with tracemalloc on s1 (2.4 kB with 110 moving obstacles, 1.7 kB charged for them;
#: 1.3 kB with fuzzynav's blocks); `tests/test_viewer_budget.py` checks the charge is
#: never under what a step holds.
STEP_BYTES = 1536


class ObstaclePositions(Mapping):
    """Where the obstacles were at a recorded step, id -> (x, y): the ids' rows (one
    dict shared by every step of a layout) and a float64 array of positions, shared
    with the step before when nothing moved. (A dict per step held 110 obstacles in
    about 20 kB: 1 MB a simulated second.)"""

    __slots__ = ("rows", "xy")

    def __init__(self, rows: dict, xy: np.ndarray):
        self.rows, self.xy = rows, xy

    def __getitem__(self, obstacle_id):
        r = self.rows[obstacle_id]
        return (float(self.xy[r, 0]), float(self.xy[r, 1]))

    def __iter__(self):
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def nbytes(self) -> int:
        return self.xy.nbytes + 112


def _block_bytes(block) -> int:
    if block is None:
        return 0
    fed, parts = block
    return int(getattr(fed, "nbytes", 0)) + 112 + sys.getsizeof(parts) + 80 * len(parts)


class StepHistory:
    """The recorded steps of a run, within ``limit`` bytes (:data:`HISTORY_BYTES`),
    charged to the world's account in the server's budget as they are kept.

    Every step is kept until the limit (or the server's budget) is reached; then every
    other step is dropped and from there one step in two is kept (the stride doubles
    each time it is reached again), so the slider still spans the whole run, more
    coarsely. The newest step is always kept (the live end). Reads as a list:
    ``len``, ``[k]``, iteration."""

    def __init__(self, account=None, limit: int = HISTORY_BYTES):
        self.account = account
        self.limit = int(limit)
        self.steps: list[HistoryStep] = []
        self.numbers: list[int] = []  # each kept step's number in the run (0, 1, ...)
        self.stride = 1
        self.bytes = 0
        self._count = 0
        self._rows: dict | None = None  # the ids' rows of the last layout recorded

    # -- reads as a list ----------------------------------------------------------------

    def __len__(self) -> int:
        return len(self.steps)

    def __bool__(self) -> bool:
        return bool(self.steps)

    def __getitem__(self, k):
        return self.steps[k]

    def __iter__(self):
        return iter(self.steps)

    # -- recording ----------------------------------------------------------------------

    def positions(self, ids, centres) -> ObstaclePositions:
        """The obstacles' positions, sharing the last step's when nothing changed."""
        ids = list(ids)
        xy = np.asarray(centres, dtype=float).reshape(-1, 2)
        last = self.steps[-1].obstacles if self.steps else None
        if (
            isinstance(last, ObstaclePositions)
            and list(last.rows) == ids
            and np.array_equal(last.xy, xy)
        ):
            return last
        if self._rows is None or list(self._rows) != ids:
            self._rows = {i: r for r, i in enumerate(ids)}
        return ObstaclePositions(self._rows, xy.copy())

    def _cost(self, k: int) -> int:
        """What step ``k`` adds to the steps before it (its positions only when new)."""
        step = self.steps[k]
        n = STEP_BYTES + _block_bytes(step.block)
        obstacles = step.obstacles
        if k == 0 or obstacles is not self.steps[k - 1].obstacles:
            n += getattr(obstacles, "nbytes", 0) or 200 * len(obstacles)
        return n

    def append(self, step: HistoryStep) -> None:
        number = self._count
        self._count += 1
        if len(self.steps) > 1 and self.numbers[-1] % self.stride:
            # the last step was kept only as the live end: this one takes its place
            self.bytes -= self._cost(len(self.steps) - 1)
            self.steps.pop()
            self.numbers.pop()
        self.steps.append(step)
        self.numbers.append(number)
        self.bytes += self._cost(len(self.steps) - 1)
        while len(self.steps) > 2 and not self._charge():
            self._thin()
        if len(self.steps) <= 2:
            self._charge()

    def _charge(self) -> bool:
        if self.bytes > self.limit:
            return False
        return self.account is None or self.account.resize("history", self.bytes)

    def _thin(self) -> None:
        """Double the stride: keep the steps on it (and the newest)."""
        self.stride *= 2
        keep = [k for k, n in enumerate(self.numbers) if n % self.stride == 0]
        if keep[-1] != len(self.steps) - 1:
            keep.append(len(self.steps) - 1)
        self.steps = [self.steps[k] for k in keep]
        self.numbers = [self.numbers[k] for k in keep]
        self.bytes = sum(self._cost(k) for k in range(len(self.steps)))

    def close(self) -> None:
        """Forget every step (a new run), and give back what they were charged."""
        self.steps, self.numbers = [], []
        self.stride, self.bytes, self._count = 1, 0, 0
        if self.account is not None:
            self.account.resize("history", 0)


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
        history = app._history
        k = app.history_index
        app._history.append(
            HistoryStep(
                time_s=sim.time_s,
                pose=tuple(arena.pose),
                input_pose=app._input_pose,
                inputs=c.last_inputs.copy(),
                output=c.last_output.copy(),
                target=tuple(float(v) for v in arena.target),
                obstacles=history.positions(ids, centres),
                block=None if seen is None else (seen[1].copy(), dict(seen[2])),
            )
        )
        if k is not None and k >= len(history):  # (thinned while a past step was shown)
            app.history_index = len(history) - 1

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
            "collided": self._collision_text(result.collisions),
            "timeout": "ran out of time",
        }.get(result.outcome, result.outcome)
        level = "success" if result.outcome == "reached" else "warning"
        app._notice(f"Run ended at t = {app.sim.time_s:.2f} s: the robot {text}.", level)

    def _collision_text(self, collisions) -> str:
        """The obstacle hit, by its name on the arena; and when a drag put it down during
        the run, that drop named as the cause."""
        app = self.app
        if not collisions:
            return "collided with an obstacle"
        hit = collisions[0].obstacle_id
        name = f"obstacle {app.editing.obstacle_number(hit)}"
        dropped = app._drops.get(hit)
        if dropped is None:
            return f"collided with {name}"
        return (
            f"collided with {name}, which was dropped in its way at t = {dropped:.2f} s "
            "(the drop caused the collision)"
        )

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

    def timeline_entry_locked(self) -> dict:
        """What drives the run now, as a lesson replays it: the control step it took
        effect at, the controller (its label; its system when it is not a named one),
        the perception, disturbance, noise and fuzzynav's parts."""
        app = self.app
        settings = app.setup.settings()
        return {
            "step": int(round(app.sim.time_s / app.sim.control_period_s)),
            "controller": settings["controller"],
            "fis": settings["fis"],
            "perception": settings["perception"],
            "disturbance_on": bool(settings["disturbance_on"]),
            "noise_std_m": float(settings["noise_std_m"]),
            "parts_off": tuple(settings["parts_off"]),
        }

    def _note_timeline_locked(self) -> None:
        """Keep the change in the run's timeline (a lesson replays it); a change at the
        same step as the last replaces it."""
        app = self.app
        entry = self.timeline_entry_locked()
        timeline = getattr(app, "_timeline", None) or []
        if timeline and timeline[-1]["step"] == entry["step"]:
            timeline[-1] = entry
        elif not timeline or {k: v for k, v in entry.items() if k != "step"} != {
            k: v for k, v in timeline[-1].items() if k != "step"
        }:
            timeline.append(entry)
        app._timeline = timeline

    def _note_change_locked(self) -> None:
        """After a change of what drives (controller, parts, perception, disturbance,
        noise): a run not started yet is labelled afresh; a run under way keeps what it
        started with, and the change is added with its time ("from 3.2 s: ...")."""
        app = self.app
        settings = self._settings()
        self._note_timeline_locked()
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
