"""The lockstep batch engine: N runs advanced together as numpy arrays.

:func:`run_batch` drives N scenarios (each with its own start, target, obstacles,
duration and disturbance) one control period per step, every quantity of every run in
one array. It is :class:`world.simulation.Simulation` without pymunk:

* **the same plant**: the LG model's exact zero-order-hold step matrix
  (:meth:`world.husky.HuskyModel.discrete`), applied to all runs as one (N x 8) x (8 x
  12) product;
* **the same motion**: the body moves as the pymunk body is moved (velocity = chord of
  the step's arc along the mid-step heading, then Chipmunk's ``p += v dt``,
  ``a += w dt``), so in ideal perception the poses agree with the pymunk engine to
  rounding;
* **the same inputs**: Eqs. 7-12 / the Husky geometry's footprint clearances
  (:mod:`world.perception`), the three sonars (3 beams x 5 rays; Chipmunk's own
  ray-circle formula, its "ray starts inside" rule, the same range, blind zone, update
  schedule and per-run seeded noise as :mod:`world.sensors`), the disturbance of each
  scenario, the obstacles' constant-acceleration laws;
* **the same contacts**: the footprint rectangle (or the paper's point robot) against
  every circle at the end of the step, as pymunk judges it, and the arena's swept test
  between the steps (:meth:`world.arena.Arena._sweep`, its constants and formula);
* **the same metrics**, accumulated per run as the run goes (no per-step log is kept,
  so 10,000 runs fit in memory): every number :func:`world.metrics.compute_metrics`
  gives that a sweep row carries.

What is shared and what is not: the plant step is one function for both engines
(:func:`world.husky.step_product`), so are the constants (sensor model, sweep, cutoff,
jump threshold) and, in ``app``, the rows and the tuning and fit costs; the inputs, the
motion, the disturbance and the metrics are the pymunk engine's formulas rewritten
operation for operation for arrays (the pymunk engine's own float code is tuned for one
run and stays as it is); the ray casts and the collision tests are closed forms instead
of Chipmunk's queries. In practice a run's trajectory is the pymunk engine's bit for bit
(tests/test_batch.py, bench/bench_batch.py --crosscheck); the one known source of
last-bit differences is ``math.hypot`` there against numpy's ``hypot`` here. A run
that ends is dropped from the arrays: it costs nothing after its last step.

The world knows nothing of the controller: it calls ``controller.decide(inputs, runs,
ranges_m)`` (:class:`BatchController`) with the active runs' inputs (n, 4), their
indices in the batch (n,) and their sonar readings (n, 3); the controller returns the
wheel voltages (n, 2). The glue for fuzzynav's controllers is
:mod:`controller.batch`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from fuzzynav.world.arena import (
    POINT_ROBOT_RADIUS_M,
    SWEEP_MAX_SAMPLES,
    SWEEP_RELEVANT_M,
    SWEEP_SPACING_M,
    SWEEP_TOLERANCE_M,
)
from fuzzynav.world.geometry import FULL_CIRCLE_RAD
from fuzzynav.world.husky import N_STATES, HuskyModel, step_product
from fuzzynav.world.metrics import VOLTAGE_JUMP_V
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M, check_geometry
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.sensors import SensorConfig
from fuzzynav.world.simulation import OUTCOMES, check_loop_settings, timeout_slack_s

__all__ = ["BatchController", "BatchResult", "run_batch", "OUTCOMES"]

_PI, _TWO_PI = math.pi, 2.0 * math.pi
# Column of the mean forward speed and yaw rate in the plant's step product (the mean
# state's v_MH and w_JH follow the new state's six entries).
_V_COLUMN, _W_COLUMN = N_STATES + 2, N_STATES + 3


class BatchController(Protocol):
    """What :func:`run_batch` calls: ``decide(inputs (n, 4), runs (n,), ranges_m (n, 3))
    -> wheel voltages (n, 2)`` (left, right, V, before the saturation)."""

    def decide(self, inputs: np.ndarray, runs: np.ndarray, ranges_m: np.ndarray) -> np.ndarray: ...


@dataclass
class BatchResult:
    """Per-run outcomes and metrics of a batch (arrays of length N, batch order).

    Lengths in m, times in s, voltages in V; NaN where a number does not exist (no
    arrival time, no obstacle). ``outcome`` holds indices into :data:`OUTCOMES`.
    """

    outcome: np.ndarray  # (N,) int: index into OUTCOMES
    collided: np.ndarray  # (N,) bool: a contact happened
    time_to_target_s: np.ndarray
    sim_time_s: np.ndarray
    steps: np.ndarray  # (N,) int: control periods run
    path_length_m: np.ndarray
    mad_m: np.ndarray
    rmse_m: np.ndarray
    min_center_distance_m: np.ndarray
    min_clearance_m: np.ndarray
    min_safety_distance_m: np.ndarray
    max_abs_voltage_v: np.ndarray
    voltage_jumps: np.ndarray  # (N,) int
    #: Distance from the robot's centre to the target, m: its least over the logged
    #: rows, and at the last logged row (what tuning's cost reads).
    min_target_distance_m: np.ndarray
    final_target_distance_m: np.ndarray
    geometry: str
    perception: str
    wall_time_s: float
    #: With ``trace=True``: the target bearing input phi_t (rad, disturbance included)
    #: of the last logged row (N,); per obstacle the closest centre distance (m) and
    #: its first time (s) (N, M); the largest applied voltage per wheel (N, 2), V.
    final_phi_t_rad: np.ndarray | None = None
    closest_center_distance_m: np.ndarray | None = None
    closest_center_time_s: np.ndarray | None = None
    max_voltage_v: np.ndarray | None = None
    #: Per run, its logged poses (steps + 1, 3) when ``record_poses`` was asked.
    poses: list | None = None
    scenarios: list = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.outcome)

    @property
    def outcomes(self) -> list[str]:
        return [OUTCOMES[k] for k in self.outcome.tolist()]

    @property
    def reached(self) -> np.ndarray:
        return self.outcome == OUTCOMES.index("reached")

    def metrics(self, i: int) -> dict:
        """Run ``i``'s metrics with :func:`world.metrics.compute_metrics`'s keys and
        conventions (None for a number that does not exist; no wall time per run)."""

        def number(values):
            v = float(values[i])
            return v if math.isfinite(v) else None

        reached = bool(self.outcome[i] == OUTCOMES.index("reached"))
        return {
            "reached": reached,
            "collided": bool(self.collided[i]),
            "outcome": OUTCOMES[int(self.outcome[i])],
            "time_to_target_s": number(self.time_to_target_s) if reached else None,
            "path_length_m": float(self.path_length_m[i]),
            "mad_m": number(self.mad_m),
            "rmse_m": number(self.rmse_m),
            "min_center_distance_m": number(self.min_center_distance_m),
            "min_clearance_m": number(self.min_clearance_m),
            "max_abs_voltage_v": float(self.max_abs_voltage_v[i]),
            "sim_time_s": float(self.sim_time_s[i]),
            "steps": int(self.steps[i]),
            "voltage_jumps": int(self.voltage_jumps[i]),
            "geometry": self.geometry,
            "min_safety_distance_m": number(self.min_safety_distance_m),
        }


def _wrap(angle: np.ndarray) -> np.ndarray:
    """:func:`world.geometry.wrap_angle_scalar` on arrays, operation for operation."""
    wrapped = np.fmod(angle + _PI, _TWO_PI)
    wrapped = np.where(wrapped < 0.0, wrapped + _TWO_PI, wrapped)
    wrapped = wrapped - _PI
    return np.where(wrapped == -_PI, _PI, wrapped)


def footprint_clearances(x, y, heading, cx, cy, radius, half_length_m, half_width_m):
    """Footprint-to-surface clearance (m) of every obstacle of every run: the arena's
    per-step formula (:meth:`world.arena.Arena._scene`) on (n, M) arrays, negative when
    they overlap. ``x``, ``y``, ``heading`` are (n,); ``cx``, ``cy``, ``radius`` (n, M)."""
    c = np.cos(heading)[:, None]
    s = np.sin(heading)[:, None]
    dx = cx - x[:, None]
    dy = cy - y[:, None]
    qx = np.abs(c * dx + s * dy) - half_length_m
    qy = np.abs(-s * dx + c * dy) - half_width_m
    inside = np.where(qy > qx, qy, qx)
    inside = np.where(0.0 < inside, 0.0, inside)
    outside = np.hypot(np.where(0.0 > qx, 0.0, qx), np.where(0.0 > qy, 0.0, qy))
    return outside + inside - radius


def advance_pose(x, y, heading, forward_speed_m_s, yaw_rate_rad_s, dt_s):
    """The pose after one step, as the arena moves the pymunk body
    (:meth:`world.arena.Arena.step`): the chord of the step's arc along the mid-step
    heading as the velocity, then Chipmunk's ``p + v dt`` and ``a + w dt``."""
    half_turn = 0.5 * yaw_rate_rad_s * dt_s
    with np.errstate(invalid="ignore", divide="ignore"):
        chord_scale = np.where(np.abs(half_turn) > 1e-9, np.sin(half_turn) / half_turn, 1.0)
    speed = forward_speed_m_s * chord_scale
    mid_heading = heading + half_turn
    vx = speed * np.cos(mid_heading)
    vy = speed * np.sin(mid_heading)
    return x + vx * dt_s, y + vy * dt_s, heading + yaw_rate_rad_s * dt_s


def sonar_distances(ox, oy, ux, uy, max_range_m, cx, cy, radius):
    """Echo distance (m, inf = none) of each ray against every circle, by Chipmunk's
    segment query (``cpShapeSegmentQuery``: a ray starting inside a circle hits at 0,
    else ``CircleSegmentQuery``'s quadratic), nearest over the circles.

    ``ox``, ``oy``, ``ux``, ``uy``: (n, B) ray origins and unit directions; ``cx``,
    ``cy``, ``radius``: (n, M) circles (radius NaN for none). Returns (n, B)."""
    ax = ox[:, :, None]
    ay = oy[:, :, None]
    bx = ax + max_range_m * ux[:, :, None]
    by = ay + max_range_m * uy[:, :, None]
    cx = cx[:, None, :]
    cy = cy[:, None, :]
    r = radius[:, None, :]
    dax, day = ax - cx, ay - cy
    dbx, dby = bx - cx, by - cy
    da_da = dax * dax + day * day
    da_db = dax * dbx + day * dby
    db_db = dbx * dbx + dby * dby
    qa = da_da - 2.0 * da_db + db_db
    qb = da_db - da_da
    with np.errstate(invalid="ignore", divide="ignore"):
        det = qb * qb - qa * (da_da - r * r)
        t = (-qb - np.sqrt(det)) / qa
        hit = (det >= 0.0) & (0.0 <= t) & (t <= 1.0)
        alpha = np.where(hit, t, np.inf)
        alpha = np.where(np.sqrt(da_da) - r <= 0.0, 0.0, alpha)  # starts inside: 0
    return alpha.min(axis=2, initial=np.inf) * max_range_m


def _swept_min(
    pose0, v, w, dt, law, radius, t0, half_length_m, half_width_m, path_m
) -> tuple[float, np.ndarray]:
    """:meth:`world.arena.Arena._clearance_along` for one run and obstacle: the
    clearances at the sweep's samples and their instants ``tau``."""
    n = min(SWEEP_MAX_SAMPLES, int(math.ceil(path_m / SWEEP_SPACING_M)) + 2)
    tau = np.linspace(0.0, dt, n)
    x0, y0, h0 = pose0
    heading = h0 + w * tau
    if abs(w) > 1e-12:
        x = x0 + (v / w) * (np.sin(heading) - math.sin(h0))
        y = y0 - (v / w) * (np.cos(heading) - math.cos(h0))
    else:
        x = x0 + v * tau * math.cos(h0)
        y = y0 + v * tau * math.sin(h0)
    px, py, vx, vy, hax, hay = law
    age = t0 + tau
    cx = px + vx * age + hax * age * age
    cy = py + vy * age + hay * age * age
    c, s = np.cos(heading), np.sin(heading)
    dx, dy = cx - x, cy - y
    qx = np.abs(c * dx + s * dy) - half_length_m
    qy = np.abs(-s * dx + c * dy) - half_width_m
    outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
    return outside + np.minimum(np.maximum(qx, qy), 0.0) - radius, tau


class _Active:
    """The per-run arrays of the runs still going; :meth:`keep` drops the ended ones."""

    def __init__(self, **arrays):
        self.names = list(arrays)
        for name, value in arrays.items():
            setattr(self, name, value)

    def keep(self, mask: np.ndarray) -> None:
        for name in self.names:
            setattr(self, name, getattr(self, name)[mask])


def run_batch(
    scenarios: Sequence[Scenario],
    controller: BatchController,
    *,
    perception: str = "ideal",
    geometry: str = "husky",
    control_period_s: float = 0.02,
    seeds: Sequence[int | None] | int | None = None,
    model: HuskyModel | None = None,
    sensor_config: SensorConfig | None = None,
    voltage_limit_v: float = 12.0,
    record_poses: bool = False,
    max_duration_s: float | None = None,
    stall_s: float | None = None,
    trace: bool = False,
) -> BatchResult:
    """Run every scenario to its end in lockstep; their outcomes and metrics.

    Parameters
    ----------
    scenarios : sequence of Scenario
        One run each (start, heading, target, tolerance, obstacles, duration,
        disturbance).
    controller : BatchController
        Decides every active run's wheel voltages each period (module docstring).
    perception : {"ideal", "ultrasonic"}
        As :class:`world.simulation.Simulation`.
    geometry : {"husky", "paper"}
        The Husky's 0.99 x 0.67 m footprint, or the paper's point robot (ideal only).
    control_period_s : float
        The control period and step, s (1 ms to 1 s).
    seeds : int, sequence of int or None, optional
        The sonar noise seed of each run (one int: every run); as ``Simulation(seed=)``.
    model : HuskyModel, optional
        The LG plant (the paper's parameters if omitted).
    sensor_config : SensorConfig, optional
        The sonars (the US-100 defaults if omitted).
    voltage_limit_v : float
        The saturation after the controller, V.
    record_poses : bool
        Keep every run's logged poses (``BatchResult.poses``; for tests and small
        batches: it costs 24 bytes per run and step).
    max_duration_s : float, optional
        Stop every run still going at this time as ``timeout`` (tuning's cap); the
        scenarios' own durations otherwise.
    stall_s : float, optional
        Tuning's early stop (:func:`app.experiments.objective.run_until_stalled`): a run whose
        distance to the target has not reached a new minimum by 5 cm for this many
        seconds ends as ``timeout``, its last step unlogged, as there.
    trace : bool
        Also keep what the paper fit measures (``BatchResult.final_phi_t_rad`` and the
        fields after it).

    Raises
    ------
    ValueError
        An empty batch, a bad period, limit, perception or geometry, a seeds list of
        another length, or a controller that returns voltages of the wrong shape or not
        finite (the run, time and inputs are named).
    """
    started = time.perf_counter()
    scenarios = list(scenarios)
    n_runs = len(scenarios)
    if n_runs == 0:
        raise ValueError("scenarios: the batch is empty")
    check_loop_settings(control_period_s, voltage_limit_v)
    check_geometry(geometry, perception)
    if perception not in ("ideal", "ultrasonic"):
        raise ValueError(f"perception = {perception!r}: must be one of ideal, ultrasonic")
    if seeds is None or isinstance(seeds, (int, np.integer)):
        seeds = [seeds] * n_runs
    seeds = list(seeds)
    if len(seeds) != n_runs:
        raise ValueError(f"seeds has {len(seeds)} entries for {n_runs} scenarios")
    model = model or HuskyModel.default()
    config = sensor_config or SensorConfig()
    dt = float(control_period_s)
    # The rows of the step product the loop uses: the new state, then the step-mean
    # forward speed and yaw rate (a row's sum is the same whatever rows are kept).
    step_rows = np.ascontiguousarray(
        model.discrete(dt).step_matrix[[*range(N_STATES), _V_COLUMN, _W_COLUMN]]
    )
    params = model.parameters
    if geometry == "paper":
        half_length = half_width = 0.0
    else:
        half_length = 0.5 * params.footprint_length_m
        half_width = 0.5 * params.footprint_width_m
    half_diagonal = 0.5 * math.hypot(2.0 * half_length, 2.0 * half_width)
    point_robot = geometry == "paper"
    ultrasonic = perception == "ultrasonic"
    limit = float(voltage_limit_v)

    # -- the batch as arrays --------------------------------------------------------
    n_obstacles = max(len(sc.obstacles) for sc in scenarios)
    m = max(n_obstacles, 1)
    law = np.zeros((6, n_runs, m))  # p0x, p0y, v0x, v0y, a_x / 2, a_y / 2
    radius = np.full((n_runs, m), np.nan)
    for i, sc in enumerate(scenarios):
        for j, o in enumerate(sc.obstacles):
            law[:, i, j] = (
                o.position[0],
                o.position[1],
                o.velocity[0],
                o.velocity[1],
                0.5 * o.acceleration[0],
                0.5 * o.acceleration[1],
            )
            radius[i, j] = o.radius_m
    present = np.isfinite(radius)
    moving = present & ((law[2] != 0.0) | (law[3] != 0.0) | (law[4] != 0.0) | (law[5] != 0.0))
    any_moving = bool(moving.any())
    start = np.array([sc.start for sc in scenarios], dtype=float)
    target = np.array([sc.target for sc in scenarios], dtype=float)
    disturbance = np.array(
        [
            (d.amplitude, d.angular_frequency_rad_s, d.start_s, d.stop_s)
            if (d := sc.disturbance) is not None
            else (0.0, 0.0, math.inf, -math.inf)
            for sc in scenarios
        ],
        dtype=float,
    )
    has_window = np.array([sc.disturbance is not None for sc in scenarios])
    duration = np.array([sc.duration_s for sc in scenarios], dtype=float)
    if max_duration_s is not None:
        duration = np.minimum(duration, float(max_duration_s))
    mount_x = np.array([mt.x_m for mt in config.mounts])
    mount_y = np.array([mt.y_m for mt in config.mounts])
    mount_angle = np.array([mt.angle_rad for mt in config.mounts])
    offsets = np.asarray(config.ray_offsets_rad(), dtype=float)
    n_sensors, n_rays = len(mount_x), len(offsets)
    rngs = (
        [np.random.default_rng(s) for s in seeds] if ultrasonic and config.noise_std_m > 0 else None
    )
    # The farthest any ray reaches from the robot's centre, m (world.sensors' prefilter).
    sonar_reach_m = (
        max(math.hypot(mt.x_m, mt.y_m) for mt in config.mounts) + config.max_range_m + 1e-6
    )

    # -- per-run results (batch order) ----------------------------------------------
    outcome = np.full(n_runs, -1, dtype=np.int64)
    collided = np.zeros(n_runs, dtype=bool)
    sim_time = np.zeros(n_runs)
    steps_done = np.zeros(n_runs, dtype=np.int64)
    path_sum = np.zeros(n_runs)
    dev_abs = np.zeros(n_runs)
    dev_sq = np.zeros(n_runs)
    rows = np.zeros(n_runs, dtype=np.int64)
    min_centre = np.full(n_runs, np.inf)
    min_clear = np.full(n_runs, np.inf)
    max_abs_v = np.zeros(n_runs)
    jumps = np.zeros(n_runs, dtype=np.int64)
    min_target = np.full(n_runs, np.inf)
    final_target = np.full(n_runs, np.nan)
    if trace:
        final_phi_t = np.full(n_runs, np.nan)
        pass_d = np.full((n_runs, m), np.inf)
        pass_t = np.zeros((n_runs, m))
        max_v = np.full((n_runs, 2), -np.inf)
    pose_log: list | None = [] if record_poses else None

    # The ideal path (the start-target segment) of every run, for MAD and RMSE.
    seg = target - start
    seg_len2 = np.einsum("ij,ij->i", seg, seg)

    a = _Active(
        run=np.arange(n_runs),
        x=start[:, 0].copy(),
        y=start[:, 1].copy(),
        h=np.array([float(sc.heading_rad) for sc in scenarios]),
        lg=np.zeros((n_runs, N_STATES)),
        law=law.transpose(1, 0, 2).copy(),  # (n, 6, M)
        radius=radius,
        present=present,
        moving=moving,
        target=target,
        start=start,
        seg=seg,
        seg_len2=seg_len2,
        disturbance=disturbance,
        has_window=has_window,
        # the first time that is the duration (the pymunk loop's test, to the bit)
        timeout_at_s=duration - timeout_slack_s(duration, dt),
        tolerance=np.array([sc.tolerance_m for sc in scenarios], dtype=float),
        # half the field of view of ideal perception (inf: all around)
        half_field=np.array(
            [
                np.inf if sc.field_of_view_rad >= FULL_CIRCLE_RAD else 0.5 * sc.field_of_view_rad
                for sc in scenarios
            ]
        ),
        ranges=np.full((n_runs, n_sensors), np.inf),
        prev_v=np.full((n_runs, 2), np.nan),
        best=np.full(n_runs, np.inf),  # the stall rule's best distance and its time
        best_t=np.zeros(n_runs),
        clear=np.zeros((n_runs, m)),
        cx=np.zeros((n_runs, m)),
        cy=np.zeros((n_runs, m)),
        # Where pymunk's rays see the obstacles: Chipmunk caches a shape's centre when
        # it steps the space, after moving a kinematic body by v dt with the arena's
        # chord velocity, x0 + ((x1 - x0) / dt) dt (the arena then puts the body at x1,
        # but the cached centre stays until the next step): a last bit off the law.
        sx=np.zeros((n_runs, m)),
        sy=np.zeros((n_runs, m)),
    )

    def centres(t: float) -> tuple[np.ndarray, np.ndarray]:
        # Obstacle.law as the arena evaluates it: p0 + v0 tau + (a / 2) tau^2, tau = t.
        lw = a.law
        return (
            lw[:, 0] + lw[:, 2] * t + lw[:, 4] * t * t,
            lw[:, 1] + lw[:, 3] * t + lw[:, 5] * t * t,
        )

    def log_row(rows_mask=None, t_row=0.0) -> None:
        """What one logged row adds to the metrics: position, target distance, centres
        (of the runs ``rows_mask`` selects; all if None)."""
        if rows_mask is not None and not rows_mask.all():
            kept = _Active(
                **{
                    name: getattr(a, name)
                    for name in (
                        "run",
                        "x",
                        "y",
                        "h",
                        "start",
                        "seg",
                        "seg_len2",
                        "present",
                        "cx",
                        "cy",
                        "target",
                        "disturbance",
                    )
                }
            )
            kept.keep(rows_mask)
        else:
            kept = a
        _log_row(kept, t_row)

    def _log_row(a, t_row) -> None:
        run = a.run
        px = a.x - a.start[:, 0]
        py = a.y - a.start[:, 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            along = np.clip((px * a.seg[:, 0] + py * a.seg[:, 1]) / a.seg_len2, 0.0, 1.0)
        along = np.where(a.seg_len2 == 0.0, 0.0, along)
        d = np.hypot(
            a.x - (a.start[:, 0] + along * a.seg[:, 0]), a.y - (a.start[:, 1] + along * a.seg[:, 1])
        )
        dev_abs[run] += np.abs(d)
        dev_sq[run] += d * d
        rows[run] += 1
        to_target = np.hypot(a.target[:, 0] - a.x, a.target[:, 1] - a.y)
        min_target[run] = np.minimum(min_target[run], to_target)
        final_target[run] = to_target
        if m:
            centre = np.hypot(a.cx - a.x[:, None], a.cy - a.y[:, None])
            centre = np.where(a.present, centre, np.inf)
            min_centre[run] = np.minimum(min_centre[run], centre.min(axis=1))
            if trace:  # paper_fit.closest_approaches: the first least distance
                closer = centre < pass_d[run]
                pass_d[run] = np.where(closer, centre, pass_d[run])
                pass_t[run] = np.where(closer, t_row, pass_t[run])
        if trace:  # the row's phi_t input as sensed then, disturbance included
            phi_t = _wrap(np.arctan2(a.target[:, 1] - a.y, a.target[:, 0] - a.x) - a.h)
            amp, omega, d_start, d_stop = a.disturbance.T
            on = (d_start <= t_row) & (t_row < d_stop)
            value = np.where(on, amp * np.sin(omega * t_row), 0.0)
            final_phi_t[run] = np.where(value != 0.0, phi_t + value, phi_t)
        if pose_log is not None:
            pose_log.append((run.copy(), np.stack([a.x, a.y, a.h], axis=1)))

    t = 0.0
    a.cx, a.cy = centres(t)
    a.sx, a.sy = a.cx, a.cy
    a.clear = footprint_clearances(a.x, a.y, a.h, a.cx, a.cy, a.radius, half_length, half_width)
    log_row()
    next_update_s = -math.inf
    update_period_s = 1.0 / config.update_rate_hz

    while a.run.size:
        n = a.run.size
        # -- sense --------------------------------------------------------------
        dx = a.target[:, 0] - a.x
        dy = a.target[:, 1] - a.y
        d_t = np.hypot(dx, dy)
        phi_t = _wrap(np.arctan2(dy, dx) - a.h)
        if ultrasonic and not t + 1e-12 < next_update_s:
            following = next_update_s + update_period_s
            next_update_s = following if following > t else t + update_period_s
            # Only the obstacles within a ray's reach of the robot (a conservative
            # test, as the pymunk sensors' prefilter): the readings of casting all.
            dxr = a.sx - a.x[:, None]
            dyr = a.sy - a.y[:, None]
            within = sonar_reach_m + a.radius
            near = a.present & (dxr * dxr + dyr * dyr <= within * within)
            ranges = np.full((n, n_sensors), np.inf)
            pair_rows, pair_cols = np.nonzero(near)
            if pair_rows.size:
                starts = np.flatnonzero(np.r_[True, pair_rows[1:] != pair_rows[:-1]])
                seen_rows = pair_rows[starts]
                pair_row = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, pair_rows.size]))
                h = a.h[seen_rows]
                c, s = np.cos(h)[:, None], np.sin(h)[:, None]
                ox = a.x[seen_rows, None] + c * mount_x - s * mount_y  # (pair_rows, sensors)
                oy = a.y[seen_rows, None] + s * mount_x + c * mount_y
                direction = h[:, None] + mount_angle
                ray = (direction[:, :, None] + offsets).reshape(-1, n_sensors * n_rays)
                hits = sonar_distances(
                    np.repeat(ox, n_rays, axis=1)[pair_row],
                    np.repeat(oy, n_rays, axis=1)[pair_row],
                    np.cos(ray)[pair_row],
                    np.sin(ray)[pair_row],
                    config.max_range_m,
                    a.sx[pair_rows, pair_cols][:, None],
                    a.sy[pair_rows, pair_cols][:, None],
                    a.radius[pair_rows, pair_cols][:, None],
                ).reshape(pair_rows.size, n_sensors, n_rays)
                ranges[seen_rows] = np.minimum.reduceat(hits.min(axis=2), starts, axis=0)
            echo = np.isfinite(ranges)
            if rngs is not None:
                for row in np.flatnonzero(echo.any(axis=1)).tolist():
                    rng = rngs[a.run[row]]
                    for k in np.flatnonzero(echo[row]).tolist():
                        ranges[row, k] += rng.normal(0.0, config.noise_std_m)
            low, high = config.min_range_m, config.max_range_m
            clamped = np.where(low > ranges, low, ranges)
            clamped = np.where(high < clamped, high, clamped)
            a.ranges = np.where(echo, clamped, np.inf)
        if ultrasonic:
            k = np.argmin(a.ranges, axis=1)
            nearest = a.ranges[np.arange(n), k]
            seen = nearest <= OBSTACLE_CUTOFF_M
            d_o = np.where(seen, nearest, np.nan)
            phi_o = np.where(seen, mount_angle[k], np.nan)
        else:
            clear = np.where(a.present, a.clear, np.inf)
            if point_robot:
                clear = clear + np.where(a.present, a.radius, 0.0)  # Eq. 8, centre to centre
            limited = np.isfinite(a.half_field)
            if limited.any():  # as Perception: obstacles outside the field are not sensed
                bearings = _wrap(
                    np.arctan2(a.cy - a.y[:, None], a.cx - a.x[:, None]) - a.h[:, None]
                )
                outside = limited[:, None] & (np.abs(bearings) > a.half_field[:, None])
                clear = np.where(outside, np.inf, clear)
            k = np.argmin(clear, axis=1)
            rows_n = np.arange(n)
            nearest = clear[rows_n, k]
            nearest = np.where(0.0 > nearest, 0.0, nearest)
            seen = ~(nearest > OBSTACLE_CUTOFF_M)
            d_o = np.where(seen, nearest, np.nan)
            bearing = np.arctan2(a.cy[rows_n, k] - a.y, a.cx[rows_n, k] - a.x) - a.h
            phi_o = np.where(seen, _wrap(bearing), np.nan)
        inputs = np.stack([d_t, d_o, phi_t, phi_o], axis=1)
        amp, omega, d_start, d_stop = a.disturbance.T
        window = (d_start <= t) & (t < d_stop)
        if window.any():
            value = np.where(window, amp * np.sin(omega * t), 0.0)
            inputs = np.where((value != 0.0)[:, None], inputs + value[:, None], inputs)

        # -- decide, saturate ---------------------------------------------------------
        raw = np.asarray(controller.decide(inputs, a.run, a.ranges), dtype=float)
        if raw.shape != (n, 2):
            raise ValueError(
                f"the batch controller returned voltages of shape {raw.shape} for {n} "
                "runs; it must return (n, 2): left, right"
            )
        bad = ~np.isfinite(raw).all(axis=1)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"controller returned non-finite voltages {raw[row].tolist()} for inputs "
                f"{inputs[row].tolist()} at t = {t:.3f} s (run {int(a.run[row])})"
            )
        volts = np.where(-limit > raw, -limit, raw)
        volts = np.where(limit < volts, limit, volts)
        run = a.run
        max_abs_v[run] = np.maximum(max_abs_v[run], np.abs(volts).max(axis=1))
        if trace:
            max_v[run] = np.maximum(max_v[run], volts)
        jump = (np.abs(volts - a.prev_v) > VOLTAGE_JUMP_V).any(axis=1)
        in_window = a.has_window & (d_start <= t) & (t <= d_stop)
        jumps[run] += jump & ~in_window
        a.prev_v = volts

        # -- plant and motion -----------------------------------------------------
        # the pymunk engine's product (world.husky.step_product): the same bits, in a
        # batch of any size
        product = step_product(step_rows, np.concatenate([a.lg, volts], axis=1))
        a.lg = product[:, :N_STATES]
        v = product[:, N_STATES]
        w = product[:, N_STATES + 1]
        pose0 = (a.x, a.y, a.h)
        c0 = a.clear
        a.x, a.y, a.h = advance_pose(a.x, a.y, a.h, v, w, dt)
        t0, t = t, t + dt
        if any_moving:
            x0, y0 = a.cx, a.cy
            a.cx, a.cy = centres(t)
            if ultrasonic:
                a.sx = np.where(a.moving, x0 + ((a.cx - x0) / dt) * dt, a.cx)
                a.sy = np.where(a.moving, y0 + ((a.cy - y0) / dt) * dt, a.cy)
        a.clear = footprint_clearances(a.x, a.y, a.h, a.cx, a.cy, a.radius, half_length, half_width)

        # -- contacts: at the step's end (pymunk), then swept between the ends ---------
        if point_robot:
            reach = a.radius + POINT_ROBOT_RADIUS_M
            ddx, ddy = a.cx - a.x[:, None], a.cy - a.y[:, None]
            contact = a.present & (ddx * ddx + ddy * ddy < reach * reach)
        else:
            contact = a.present & (a.clear <= 0.0)
        robot_path = (np.abs(v) + np.abs(w) * half_diagonal) * dt
        path = np.broadcast_to(robot_path[:, None], c0.shape)
        if any_moving:
            lw = a.law
            speed = np.hypot(lw[:, 2] + 2.0 * lw[:, 4] * t0, lw[:, 3] + 2.0 * lw[:, 5] * t0)
            obstacle_path = speed * dt + np.hypot(lw[:, 4], lw[:, 5]) * dt * dt
            path = np.where(a.moving, path + obstacle_path, path)
        low = np.minimum(c0, a.clear)
        # the arena's swept minimum takes both ends of every step (the logged rows too)
        min_clear[a.run] = np.minimum(
            min_clear[a.run], np.where(a.present, low, np.inf).min(axis=1)
        )
        bound = 0.5 * (c0 + a.clear - path)
        swept = a.present & ~((bound >= low - SWEEP_TOLERANCE_M) | (bound >= SWEEP_RELEVANT_M))
        if swept.any():
            for row, j in zip(*np.nonzero(swept)):
                samples, _ = _swept_min(
                    (float(pose0[0][row]), float(pose0[1][row]), float(pose0[2][row])),
                    float(v[row]),
                    float(w[row]),
                    dt,
                    a.law[row, :, j].tolist(),
                    float(a.radius[row, j]),
                    t0,
                    half_length,
                    half_width,
                    float(path[row, j]),
                )
                smallest = float(samples.min())
                r_run = a.run[row]
                min_clear[r_run] = min(min_clear[r_run], smallest)
                if c0[row, j] > 0.0 and not contact[row, j] and smallest <= 0.0:
                    contact[row, j] = True
        hit = contact.any(axis=1)
        collided[a.run] |= hit

        # -- the logged row after the step, and the ends ------------------------------
        to_target = np.hypot(a.target[:, 0] - a.x, a.target[:, 1] - a.y)
        reached = to_target <= a.tolerance
        timeout = t >= a.timeout_at_s
        ended = reached | hit | timeout
        if stall_s is not None:
            # run_until_stalled, after every step (the last one too): a new best by
            # 5 cm, or a stall that ends the run as a timeout
            better = to_target < a.best - 0.05
            stalled = ~better & (t - a.best_t > stall_s)
            a.best = np.where(better, to_target, a.best)
            a.best_t = np.where(better, t, a.best_t)
            cut = stalled & ~ended  # stopped before its end: the step is not logged
        else:
            stalled = cut = np.zeros(len(ended), dtype=bool)
        logged = ~cut
        steps_done[a.run] += 1
        steps_done[a.run[cut]] -= 1
        moved = np.hypot(a.x - pose0[0], a.y - pose0[1])
        path_sum[a.run] += np.where(logged, moved, 0.0)
        log_row(logged, t)
        ended |= stalled
        if ended.any():
            code = np.where(stalled, 2, np.where(reached, 0, np.where(hit, 1, 2)))
            finished = a.run[ended]
            outcome[finished] = code[ended]
            sim_time[finished] = np.where(cut, t0, t)[ended]
            a.keep(~ended)

    n_rows = np.maximum(rows, 1)
    mad = dev_abs / n_rows
    rmse = np.sqrt(dev_sq / n_rows)
    min_centre = np.where(np.isfinite(min_centre), min_centre, np.nan)
    min_clear = np.where(np.isfinite(min_clear), min_clear, np.nan)
    reached_mask = outcome == 0
    poses = None
    if pose_log is not None:
        per_run: list[list] = [[] for _ in range(n_runs)]
        for runs, block in pose_log:
            for r, p in zip(runs.tolist(), block):
                per_run[r].append(p)
        poses = [np.array(p) for p in per_run]
    return BatchResult(
        outcome=outcome,
        collided=collided,
        time_to_target_s=np.where(reached_mask, sim_time, np.nan),
        sim_time_s=sim_time,
        steps=steps_done,
        path_length_m=path_sum,
        mad_m=mad,
        rmse_m=rmse,
        min_center_distance_m=min_centre,
        min_clearance_m=min_clear,
        min_safety_distance_m=min_centre if point_robot else min_clear,
        max_abs_voltage_v=max_abs_v,
        voltage_jumps=jumps,
        min_target_distance_m=min_target,
        final_target_distance_m=final_target,
        final_phi_t_rad=final_phi_t if trace else None,
        closest_center_distance_m=pass_d if trace else None,
        closest_center_time_s=pass_t if trace else None,
        max_voltage_v=max_v if trace else None,
        geometry=geometry,
        perception=perception,
        wall_time_s=time.perf_counter() - started,
        poses=poses,
        scenarios=scenarios,
    )
