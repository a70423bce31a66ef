"""N worlds stepped together as numpy arrays: the batch engine's stepping form.

:class:`BatchWorld` holds N runs (each with its own scenario, time and sonar noise) and
advances them one control period per :meth:`~BatchWorld.step`, in stages:

* :meth:`~BatchWorld.observe`, perception: the controller's inputs ``(d_t, d_o, phi_t,
  phi_o)`` and the sonar ranges (:func:`world.kernels.target_inputs`,
  :func:`~world.kernels.ideal_obstacle_inputs` or the sonars' rays), the disturbance
  added;
* :meth:`~BatchWorld.step`, given the wheel voltages: the saturation, the plant (one
  product for all runs, :func:`world.husky.step_product`), the motion of the body and of
  the obstacles, the contacts (at the step's end and swept between the ends), the logged
  row's metrics (:class:`world.batch_metrics.BatchMetrics`) and the termination
  (reached, collided, timeout, and the caller's ``stop_rule`` when given).

Two ways to use it: :func:`world.batch.run_batch` steps a batch until every run has
ended, dropping the ended runs from the arrays (:meth:`~BatchWorld.drop_ended`); a
fixed-size user (the gymnasium vector environment, :mod:`fuzzynav.gym`) keeps all N and
starts ended runs again in place (:meth:`~BatchWorld.restart`). Every run has its own
clock, so runs that start at different steps are each the run they would be alone.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from fuzzynav.world.arena import POINT_ROBOT_RADIUS_M, SWEEP_RELEVANT_M, SWEEP_TOLERANCE_M
from fuzzynav.world.batch_metrics import BatchMetrics, BatchResult, RunObserver
from fuzzynav.world.batch_state import BatchState, scenario_arrays
from fuzzynav.world.husky import HuskyModel, step_product
from fuzzynav.world.husky_params import N_STATES
from fuzzynav.world.kernels import (
    CONTACT_CLEARANCE_M,
    advance_pose,
    disturbance_values,
    footprint_clearances,
    ideal_obstacle_inputs,
    obstacle_centres,
    obstacle_path_bound,
    sonar_distances,
    sonar_obstacle_inputs,
    swept_clearances,
    target_inputs,
)
from fuzzynav.world.metrics import in_window
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M, check_geometry
from fuzzynav.world.run_limits import check_loop_settings, run_endings
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.sensors import SCHEDULE_SLACK_S, SensorConfig

__all__ = ["BatchWorld"]

# Column of the mean forward speed and yaw rate in the plant's step product (the mean
# state's v_MH and w_JH follow the new state's six entries).
_V_COLUMN, _W_COLUMN = N_STATES + 2, N_STATES + 3


class BatchWorld:
    """N runs of the paper's plant and sensors, stepped together.

    Parameters
    ----------
    perception : {"ideal", "ultrasonic"}
        As :class:`world.simulation.Simulation`.
    geometry : {"husky", "paper"}
        The Husky's footprint, or the paper's point robot (ideal only).
    control_period_s : float
        The control period and step, s (1 ms to 1 s).
    model : HuskyModel, optional
        The LG plant (the paper's parameters if omitted).
    sensor_config : SensorConfig, optional
        The sonars (the US-100 defaults if omitted).
    voltage_limit_v : float
        The saturation after the controller, V.
    max_duration_s : float, optional
        Every run ends as ``timeout`` at this time at the latest (tuning's cap).
    stop_rule : callable, optional
        An early stop of the caller's (tuning's stall rule,
        :class:`app.experiments.objective.StallRule`): called after every step as
        ``stop_rule(runs, time_s, to_target_m)`` with the runs' batch indices, times (s)
        and distances to the target (m), each (n,); the runs it returns True for end as
        ``timeout``, their step unlogged (unless the step ended them anyway).
    observers : sequence of RunObserver
        The caller's own measurements (:class:`world.batch_metrics.RunObserver`), fed
        at every logged row and decision.
    record_poses : bool
        Keep every logged pose (for tests and small batches).
    """

    #: The runs' arrays and metrics (from :meth:`reset` on).
    s: BatchState
    metrics: BatchMetrics
    _inputs: np.ndarray | None
    _ended: np.ndarray | None

    def __init__(
        self,
        *,
        perception: str = "ideal",
        geometry: str = "husky",
        control_period_s: float = 0.02,
        model: HuskyModel | None = None,
        sensor_config: SensorConfig | None = None,
        voltage_limit_v: float = 12.0,
        max_duration_s: float | None = None,
        stop_rule=None,
        observers: Sequence[RunObserver] = (),
        record_poses: bool = False,
    ):
        check_loop_settings(control_period_s, voltage_limit_v)
        check_geometry(geometry, perception)
        if perception not in ("ideal", "ultrasonic"):
            raise ValueError(f"perception = {perception!r}: must be one of ideal, ultrasonic")
        self.perception, self.geometry = perception, geometry
        self.model = model or HuskyModel.default()
        self.config = config = sensor_config or SensorConfig()
        self.dt = dt = float(control_period_s)
        # The rows of the step product the loop uses: the new state, then the step-mean
        # forward speed and yaw rate (a row's sum is the same whatever rows are kept).
        self._step_rows = np.ascontiguousarray(
            self.model.discrete(dt).step_matrix[[*range(N_STATES), _V_COLUMN, _W_COLUMN]]
        )
        params = self.model.parameters
        self.point_robot = geometry == "paper"
        if self.point_robot:
            self.half_length = self.half_width = 0.0
        else:
            self.half_length = 0.5 * params.footprint_length_m
            self.half_width = 0.5 * params.footprint_width_m
        self.half_diagonal = 0.5 * math.hypot(2.0 * self.half_length, 2.0 * self.half_width)
        self.ultrasonic = perception == "ultrasonic"
        self.limit = float(voltage_limit_v)
        self.max_duration_s = max_duration_s
        self.stop_rule = stop_rule
        self.observers = observers
        self.record_poses = record_poses
        self.mount_x = np.array([mt.x_m for mt in config.mounts])
        self.mount_y = np.array([mt.y_m for mt in config.mounts])
        self.mount_angle = np.array([mt.angle_rad for mt in config.mounts])
        self.offsets = np.asarray(config.ray_offsets_rad(), dtype=float)
        self.n_sensors = len(self.mount_x)
        # The farthest any ray reaches from the robot's centre, m (the sensors' prefilter).
        self.sonar_reach_m = config.reach_m()
        self.update_period_s = 1.0 / config.update_rate_hz
        self._noisy = self.ultrasonic and config.noise_std_m > 0

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self, scenarios: Sequence[Scenario], seeds=None) -> None:
        """Start a batch: one run per scenario, all at their start, time 0.

        Parameters
        ----------
        scenarios : sequence of Scenario
            One run each.
        seeds : int, sequence of int or None, optional
            The sonar noise seed of each run (one int or None: every run).

        Raises
        ------
        ValueError
            An empty batch, or a seeds list of another length.
        """
        self._started = time.perf_counter()
        scenarios = list(scenarios)
        n_runs = len(scenarios)
        if n_runs == 0:
            raise ValueError("scenarios: the batch is empty")
        seeds = self._seed_list(seeds, n_runs)
        n_columns = max(1, max(len(sc.obstacles) for sc in scenarios))
        self.scenarios = scenarios
        self.n_runs = n_runs
        self.s = BatchState(n_runs, n_columns, self.n_sensors)
        self.metrics = BatchMetrics(n_runs, n_columns, self.record_poses, self.observers)
        self._rngs: list = [None] * n_runs
        self._codes = np.full(n_runs, -1, dtype=np.int64)
        self.restart(np.arange(n_runs), scenarios, seeds)

    def restart(self, runs, scenarios: Sequence[Scenario], seeds=None) -> None:
        """Start ``runs`` again in place, each on a scenario of its own, at time 0 (the
        others go on). Only while no run has been dropped (:meth:`drop_ended`).

        Parameters
        ----------
        runs : array_like of int
            Batch indices.
        scenarios : sequence of Scenario
            One per run in ``runs``.
        seeds : int, sequence of int or None, optional
            Their sonar noise seeds.
        """
        s = self.s
        runs = np.asarray(runs, dtype=np.int64)
        scenarios = list(scenarios)
        if len(scenarios) != runs.size:
            raise ValueError(f"{len(scenarios)} scenarios for {runs.size} runs")
        if s.run.size != self.n_runs:
            raise ValueError("restart: runs have been dropped from this batch")
        seeds = self._seed_list(seeds, runs.size)
        n_columns = max(len(sc.obstacles) for sc in scenarios)
        if n_columns > s.n_columns:
            s.widen(n_columns)
            self.metrics.widen(n_columns)
        s.set_runs(runs, scenario_arrays(scenarios, s.n_columns, self.max_duration_s, self.dt))
        for k, r in enumerate(runs.tolist()):
            self.scenarios[r] = scenarios[k]
            if self._noisy:
                self._rngs[r] = np.random.default_rng(seeds[k])
        self._any_moving = bool(s.moving.any())
        self._any_disturbed = bool(s.has_window.any())
        cx, cy = obstacle_centres(s.law[runs], s.t[runs])
        clear = footprint_clearances(
            s.x[runs], s.y[runs], s.h[runs], cx, cy, s.radius[runs],
            self.half_length, self.half_width,
        )  # fmt: skip
        s.set_runs(runs, {"cx": cx, "cy": cy, "sx": cx, "sy": cy, "clear": clear})
        self._codes[runs] = -1
        self._ended = None
        self.metrics.restart(runs)
        self.metrics.log_rows(s.select(runs), s.t[runs])
        self._inputs = None

    @staticmethod
    def _seed_list(seeds, n: int) -> list:
        if seeds is None or isinstance(seeds, (int, np.integer)):
            return [seeds] * n
        seeds = list(seeds)
        if len(seeds) != n:
            raise ValueError(f"seeds has {len(seeds)} entries for {n} scenarios")
        return seeds

    @property
    def runs(self) -> np.ndarray:
        """The batch indices of the runs in the arrays (all, unless dropped), (n,)."""
        return self.s.run

    @property
    def time_s(self) -> np.ndarray:
        """Each run's time since its start, s, (n,)."""
        return self.s.t

    @property
    def lg_state(self) -> np.ndarray:
        """Each run's LG state (w_LW, w_RW, v_MH, w_JH, i_L1, i_L2), (n, 6)."""
        return self.s.lg

    @property
    def pose(self) -> np.ndarray:
        """Each run's pose (x m, y m, heading rad, not wrapped), (n, 3)."""
        s = self.s
        return np.stack([s.x, s.y, s.h], axis=1)

    def drop_ended(self) -> None:
        """Drop the runs that ended in the last step from the arrays."""
        ended = self._ended
        if ended is not None and ended.any():
            self.s.keep(~ended)
            self._ended = None

    def result(self) -> BatchResult:
        """The outcomes and metrics so far (:class:`world.batch_metrics.BatchResult`)."""
        return self.metrics.result(
            self.geometry,
            self.perception,
            time.perf_counter() - self._started,
            self.scenarios,
        )

    @property
    def outcome_codes(self) -> np.ndarray:
        """Each run's ending (batch order): -1 going, else an index into
        :data:`world.run_limits.OUTCOMES`, (N,)."""
        return self._codes

    # -- perception --------------------------------------------------------------------

    def observe(self) -> tuple[np.ndarray, np.ndarray]:
        """The controller's inputs now and the sonar readings of the runs in the arrays.

        Returns
        -------
        tuple of numpy.ndarray
            ``inputs`` (n, 4): ``d_t`` m, ``d_o`` m, ``phi_t`` rad, ``phi_o`` rad, the
            disturbance added (NaN: no obstacle sensed); ``ranges`` (n, sensors): m,
            inf for no echo (all inf in ideal perception).
        """
        s = self.s
        d_t, phi_t = target_inputs(s.x, s.y, s.h, s.target)
        if self.ultrasonic:
            self._update_sonars()
            d_o, phi_o = sonar_obstacle_inputs(s.ranges, self.mount_angle, OBSTACLE_CUTOFF_M)
        else:
            d_o, phi_o = ideal_obstacle_inputs(
                s.x, s.y, s.h, s.cx, s.cy, s.radius, s.present, s.clear, s.half_field,
                self.point_robot, OBSTACLE_CUTOFF_M,
            )  # fmt: skip
        inputs = np.stack([d_t, d_o, phi_t, phi_o], axis=1)
        if self._any_disturbed:
            value = disturbance_values(s.disturbance, s.t)
            inputs = np.where((value != 0.0)[:, None], inputs + value[:, None], inputs)
        self._inputs = inputs
        return inputs, s.ranges

    def _update_sonars(self) -> None:
        """New readings for the runs whose sonars are due (the sensors' schedule)."""
        s = self.s
        due = ~(s.t + SCHEDULE_SLACK_S < s.next_update)
        if not due.any():
            return
        following = s.next_update + self.update_period_s
        s.next_update = np.where(
            due, np.where(following > s.t, following, s.t + self.update_period_s), s.next_update
        )
        rows = slice(None) if due.all() else np.flatnonzero(due)
        ranges = self._cast(rows)
        echo = np.isfinite(ranges)
        if self._noisy:
            run = s.run[rows]
            for row in np.flatnonzero(echo.any(axis=1)).tolist():
                rng = self._rngs[run[row]]
                for k in np.flatnonzero(echo[row]).tolist():
                    ranges[row, k] += rng.normal(0.0, self.config.noise_std_m)
        low, high = self.config.min_range_m, self.config.max_range_m
        clamped = np.where(low > ranges, low, ranges)
        clamped = np.where(high < clamped, high, clamped)
        fresh = np.where(echo, clamped, np.inf)
        if isinstance(rows, slice):
            s.ranges = fresh
        else:
            s.ranges = s.ranges.copy()
            s.ranges[rows] = fresh

    def _cast(self, rows) -> np.ndarray:
        """The noise-free echo of every sonar of the runs ``rows`` (m, inf: none): only
        the obstacles within a ray's reach (the sensors' prefilter) are cast against."""
        s = self.s
        x, y, h = s.x[rows], s.y[rows], s.h[rows]
        sx, sy, radius = s.sx[rows], s.sy[rows], s.radius[rows]
        n, n_sensors, n_rays = x.size, self.n_sensors, self.offsets.size
        dxr = sx - x[:, None]
        dyr = sy - y[:, None]
        within = self.sonar_reach_m + radius
        near = s.present[rows] & (dxr * dxr + dyr * dyr <= within * within)
        ranges = np.full((n, n_sensors), np.inf)
        pair_rows, pair_cols = np.nonzero(near)
        if not pair_rows.size:
            return ranges
        starts = np.flatnonzero(np.r_[True, pair_rows[1:] != pair_rows[:-1]])
        seen_rows = pair_rows[starts]
        pair_row = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, pair_rows.size]))
        hh = h[seen_rows]
        c, sn = np.cos(hh)[:, None], np.sin(hh)[:, None]
        ox = x[seen_rows, None] + c * self.mount_x - sn * self.mount_y  # (rows, sensors)
        oy = y[seen_rows, None] + sn * self.mount_x + c * self.mount_y
        direction = hh[:, None] + self.mount_angle
        ray = (direction[:, :, None] + self.offsets).reshape(-1, n_sensors * n_rays)
        hits = sonar_distances(
            np.repeat(ox, n_rays, axis=1)[pair_row],
            np.repeat(oy, n_rays, axis=1)[pair_row],
            np.cos(ray)[pair_row],
            np.sin(ray)[pair_row],
            self.config.max_range_m,
            sx[pair_rows, pair_cols][:, None],
            sy[pair_rows, pair_cols][:, None],
            radius[pair_rows, pair_cols][:, None],
        ).reshape(pair_rows.size, n_sensors, n_rays)
        ranges[seen_rows] = np.minimum.reduceat(hits.min(axis=2), starts, axis=0)
        # Held until the next cast, as the loop's frame held it before the engine was
        # split into stages: freed here, it let malloc give the heap's top back to the
        # system after every cast and fault it in again at the next (the ultrasonic
        # bench ran a quarter slower, all of it in page faults).
        self._last_hits = hits
        return ranges

    # -- one control period ------------------------------------------------------------

    def step(self, wheel_voltages) -> np.ndarray:
        """Apply the wheel voltages for one period to the runs in the arrays.

        Parameters
        ----------
        wheel_voltages : array_like, (n, 2)
            Left and right, V, before the saturation.

        Returns
        -------
        numpy.ndarray, (n,) int
            Each run's ending in this step: -1 going on, else an index into
            :data:`world.run_limits.OUTCOMES` (``stop_rule``'s ending is ``timeout``).

        Raises
        ------
        ValueError
            Voltages of the wrong shape or not finite (the run, time and inputs named).
        """
        s = self.s
        volts = self._saturate(wheel_voltages)
        window = s.has_window & in_window(s.t, s.disturbance[:, 2], s.disturbance[:, 3])
        self.metrics.add_voltages(s.run, volts, s.prev_v, window)
        s.prev_v = volts
        v, w, pose0, c0, t0 = self._move(volts)
        hit = self._contacts(v, w, pose0, c0, t0)
        self._inputs = None
        return self._finish(pose0, t0, hit)

    def _saturate(self, wheel_voltages) -> np.ndarray:
        s = self.s
        n = s.run.size
        raw = np.asarray(wheel_voltages)
        if raw.dtype.kind not in "iuf" or raw.shape != (n, 2):
            raise ValueError(
                f"the batch controller returned {raw.dtype} voltages of shape {raw.shape} "
                f"for {n} runs; it must return real numbers of shape (n, 2): left, right"
            )
        raw = raw.astype(float, copy=False)
        bad = ~np.isfinite(raw).all(axis=1)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            seen = "" if self._inputs is None else f" for inputs {self._inputs[row].tolist()}"
            raise ValueError(
                f"controller returned non-finite voltages {raw[row].tolist()}{seen} "
                f"at t = {s.t[row]:.3f} s (run {int(s.run[row])})"
            )
        limit = self.limit
        volts = np.where(-limit > raw, -limit, raw)
        return np.where(limit < volts, limit, volts)

    def _move(self, volts):
        """The plant, the body and the obstacles over the step; the step-mean speeds,
        the pose, clearances and times at its start."""
        s = self.s
        dt = self.dt
        # the pymunk engine's product (world.husky.step_product): the same bits, in a
        # batch of any size
        product = step_product(self._step_rows, np.concatenate([s.lg, volts], axis=1))
        s.lg = product[:, :N_STATES]
        v = product[:, N_STATES]
        w = product[:, N_STATES + 1]
        pose0 = (s.x, s.y, s.h)
        c0 = s.clear
        s.x, s.y, s.h = advance_pose(s.x, s.y, s.h, v, w, dt)
        t0 = s.t
        s.t = t0 + dt
        if self._any_moving:
            x0, y0 = s.cx, s.cy
            s.cx, s.cy = obstacle_centres(s.law, s.t)
            if self.ultrasonic:
                # Where pymunk's rays see the obstacles: Chipmunk caches a shape's
                # centre after moving its kinematic body by the chord velocity,
                # x0 + ((x1 - x0) / dt) dt: a last bit off the law.
                s.sx = np.where(s.moving, x0 + ((s.cx - x0) / dt) * dt, s.cx)
                s.sy = np.where(s.moving, y0 + ((s.cy - y0) / dt) * dt, s.cy)
        s.clear = footprint_clearances(
            s.x, s.y, s.h, s.cx, s.cy, s.radius, self.half_length, self.half_width
        )
        return v, w, pose0, c0, t0

    def _contacts(self, v, w, pose0, c0, t0) -> np.ndarray:
        """Contacts at the step's end (as pymunk judges them), then swept between the
        ends (:meth:`world.arena.Arena._sweep`); the least clearance kept. Returns which
        runs touched an obstacle, (n,)."""
        s = self.s
        dt = self.dt
        if self.point_robot:
            reach = s.radius + POINT_ROBOT_RADIUS_M
            ddx, ddy = s.cx - s.x[:, None], s.cy - s.y[:, None]
            contact = s.present & (ddx * ddx + ddy * ddy < reach * reach)
        else:
            contact = s.present & (s.clear <= CONTACT_CLEARANCE_M)
        touch = 0.0 if self.point_robot else CONTACT_CLEARANCE_M
        robot_path = (np.abs(v) + np.abs(w) * self.half_diagonal) * dt
        path = np.broadcast_to(robot_path[:, None], c0.shape)
        if self._any_moving:
            path = np.where(s.moving, path + obstacle_path_bound(s.law, t0, dt), path)
        low = np.minimum(c0, s.clear)
        # the arena's swept minimum takes both ends of every step (the logged rows too)
        min_clear = self.metrics.min_clear
        min_clear[s.run] = np.minimum(
            min_clear[s.run], np.where(s.present, low, np.inf).min(axis=1)
        )
        bound = 0.5 * (c0 + s.clear - path)
        swept = s.present & ~((bound >= low - SWEEP_TOLERANCE_M) | (bound >= SWEEP_RELEVANT_M))
        for row, j in zip(*np.nonzero(swept)):
            samples, _ = swept_clearances(
                (float(pose0[0][row]), float(pose0[1][row]), float(pose0[2][row])),
                float(v[row]),
                float(w[row]),
                dt,
                s.law[row, :, j].tolist(),
                float(s.radius[row, j]),
                float(t0[row]),
                self.half_length,
                self.half_width,
                float(path[row, j]),
            )
            smallest = float(samples.min())
            r_run = s.run[row]
            min_clear[r_run] = min(min_clear[r_run], smallest)
            if c0[row, j] > touch and not contact[row, j] and smallest <= touch:
                contact[row, j] = True
        hit = contact.any(axis=1)
        self.metrics.collided[s.run] |= hit
        return hit

    def _finish(self, pose0, t0, hit) -> np.ndarray:
        """The logged row after the step, and the ends (module docstring)."""
        s, m = self.s, self.metrics
        t = s.t
        to_target = np.hypot(s.target[:, 0] - s.x, s.target[:, 1] - s.y)
        ending = run_endings(to_target, s.tolerance, hit, t, s.timeout_at_s)
        ended = ending >= 0
        if self.stop_rule is not None:  # after every step, the last one too
            stalled = np.asarray(self.stop_rule(s.run, t, to_target), dtype=bool)
            cut = stalled & ~ended  # stopped before its end: the step is not logged
        else:
            stalled = cut = np.zeros(len(ended), dtype=bool)
        logged = ~cut
        m.steps_done[s.run] += 1
        m.steps_done[s.run[cut]] -= 1
        moved = np.hypot(s.x - pose0[0], s.y - pose0[1])
        m.path_sum[s.run] += np.where(logged, moved, 0.0)
        if logged.all():
            m.log_rows(s, t)
        else:
            rows = np.flatnonzero(logged)
            m.log_rows(s.select(rows), t[rows])
        ended |= stalled
        self._ended = ended
        if not ended.any():
            self._codes[s.run] = -1
            return np.full(len(ended), -1, dtype=np.int64)
        code = np.where(stalled, 2, ending)  # the stop rule's ending is a timeout
        finished = s.run[ended]
        m.outcome[finished] = code[ended]
        m.sim_time[finished] = np.where(cut, t0, t)[ended]
        self._codes[s.run] = code
        return code
