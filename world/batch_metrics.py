"""The batch engine's run metrics, accumulated per run as the runs go, and its result.

No per-step log is kept (so 10,000 runs fit in memory): every logged row adds its terms
(:meth:`BatchMetrics.log_rows`), every decision its voltages
(:meth:`BatchMetrics.add_voltages`), and :meth:`BatchMetrics.result` gives every number
:func:`world.metrics.compute_metrics` gives that a sweep row carries, with its
conventions. What else a caller wants to measure (the paper fit's observers,
:mod:`app.experiments.batch_runs`) it measures through the same hooks, as a
:class:`RunObserver`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from fuzzynav.world.kernels import line_deviation
from fuzzynav.world.metrics import metrics_row, safety_distance, voltage_jumped
from fuzzynav.world.run_limits import OUTCOMES

__all__ = ["BatchMetrics", "BatchResult", "RunObserver"]


class RunObserver(Protocol):
    """A caller's own measurement of a batch's runs, fed as the metrics are
    (:class:`BatchMetrics`; ``observers`` of :func:`world.batch.run_batch`).

    ``start(n_runs, n_columns)`` once at the batch's start; ``restart(runs)`` when runs
    begin again (their batch indices); ``widen(n_columns)`` when runs with more obstacle
    columns join; ``log_rows(s, t_row, centre)`` at every logged row of the runs ``s.run``
    (their arrays as :meth:`BatchMetrics.log_rows` reads them, the rows' times (n,) s,
    and every obstacle's centre distance (n, M) m, inf for none);
    ``add_voltages(runs, volts)`` at every decision (the applied voltages (n, 2), V).
    """

    def start(self, n_runs: int, n_columns: int) -> None: ...

    def restart(self, runs: np.ndarray) -> None: ...

    def widen(self, n_columns: int) -> None: ...

    def log_rows(self, s, t_row: np.ndarray, centre: np.ndarray) -> None: ...

    def add_voltages(self, runs: np.ndarray, volts: np.ndarray) -> None: ...


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
        conventions (None for a number that does not exist; no wall time per run).

        Parameters
        ----------
        i : int
            The run's index in the batch.

        Returns
        -------
        dict
            The metrics by name.
        """

        def number(values):
            v = float(values[i])
            return v if math.isfinite(v) else None

        return metrics_row(
            outcome=OUTCOMES[int(self.outcome[i])],
            collided=bool(self.collided[i]),
            sim_time_s=float(self.sim_time_s[i]),
            path_length_m=float(self.path_length_m[i]),
            mad_m=number(self.mad_m),
            rmse_m=number(self.rmse_m),
            min_center_distance_m=number(self.min_center_distance_m),
            min_clearance_m=number(self.min_clearance_m),
            max_abs_voltage_v=float(self.max_abs_voltage_v[i]),
            steps=int(self.steps[i]),
            voltage_jumps=int(self.voltage_jumps[i]),
            geometry=self.geometry,
        )


#: The per-run accumulators and their starting values.
_SCALARS = {
    "outcome": (-1, np.int64),
    "collided": (False, bool),
    "sim_time": (0.0, float),
    "steps_done": (0, np.int64),
    "path_sum": (0.0, float),
    "dev_abs": (0.0, float),
    "dev_sq": (0.0, float),
    "rows": (0, np.int64),
    "min_centre": (np.inf, float),
    "min_clear": (np.inf, float),
    "max_abs_v": (0.0, float),
    "jumps": (0, np.int64),
    "min_target": (np.inf, float),
    "final_target": (np.nan, float),
}


class BatchMetrics:
    """The metrics of ``n_runs`` runs with up to ``n_columns`` obstacles each.

    Parameters
    ----------
    n_runs : int
        Runs in the batch.
    n_columns : int
        Obstacle columns (the most obstacles of a run; at least 1).
    record_poses : bool
        Keep every logged pose of every run.
    observers : sequence of RunObserver
        The caller's own measurements, fed at every row and decision.
    """

    # the accumulators, (N,) each (set from _SCALARS)
    outcome: np.ndarray
    collided: np.ndarray
    sim_time: np.ndarray
    steps_done: np.ndarray
    path_sum: np.ndarray
    dev_abs: np.ndarray
    dev_sq: np.ndarray
    rows: np.ndarray
    min_centre: np.ndarray
    min_clear: np.ndarray
    max_abs_v: np.ndarray
    jumps: np.ndarray
    min_target: np.ndarray
    final_target: np.ndarray

    def __init__(
        self,
        n_runs: int,
        n_columns: int,
        record_poses: bool,
        observers: Sequence[RunObserver] = (),
    ):
        self.n_runs = n_runs
        for name, (value, dtype) in _SCALARS.items():
            setattr(self, name, np.full(n_runs, value, dtype=dtype))
        self.observers = list(observers)
        for observer in self.observers:
            observer.start(n_runs, n_columns)
        self.pose_log: list | None = [] if record_poses else None

    def restart(self, runs: np.ndarray) -> None:
        """Every accumulator of ``runs`` back to its start (a run begins again).

        Parameters
        ----------
        runs : numpy.ndarray
            Batch indices.
        """
        for name, (value, _) in _SCALARS.items():
            getattr(self, name)[runs] = value
        for observer in self.observers:
            observer.restart(runs)

    def widen(self, n_columns: int) -> None:
        """Room for ``n_columns`` obstacle columns (the observers' per-obstacle arrays).

        Parameters
        ----------
        n_columns : int
            The new number of columns (not fewer than now).
        """
        for observer in self.observers:
            observer.widen(n_columns)

    def log_rows(self, s, t_row: np.ndarray) -> None:
        """What one logged row of each run in ``s`` adds: its position's deviation from
        the ideal line, its distance to the target, its obstacles' centre distances.

        Parameters
        ----------
        s : object
            The runs' arrays (``run``, ``x``, ``y``, ``h``, ``start``, ``seg``,
            ``seg_len2``, ``present``, ``cx``, ``cy``, ``target``, ``disturbance``;
            :class:`world.batch_world.BatchWorld`'s state or a selection of it).
        t_row : numpy.ndarray, (n,)
            The rows' times, s.
        """
        run = s.run
        d = line_deviation(s.x, s.y, s.start, s.seg, s.seg_len2)
        self.dev_abs[run] += np.abs(d)
        self.dev_sq[run] += d * d
        self.rows[run] += 1
        to_target = np.hypot(s.target[:, 0] - s.x, s.target[:, 1] - s.y)
        self.min_target[run] = np.minimum(self.min_target[run], to_target)
        self.final_target[run] = to_target
        centre = np.hypot(s.cx - s.x[:, None], s.cy - s.y[:, None])
        centre = np.where(s.present, centre, np.inf)
        self.min_centre[run] = np.minimum(self.min_centre[run], centre.min(axis=1))
        for observer in self.observers:
            observer.log_rows(s, t_row, centre)
        if self.pose_log is not None:
            self.pose_log.append((run.copy(), np.stack([s.x, s.y, s.h], axis=1)))

    def add_voltages(self, run, volts, prev_v, in_window) -> None:
        """A decision's applied voltages: the largest magnitude, the jumps outside the
        disturbance's window (:func:`world.metrics.voltage_jumps`).

        Parameters
        ----------
        run : numpy.ndarray, (n,)
            Batch indices.
        volts : numpy.ndarray, (n, 2)
            The voltages applied now, V.
        prev_v : numpy.ndarray, (n, 2)
            Those of the previous decision (NaN before the first), V.
        in_window : numpy.ndarray, (n,) bool
            Runs inside their disturbance's window (its end included).
        """
        self.max_abs_v[run] = np.maximum(self.max_abs_v[run], np.abs(volts).max(axis=1))
        for observer in self.observers:
            observer.add_voltages(run, volts)
        self.jumps[run] += voltage_jumped(prev_v, volts) & ~in_window

    def result(self, geometry, perception, wall_time_s, scenarios) -> BatchResult:
        """The batch's :class:`BatchResult`.

        Parameters
        ----------
        geometry, perception : str
            The batch's settings, as given.
        wall_time_s : float
            The batch's wall time, s.
        scenarios : list of Scenario
            The runs' scenarios, batch order.

        Returns
        -------
        BatchResult
        """
        n_rows = np.maximum(self.rows, 1)
        min_centre = np.where(np.isfinite(self.min_centre), self.min_centre, np.nan)
        min_clear = np.where(np.isfinite(self.min_clear), self.min_clear, np.nan)
        poses = None
        if self.pose_log is not None:
            per_run: list[list] = [[] for _ in range(self.n_runs)]
            for runs, block in self.pose_log:
                for r, p in zip(runs.tolist(), block):
                    per_run[r].append(p)
            poses = [np.array(p) for p in per_run]
        return BatchResult(
            outcome=self.outcome,
            collided=self.collided,
            time_to_target_s=np.where(self.outcome == 0, self.sim_time, np.nan),
            sim_time_s=self.sim_time,
            steps=self.steps_done,
            path_length_m=self.path_sum,
            mad_m=self.dev_abs / n_rows,
            rmse_m=np.sqrt(self.dev_sq / n_rows),
            min_center_distance_m=min_centre,
            min_clearance_m=min_clear,
            min_safety_distance_m=safety_distance(geometry, min_centre, min_clear),
            max_abs_voltage_v=self.max_abs_v,
            voltage_jumps=self.jumps,
            min_target_distance_m=self.min_target,
            final_target_distance_m=self.final_target,
            geometry=geometry,
            perception=perception,
            wall_time_s=wall_time_s,
            poses=poses,
            scenarios=scenarios,
        )
