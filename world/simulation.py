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
``controller(inputs, ranges_m=ranges)`` with the three sensor readings (m, inf = none);
one that sets ``needs_context = True`` as ``controller(inputs, context=...)`` with the
world as the simulation knows it (:class:`world.perception.ControlContext`). One that declares ``needs_robot`` or ``needs_sensor_mounts`` is told the robot
(:attr:`Simulation.robot`) or its sonars before each start (:func:`world.robot.brief`).
The world never imports a controller: it only calls what it is given.

Row ``k`` of the log holds the state at ``time_s[k]``, the inputs sensed then and the
voltages applied from then to ``time_s[k + 1]``; the last row is the final state, with
NaN voltages because no decision follows it.

The loop works on plain floats (only the controller's ``inputs`` and the plant's
``[x; u]`` are arrays) and writes log rows in blocks: docs/speed.md has its numbers.

The bounds of a run and its outcomes are :mod:`world.run_limits`'s, the log and its
spool :mod:`world.sim_log`'s; their public names are imported here too, so that
``fuzzynav.world.simulation`` still offers them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from fuzzynav.world import perception as _perception
from fuzzynav.world.arena import Arena, Collision
from fuzzynav.world.husky import HuskyModel
from fuzzynav.world.metrics import compute_metrics
from fuzzynav.world.robot import HUSKY, brief
from fuzzynav.world.run_limits import MAX_CONTROL_PERIOD_S as MAX_CONTROL_PERIOD_S
from fuzzynav.world.run_limits import MAX_STEPS as MAX_STEPS
from fuzzynav.world.run_limits import MEMORY_BUDGET_BYTES as MEMORY_BUDGET_BYTES
from fuzzynav.world.run_limits import MIN_CONTROL_PERIOD_S as MIN_CONTROL_PERIOD_S
from fuzzynav.world.run_limits import OUTCOMES as OUTCOMES
from fuzzynav.world.run_limits import TIMEOUT_SLACK_S as TIMEOUT_SLACK_S
from fuzzynav.world.run_limits import Outcome as Outcome
from fuzzynav.world.run_limits import check_loop_settings as check_loop_settings
from fuzzynav.world.run_limits import check_run_size as check_run_size
from fuzzynav.world.run_limits import log_bytes as log_bytes
from fuzzynav.world.run_limits import run_ending, wheel_voltages
from fuzzynav.world.run_limits import timeout_slack_s as timeout_slack_s
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.sensors import RangeSensorArray, SensorConfig
from fuzzynav.world.sim_log import LOG_BLOCK_BYTES as LOG_BLOCK_BYTES
from fuzzynav.world.sim_log import SimulationLog as SimulationLog
from fuzzynav.world.sim_log import _LogBuffer, log_block_rows

_FLOAT64 = np.dtype(np.float64)


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
    geometry: str = "husky"
    #: The true minimum footprint clearance over the run, swept between the steps
    #: (:meth:`world.arena.Arena._sweep`); the log holds it at the steps only.
    swept_min_clearance_m: float | None = None

    @property
    def reached(self) -> bool:
        return self.outcome == "reached"

    @property
    def collided(self) -> bool:
        return bool(self.collisions)


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
    voltage_limit_v : float, optional
        Saturation after the controller (default the robot's: the paper's 12 V).
    stop_on_collision : bool
        End the run as ``collided`` at the first contact (default); otherwise contacts are
        recorded and the run goes on.
    geometry : {"husky", "paper"}
        ``husky`` (default): the plant's footprint (husky.toml) collides and senses.
        ``paper``: the paper's point robot; its inputs are Eqs. 7-12 centre to centre
        (:mod:`world.perception`), it collides when its centre enters an obstacle's disc,
        and its logged clearance is centre to surface. Ideal perception only.
    """

    def __init__(
        self,
        scenario: Scenario,
        controller,
        *,
        perception: str = "ideal",
        control_period_s: float = 0.02,
        seed: int | None = None,
        model: HuskyModel | None = None,
        sensor_config: SensorConfig | None = None,
        voltage_limit_v: float | None = None,
        stop_on_collision: bool = True,
        geometry: str = "husky",
    ):
        voltage_limit_v = HUSKY.voltage_limit_v if voltage_limit_v is None else voltage_limit_v
        check_loop_settings(control_period_s, voltage_limit_v)
        _perception.check_controller(controller)
        self.scenario = scenario
        self.controller = controller
        self.control_period_s = float(control_period_s)
        self.model = model or HuskyModel.default()
        params = self.model.parameters
        _perception.check_geometry(geometry, perception)
        self.geometry = geometry
        footprint = (
            (0.0, 0.0)
            if geometry == "paper"
            else (params.footprint_length_m, params.footprint_width_m)
        )
        self.arena = Arena(
            footprint,
            params.hull_mass_kg,
            params.hull_inertia_kg_m2,
        )
        self.sensors = RangeSensorArray(sensor_config)
        self.robot = HUSKY.with_parameters(params, self.sensors.config.mounts, voltage_limit_v)
        self.perception = _perception.Perception(
            perception,
            self.sensors,
            geometry=geometry,
            field_of_view_rad=scenario.field_of_view_rad,
        )
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
        # The field of view is the scenario's (its robot's sensors), so it follows it.
        self.perception.set_field_of_view(sc.field_of_view_rad)
        self._timeout_at_s = sc.duration_s - float(
            timeout_slack_s(sc.duration_s, self.control_period_s)
        )
        self.arena.reset(sc.start, sc.heading_rad, sc.target, sc.obstacles)
        self.sensors.reset(self.seed)
        brief(self.controller, self.robot.with_mounts(self.sensors.config.mounts))
        self.controller.reset()
        self.x = np.zeros(6)
        self.outcome: str | None = None
        self._wall_time_s = 0.0
        # The log is sized for the whole run up to a block (LOG_BLOCK_BYTES); a longer
        # run's earlier blocks go to the disk, so memory does not grow with the length.
        capacity = int(math.ceil(min(sc.duration_s, 3600.0) / self.control_period_s)) + 2
        self._log = _LogBuffer(
            capacity, log_block_rows(len(sc.obstacles)), len(self.sensors.config.mounts)
        )
        self._pending: dict | None = None

    @property
    def time_s(self) -> float:
        return self.arena.time_s

    @property
    def done(self) -> bool:
        return self.outcome is not None

    @property
    def log(self) -> SimulationLog:
        """The log so far (a copy: the caller's to keep)."""
        return self._log.freeze()

    def log_view(self) -> SimulationLog:
        """The log so far without copying it: valid until the next :meth:`step` (for
        readers of the new rows now and then, such as a live recording)."""
        return self._log.view()

    # -- one control period ------------------------------------------------------------

    def sense(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The controller's inputs now (with disturbance), the ranges, the disturbance."""
        d_t, d_o, phi_t, phi_o, ranges, _, disturbance = self._sense(None)
        return np.array((d_t, d_o, phi_t, phi_o)), ranges, disturbance

    def _sense(self, target_xy):
        """:meth:`sense` as floats: ``(d_t, d_o, phi_t, phi_o, ranges, ranges list,
        disturbance)``."""
        perception = self.perception
        time_s = self.arena.time_s
        fast = getattr(perception, "_sense", None)
        if fast is not None:
            d_t, d_o, phi_t, phi_o, ranges, ranges_list = fast(self.arena, time_s, target_xy)
        else:  # any object with Perception.inputs()
            inputs, ranges = perception.inputs(self.arena, time_s)
            d_t, d_o, phi_t, phi_o = np.asarray(inputs, dtype=float).reshape(4).tolist()
            ranges_list = np.asarray(ranges, dtype=float).tolist()
        disturbance = self.disturbance.value(time_s) if self.disturbance else 0.0
        if disturbance:  # NaN (nothing detected) stays NaN
            d_t += disturbance
            d_o += disturbance
            phi_t += disturbance
            phi_o += disturbance
        return d_t, d_o, phi_t, phi_o, ranges, ranges_list, disturbance

    def decide(self, inputs: np.ndarray, ranges: np.ndarray) -> np.ndarray:
        return np.array(self._decide(inputs, ranges))

    def _decide(self, inputs: np.ndarray, ranges: np.ndarray) -> tuple[float, float]:
        """The controller's two voltages as floats, checked finite."""
        controller = self.controller
        if getattr(controller, "needs_context", False):  # controller/interface.py
            context = _perception.control_context(self.arena, self.control_period_s, ranges)
            raw = controller(inputs, context=context)
        elif getattr(controller, "needs_ranges", False):
            raw = controller(inputs, ranges_m=ranges)
        else:
            raw = controller(inputs)
        if type(raw) is np.ndarray and raw.dtype is _FLOAT64 and raw.shape == (2,):
            left, right = raw.tolist()
        else:
            left, right = wheel_voltages(raw, controller)
        if not (math.isfinite(left) and math.isfinite(right)):
            raise ValueError(
                f"controller returned non-finite voltages {[left, right]} "
                f"for inputs {inputs.tolist()} at t = {self.time_s:.3f} s"
            )
        return left, right

    def step(self) -> str | None:
        """Advance one control period; returns the outcome once the run has ended."""
        if self.outcome is not None:
            return self.outcome
        started = time.perf_counter()
        arena = self.arena
        target = arena.target
        target_xy = target.tolist() if type(target) is np.ndarray else [float(v) for v in target]
        d_t, d_o, phi_t, phi_o, ranges, ranges_list, disturbance = self._sense(target_xy)
        inputs = np.array((d_t, d_o, phi_t, phi_o))
        left, right = self._decide(inputs, ranges)
        # The saturation block, np.clip(raw, -limit, limit) on two finite floats.
        limit = self.voltage_limit_v
        v_left = min(max(left, -limit), limit)
        v_right = min(max(right, -limit), limit)
        x_list = self._state_list()
        self._record(
            x_list,
            d_t,
            d_o,
            phi_t,
            phi_o,
            ranges_list,
            disturbance,
            left,
            right,
            v_left,
            v_right,
            target_xy,
        )

        dt = self.control_period_s
        forward_speed, yaw_rate = self._advance_plant(v_left, v_right, dt)
        new_contacts = arena.step(forward_speed, yaw_rate, dt)

        x, y, _ = arena._pose
        ending = run_ending(
            math.hypot(target_xy[0] - x, target_xy[1] - y),
            self.scenario.tolerance_m,
            bool(new_contacts) and self.stop_on_collision,
            arena.time_s,
            self._timeout_at_s,
        )
        if ending >= 0:
            self.outcome = OUTCOMES[ending]
        if self.outcome is not None:
            d_t, d_o, phi_t, phi_o, _, ranges_list, disturbance = self._sense(None)
            nan = math.nan
            self._record(
                self._state_list(),
                d_t,
                d_o,
                phi_t,
                phi_o,
                ranges_list,
                disturbance,
                nan,
                nan,
                nan,
                nan,
                None,
            )
        self._wall_time_s += time.perf_counter() - started
        return self.outcome

    def _state_list(self) -> list[float]:
        """``self.x`` as floats, read afresh (it may have been set or edited in place)."""
        x = self.x
        if type(x) is np.ndarray and x.dtype is _FLOAT64:
            return x.tolist()
        return np.asarray(x, dtype=float).reshape(-1).tolist()

    def _advance_plant(self, v_left: float, v_right: float, dt: float) -> tuple[float, float]:
        """One plant step with the voltages held over ``dt`` (:meth:`HuskyModel.step`):
        sets ``self.x``, returns the step-mean forward speed and yaw rate."""
        self.x, x_mean = self.model.step(self.x, np.array((v_left, v_right)), dt)
        return float(x_mean[2]), float(x_mean[3])

    def _record(
        self,
        x_list,
        d_t,
        d_o,
        phi_t,
        phi_o,
        ranges_list,
        disturbance,
        raw_left,
        raw_right,
        v_left,
        v_right,
        target_xy,
    ) -> None:
        arena = self.arena
        x, y, heading = arena._pose
        if target_xy is None:
            target_xy = arena.target.tolist()
        # Same order as _LogBuffer._FIELDS.
        row = [
            arena.time_s,
            x,
            y,
            heading,
            *x_list,
            d_t,
            d_o,
            phi_t,
            phi_o,
            disturbance,
            raw_left,
            raw_right,
            v_left,
            v_right,
            *ranges_list,
            *target_xy,
        ]
        scene = arena._scene()
        self._log.append(row, scene.ids, scene.radii, scene.xy_flat, scene.clearances)

    # -- whole runs --------------------------------------------------------------------

    def run(self, progress=None) -> SimulationResult:
        """Run to the end; ``progress(time_s)`` is called now and then if given.

        Raises
        ------
        ValueError
            Before the first step, when the run would take more than :data:`MAX_STEPS`
            steps (its duration over the control period) or its log more than
            :data:`MEMORY_BUDGET_BYTES` (:func:`check_run_size`): it would not fit in
            memory. (Stepping by hand, as the viewer does, has no such bound.)
        """
        check_run_size(
            self.scenario.duration_s - self.time_s,
            self.control_period_s,
            len(self.scenario.obstacles),
        )
        every = max(1, int(1.0 / self.control_period_s))
        steps = 0
        while self.outcome is None:  # not self.done
            self.step()
            steps += 1
            if progress is not None and steps % every == 0:
                progress(self.time_s)
        return self.result()

    def result(self) -> SimulationResult:
        log = self.log
        result = SimulationResult(
            scenario=self.scenario,
            outcome=self.outcome or "running",
            log=log,
            collisions=list(self.arena.collisions),
            wall_time_s=self._wall_time_s,
            seed=self.seed,
            perception=self.perception.mode,
            control_period_s=self.control_period_s,
            geometry=self.geometry,
            swept_min_clearance_m=(
                self.arena.min_clearance_m if math.isfinite(self.arena.min_clearance_m) else None
            ),
        )
        result.metrics = compute_metrics(result)
        return result
