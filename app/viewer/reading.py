"""Reading the world for the page: a :class:`Snapshot` per frame (the live world, or
the recorded step the time slider shows), the trail and the plots' signals, fuzzynav's
memory placed in the world. A part of :class:`ViewerApp` (:mod:`.model`), whose state
and lock it shares."""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.viewer.state import (
    ObstacleView,
    Snapshot,
)
from fuzzynav.world.geometry import to_world_frame


class Reading:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app

    def snapshot(self) -> Snapshot:
        app = self.app
        with app.lock:
            snap = self._live_snapshot_locked()
            snap.history_span = (
                (app._history[0].time_s, app._history[-1].time_s) if app._history else (0.0, 0.0)
            )
            k = app.history_index
            if k is None or k >= len(app._history):
                return snap
            h = app._history[k]
            limit = app.sim.voltage_limit_v
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
        app = self.app
        with app.lock:  # (held already: an RLock)
            sim = app.sim
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
                version=app.version,
                run_id=app.run_id,
                layout_id=app.layout_id,
                time_s=t,
                playing=app.playing,
                speed=app.speed,
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
                inputs=app.controller.last_inputs.copy(),
                voltages_v=np.clip(
                    app.controller.last_output, -sim.voltage_limit_v, sim.voltage_limit_v
                ),
                nearest_clearance_m=float(clearances.min()) if len(clearances) else math.inf,
                scenario_label=app.scenario_label,
                controller_label=app.controller_label,
                perception=sim.perception.mode,
                field_of_view_rad=sim.perception.field_of_view_rad,
                geometry=app.geometry,
                disturbance_on=app.disturbance_on,
                noise_std_m=app.noise_std_m,
                message=app.message,
                message_level=app.message_level,
                layout_edited=app.editing.layout_edited,
                metrics=dict(app.metrics) if app.metrics else None,
                memory_xy=memory_xy,
                steer_heading_rad=steer,
                parts_off=app.parts_off,
                has_parts=hasattr(app.controller.inner, "set_parts_off"),
                ghost=app.ghost,
                ghost_id=app.ghost_id,
                run_label=app.run_label,
                disturbance_text=app.results.disturbance_text() if app.disturbance_on else "",
                inputs_disturbed=self._inputs_disturbed_locked(),
                obstacle_numbers={i: k + 1 for k, (i, _) in enumerate(app._layout)},
                what_if=None if app.what_if is None else app.what_if.copy(),
                input_pose=app._input_pose,
            )

    def _inputs_disturbed_locked(self) -> bool:
        app = self.app
        d = app.sim.disturbance
        if d is None or not np.isfinite(app.controller.last_inputs[0]):
            return False
        t = app.sim.time_s - app.sim.control_period_s  # when the last inputs were read
        return d.start_s <= t < d.stop_s

    def trail_since(self, start: int) -> tuple[int, np.ndarray]:
        """(run id, trail points from index ``start`` on)."""
        app = self.app
        with app.lock:
            return app.run_id, np.array(app._trail[start:], dtype=float).reshape(-1, 2)

    def signals(self) -> np.ndarray:
        """The last ``PLOT_WINDOW_S`` of the live signal rows, (t, d_t, d_o, phi_t, phi_o,
        v_left, v_right): ``.driver.SIGNAL_COLUMNS``."""
        app = self.app
        with app.lock:
            return app._signals.ordered()

    def _memory_view(self, pose):
        """(points (n, 2) in the world, steering heading) of a controller that shows its
        memory (``teaching_points``), placed from its own frame by the true pose; else
        (None, nan). Called under the lock."""
        app = self.app
        shown = app._probe if app._probe is not None else app.controller.inner
        view = getattr(shown, "teaching_points", None)
        if view is None:
            return None, math.nan
        points, bearing = view()
        x, y, heading = pose
        return to_world_frame(np.reshape(points, (-1, 2)), (x, y), heading), heading + bearing
