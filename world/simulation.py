"""The closed loop: sense, decide, saturate, step the LG plant and the pymunk world.

Every control period (20 ms by default) the simulation

1. reads the sensors and forms the controller's inputs ``(d_t, d_o, phi_t, phi_o)``
   (see :mod:`world.perception`), adding the scenario's disturbance if one is active;
2. asks the controller for two wheel voltages ``(v_s1 left, v_s2 right)`` and clips them
   to +-``voltage_limit_v`` (the paper's 12 V saturation block);
3. advances the LG state exactly over the period (zero-order hold) and moves the pymunk
   body with the exact mean forward speed and yaw rate over the period;
4. logs the row and ends the run on arrival, collision or timeout.

A controller is any object with ``reset()`` and ``__call__(inputs) -> voltages`` where
``inputs`` is a float array (4,) and ``voltages`` any sequence of two floats. A
controller that sets ``needs_ranges = True`` is called as
``controller(inputs, ranges_m=ranges)`` with the three sensor readings (m, inf = none).
The world never imports a controller: it only calls what it is given.

Row ``k`` of the log holds the state at ``time_s[k]``, the inputs sensed then and the
voltages applied from then to ``time_s[k + 1]``; the last row is the final state, with
NaN voltages because no decision follows it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from world.arena import Arena, Collision
from world.husky import HuskyModel
from world.metrics import compute_metrics
from world.perception import Perception
from world.scenario import Scenario
from world.sensors import RangeSensorArray, SensorConfig

OUTCOMES = ("reached", "collided", "timeout")


@dataclass
class SimulationLog:
    """Per-step arrays of one run (see the module docstring for the row convention)."""

    time_s: np.ndarray            # (N,)
    pose: np.ndarray              # (N, 3): x m, y m, heading rad (continuous, not wrapped)
    lg_state: np.ndarray          # (N, 6): w_LW, w_RW, v_MH, w_JH, i_L1, i_L2
    inputs: np.ndarray            # (N, 4): d_t, d_o, phi_t, phi_o as the controller saw them
    disturbance: np.ndarray       # (N,): the value added to every input
    controller_output_v: np.ndarray  # (N, 2): left, right before saturation
    voltages_v: np.ndarray        # (N, 2): left, right as applied
    ranges_m: np.ndarray          # (N, 3): left, front, right sensor readings
    target_xy: np.ndarray         # (N, 2)
    obstacle_xy: np.ndarray       # (N, n_obstacles, 2); NaN while an obstacle is absent
    obstacle_radii_m: np.ndarray  # (n_obstacles,)
    obstacle_ids: list[int]
    center_distance_m: np.ndarray  # (N, n_obstacles): robot centre to obstacle centre
    clearance_m: np.ndarray       # (N, n_obstacles): footprint to obstacle surface

    def __len__(self) -> int:
        return len(self.time_s)


@dataclass
class SimulationResult:
    scenario: Scenario
    outcome: str
    log: SimulationLog
    collisions: list[Collision]
    wall_time_s: float
    seed: int | None
    perception: str
    control_period_s: float
    metrics: dict = field(default_factory=dict)

    @property
    def reached(self) -> bool:
        return self.outcome == "reached"

    @property
    def collided(self) -> bool:
        return bool(self.collisions)


class _LogBuffer:
    """Growable per-step arrays; obstacles may be added while the simulation runs.

    The per-step floats live in one wide matrix, so a row is written with a single
    assignment (the loop is dominated by per-call overheads, not by arithmetic).
    """

    _FIELDS = {"time_s": 1, "pose": 3, "lg_state": 6, "inputs": 4, "disturbance": 1,
               "controller_output_v": 2, "voltages_v": 2, "ranges_m": 3, "target_xy": 2}

    def __init__(self, capacity: int):
        self.n = 0
        self.capacity = max(capacity, 16)
        self.width = sum(self._FIELDS.values())
        self.rows = np.full((self.capacity, self.width), np.nan)
        self.obstacle_ids: list[int] = []
        self.obstacle_radii: list[float] = []
        # Per obstacle column: x, y, centre distance, clearance.
        self.obstacles = np.full((self.capacity, 0, 4), np.nan)
        self._columns_key: tuple = ()
        self._columns = np.zeros(0, dtype=int)

    def _grow(self) -> None:
        self.capacity *= 2
        self.rows = np.concatenate([self.rows, np.full_like(self.rows, np.nan)])
        self.obstacles = np.concatenate([self.obstacles, np.full_like(self.obstacles, np.nan)])

    def _columns_for(self, ids: list[int], radii) -> np.ndarray:
        key = tuple(ids)
        if key != self._columns_key:
            for obstacle_id, radius in zip(ids, radii):
                if obstacle_id not in self.obstacle_ids:
                    self.obstacle_ids.append(obstacle_id)
                    self.obstacle_radii.append(float(radius))
                    self.obstacles = np.concatenate(
                        [self.obstacles, np.full((self.capacity, 1, 4), np.nan)], axis=1)
            self._columns = np.array([self.obstacle_ids.index(i) for i in ids], dtype=int)
            self._columns_key = key
        return self._columns

    def append(self, row: list[float], ids, centres, radii, center_distance, clearance) -> None:
        if self.n == self.capacity:
            self._grow()
        i = self.n
        self.rows[i] = row
        if ids:
            cols = self._columns_for(ids, radii)
            block = self.obstacles[i]
            block[cols, 0:2] = centres
            block[cols, 2] = center_distance
            block[cols, 3] = clearance
        self.n += 1

    def freeze(self) -> SimulationLog:
        n = self.n
        fields, start = {}, 0
        for name, width in self._FIELDS.items():
            column = self.rows[:n, start:start + width]
            fields[name] = column[:, 0].copy() if name in ("time_s", "disturbance") else column.copy()
            start += width
        return SimulationLog(
            **fields,
            obstacle_xy=self.obstacles[:n, :, 0:2].copy(),
            obstacle_radii_m=np.asarray(self.obstacle_radii, dtype=float),
            obstacle_ids=list(self.obstacle_ids),
            center_distance_m=self.obstacles[:n, :, 2].copy(),
            clearance_m=self.obstacles[:n, :, 3].copy(),
        )


class Simulation:
    """One robot, one scenario, one controller; reproducible from ``seed``.

    Parameters
    ----------
    scenario : Scenario
        Start pose, target, obstacles, duration and disturbance.
    controller
        See the module docstring for the protocol.
    perception : {"ideal", "ultrasonic"}
        How the obstacle inputs are formed (:mod:`world.perception`).
    control_period_s : float
        Sampling period of the controller and step of plant and world (ZOH is exact, so
        the plant is accurate at any period).
    seed : int or None
        Seeds the sensor noise.
    model : HuskyModel, optional
        The LG plant; ``HuskyModel.default()`` (the paper's parameters) if omitted.
    sensor_config : SensorConfig, optional
    voltage_limit_v : float
        Saturation after the controller (the paper's 12 V).
    stop_on_collision : bool
        End the run as ``collided`` at the first contact (default); otherwise contacts are
        recorded and the run goes on.
    """

    def __init__(self, scenario: Scenario, controller, *, perception: str = "ideal",
                 control_period_s: float = 0.02, seed: int | None = None,
                 model: HuskyModel | None = None, sensor_config: SensorConfig | None = None,
                 voltage_limit_v: float = 12.0, stop_on_collision: bool = True):
        if not (math.isfinite(control_period_s) and control_period_s > 0):
            raise ValueError(f"control_period_s = {control_period_s!r}: must be positive")
        if not (math.isfinite(voltage_limit_v) and voltage_limit_v > 0):
            raise ValueError(f"voltage_limit_v = {voltage_limit_v!r}: must be positive")
        self.scenario = scenario
        self.controller = controller
        self.control_period_s = float(control_period_s)
        self.model = model or HuskyModel.default()
        params = self.model.parameters
        self.arena = Arena((params.footprint_length_m, params.footprint_width_m),
                           params.hull_mass_kg, params.hull_inertia_kg_m2)
        self.sensors = RangeSensorArray(sensor_config)
        self.perception = Perception(perception, self.sensors)
        self.voltage_limit_v = float(voltage_limit_v)
        self.stop_on_collision = stop_on_collision
        self.disturbance = scenario.disturbance
        self.reset(seed)

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self, seed: int | None = None, scenario: Scenario | None = None) -> None:
        """Back to the scenario's start (optionally a new scenario), same seed if None."""
        if scenario is not None:
            self.scenario = scenario
            self.disturbance = scenario.disturbance
        if seed is not None or not hasattr(self, "seed"):
            self.seed = seed
        sc = self.scenario
        self.arena.reset(sc.start, sc.heading_rad, sc.target, sc.obstacles)
        self.sensors.reset(self.seed)
        self.controller.reset()
        self.x = np.zeros(6)
        self.outcome: str | None = None
        self._wall_time_s = 0.0
        capacity = int(math.ceil(sc.duration_s / self.control_period_s)) + 2
        self._log = _LogBuffer(capacity)
        self._pending: dict | None = None

    @property
    def time_s(self) -> float:
        return self.arena.time_s

    @property
    def done(self) -> bool:
        return self.outcome is not None

    @property
    def log(self) -> SimulationLog:
        return self._log.freeze()

    # -- one control period ------------------------------------------------------------

    def sense(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The controller's inputs now (with disturbance), the ranges, the disturbance."""
        inputs, ranges = self.perception.inputs(self.arena, self.time_s)
        disturbance = self.disturbance.value(self.time_s) if self.disturbance else 0.0
        if disturbance:
            inputs = inputs + disturbance  # NaN (nothing detected) stays NaN
        return inputs, ranges, disturbance

    def decide(self, inputs: np.ndarray, ranges: np.ndarray) -> np.ndarray:
        if getattr(self.controller, "needs_ranges", False):
            raw = self.controller(inputs, ranges_m=ranges)
        else:
            raw = self.controller(inputs)
        raw = np.asarray(raw, dtype=float).reshape(2)
        if not np.all(np.isfinite(raw)):
            raise ValueError(f"controller returned non-finite voltages {raw.tolist()} "
                             f"for inputs {inputs.tolist()} at t = {self.time_s:.3f} s")
        return raw

    def step(self) -> str | None:
        """Advance one control period; returns the outcome once the run has ended."""
        if self.done:
            return self.outcome
        started = time.perf_counter()
        inputs, ranges, disturbance = self.sense()
        raw = self.decide(inputs, ranges)
        limit = self.voltage_limit_v
        voltages = np.clip(raw, -limit, limit)
        self._record(inputs, ranges, disturbance, raw, voltages)

        dt = self.control_period_s
        self.x, x_mean = self.model.step(self.x, voltages, dt)
        new_contacts = self.arena.step(float(x_mean[2]), float(x_mean[3]), dt)

        pose = self.arena.pose
        target = self.arena.target
        if math.hypot(target[0] - pose[0], target[1] - pose[1]) <= self.scenario.tolerance_m:
            self.outcome = "reached"
        elif new_contacts and self.stop_on_collision:
            self.outcome = "collided"
        elif self.time_s >= self.scenario.duration_s - 1e-9:
            self.outcome = "timeout"
        if self.outcome is not None:
            inputs, ranges, disturbance = self.sense()
            nan2 = np.full(2, np.nan)
            self._record(inputs, ranges, disturbance, nan2, nan2)
        self._wall_time_s += time.perf_counter() - started
        return self.outcome

    def _record(self, inputs, ranges, disturbance, raw, voltages) -> None:
        centres, radii, ids = self.arena.obstacle_arrays()
        x, y, heading = self.arena.pose
        centre_distance = np.hypot(centres[:, 0] - x, centres[:, 1] - y)
        # Same order as _LogBuffer._FIELDS.
        row = [self.time_s, x, y, heading, *self.x.tolist(), *inputs.tolist(), disturbance,
               *raw.tolist(), *voltages.tolist(), *ranges.tolist(), *self.arena.target.tolist()]
        self._log.append(row, ids, centres, radii, centre_distance, self.arena.clearances())

    # -- whole runs --------------------------------------------------------------------

    def run(self, progress=None) -> SimulationResult:
        """Run to the end; ``progress(time_s)`` is called now and then if given."""
        every = max(1, int(1.0 / self.control_period_s))
        steps = 0
        while not self.done:
            self.step()
            steps += 1
            if progress is not None and steps % every == 0:
                progress(self.time_s)
        return self.result()

    def result(self) -> SimulationResult:
        log = self.log
        result = SimulationResult(
            scenario=self.scenario, outcome=self.outcome or "running", log=log,
            collisions=list(self.arena.collisions), wall_time_s=self._wall_time_s,
            seed=self.seed, perception=self.perception.mode,
            control_period_s=self.control_period_s)
        result.metrics = compute_metrics(result)
        return result
