"""The lockstep batch engine: N runs advanced together as numpy arrays.

:func:`run_batch` drives N scenarios (each with its own start, target, obstacles,
duration and disturbance) one control period per step, every quantity of every run in
one array; a run that ends is dropped from the arrays. It is
:class:`world.simulation.Simulation` without pymunk, its runs the pymunk engine's to
rounding (what is shared and how it is checked: docs/experiments.md, "Two engines").
The stepping form is :class:`world.batch_world.BatchWorld` (``reset``, ``observe``,
``step``), made of the array stages of :mod:`world.kernels`; the metrics, accumulated as
the runs go (no per-step log is kept), are :mod:`world.batch_metrics`'s.

The world knows nothing of the controller: it calls ``controller.decide(inputs, runs,
ranges_m)`` (:class:`BatchController`) with the active runs' inputs (n, 4), their
indices in the batch (n,) and their sonar readings (n, 3); the controller returns the
wheel voltages (n, 2). The glue for fuzzynav's controllers is :mod:`controller.batch`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from fuzzynav.world.batch_metrics import BatchResult, RunObserver
from fuzzynav.world.batch_world import BatchWorld
from fuzzynav.world.husky import HuskyModel
from fuzzynav.world.kernels import advance_pose, footprint_clearances, sonar_distances
from fuzzynav.world.run_limits import OUTCOMES
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.sensors import SensorConfig

__all__ = [
    "BatchController",
    "BatchResult",
    "BatchWorld",
    "OUTCOMES",
    "advance_pose",
    "footprint_clearances",
    "run_batch",
    "sonar_distances",
]


class BatchController(Protocol):
    """What :func:`run_batch` calls: ``decide(inputs (n, 4), runs (n,), ranges_m (n, 3))
    -> wheel voltages (n, 2)`` (left, right, V, before the saturation)."""

    def decide(self, inputs: np.ndarray, runs: np.ndarray, ranges_m: np.ndarray) -> np.ndarray: ...


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
    stop_rule=None,
    observers: Sequence[RunObserver] = (),
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
    stop_rule : callable, optional
        An early stop of the caller's, ``stop_rule(runs, time_s, to_target_m) -> (n,)
        bool`` after every step (tuning's stall rule,
        :class:`app.experiments.objective.StallRule`): the runs it stops end as
        ``timeout``, their last step unlogged (:class:`world.batch_world.BatchWorld`).
    observers : sequence of RunObserver, optional
        The caller's own measurements (:class:`world.batch_metrics.RunObserver`: the
        paper fit's, :class:`app.experiments.batch_runs.FitTrace`), fed at every logged
        row and decision.

    Returns
    -------
    BatchResult
        Every run's outcome and metrics, batch order.

    Raises
    ------
    ValueError
        An empty batch, a bad period, limit, perception or geometry, a seeds list of
        another length, or a controller that returns voltages of the wrong shape or not
        finite (the run, time and inputs are named).
    """
    world = BatchWorld(
        perception=perception,
        geometry=geometry,
        control_period_s=control_period_s,
        model=model,
        sensor_config=sensor_config,
        voltage_limit_v=voltage_limit_v,
        max_duration_s=max_duration_s,
        stop_rule=stop_rule,
        observers=observers,
        record_poses=record_poses,
    )
    world.reset(scenarios, seeds)
    while world.runs.size:
        inputs, ranges = world.observe()
        world.step(controller.decide(inputs, world.runs, ranges))
        world.drop_ended()
    return world.result()
