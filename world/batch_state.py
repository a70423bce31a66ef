"""The per-run arrays of the batch engine (:class:`world.batch_world.BatchWorld`): each
run's scenario as arrays, its robot, its clock and its sonars.

Arrays are never written in place once handed out: :meth:`BatchState.set_runs` writes
into copies, so a controller that keeps last step's ``ranges`` keeps last step's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import SimpleNamespace

import numpy as np

from fuzzynav.world import kernels
from fuzzynav.world.geometry import FULL_CIRCLE_RAD
from fuzzynav.world.husky_params import N_STATES
from fuzzynav.world.run_limits import timeout_slack_s
from fuzzynav.world.scenario import Scenario

__all__ = ["BatchState", "scenario_arrays"]

#: Per-run arrays with one column per obstacle, and their padding for an absent one.
_COLUMN_PADDING = {
    "radius": np.nan,
    "present": False,
    "moving": False,
    "clear": np.nan,
    "cx": 0.0,
    "cy": 0.0,
    "sx": 0.0,
    "sy": 0.0,
}
#: What a logged row reads (:meth:`world.batch_metrics.BatchMetrics.log_rows`).
_ROW_FIELDS = (
    "run", "x", "y", "h", "start", "seg", "seg_len2", "present", "cx", "cy", "target",
    "disturbance",
)  # fmt: skip


def scenario_arrays(
    scenarios: Sequence[Scenario], n_columns: int, max_duration_s: float | None, dt: float
) -> dict:
    """The arrays of runs starting on ``scenarios``: their scenario, and their robot,
    clock and sonars at the start.

    Parameters
    ----------
    scenarios : sequence of Scenario
        One per run.
    n_columns : int
        Obstacle columns (at least the most obstacles of a scenario).
    max_duration_s : float or None
        A cap on the scenarios' durations, s.
    dt : float
        The control period, s (the timeout's slack).

    Returns
    -------
    dict
        Name to array, the run first on every axis.
    """
    k = len(scenarios)
    law = np.zeros((k, kernels.LAW_SIZE, n_columns))  # kernels.obstacle_law per column
    radius = np.full((k, n_columns), np.nan)
    for i, sc in enumerate(scenarios):
        for j, o in enumerate(sc.obstacles):
            law[i, :, j] = kernels.obstacle_law(o)
            radius[i, j] = o.radius_m
    present = np.isfinite(radius)
    moving = present & (
        (law[:, 2] != 0.0) | (law[:, 3] != 0.0) | (law[:, 4] != 0.0) | (law[:, 5] != 0.0)
    )
    start = np.array([sc.start for sc in scenarios], dtype=float).reshape(k, 2)
    target = np.array([sc.target for sc in scenarios], dtype=float).reshape(k, 2)
    disturbance = np.array(
        [
            (d.amplitude, d.angular_frequency_rad_s, d.start_s, d.stop_s)
            if (d := sc.disturbance) is not None
            else (0.0, 0.0, math.inf, -math.inf)
            for sc in scenarios
        ],
        dtype=float,
    ).reshape(k, 4)
    duration = np.array([sc.duration_s for sc in scenarios], dtype=float)
    if max_duration_s is not None:
        duration = np.minimum(duration, float(max_duration_s))
    # The ideal path (the start-target segment) of every run, for MAD and RMSE.
    seg = target - start
    return {
        "x": start[:, 0].copy(),
        "y": start[:, 1].copy(),
        "h": np.array([float(sc.heading_rad) for sc in scenarios]),
        "lg": np.zeros((k, N_STATES)),
        "t": np.zeros(k),
        "law": law,
        "radius": radius,
        "present": present,
        "moving": moving,
        "target": target,
        "start": start,
        "seg": seg,
        "seg_len2": np.einsum("ij,ij->i", seg, seg),
        "disturbance": disturbance,
        "has_window": np.array([sc.disturbance is not None for sc in scenarios]),
        # the first time that is the duration (the pymunk loop's test, to the bit)
        "timeout_at_s": duration - timeout_slack_s(duration, dt),
        "tolerance": np.array([sc.tolerance_m for sc in scenarios], dtype=float),
        # half the field of view of ideal perception (inf: all around)
        "half_field": np.array(
            [
                np.inf if sc.field_of_view_rad >= FULL_CIRCLE_RAD else 0.5 * sc.field_of_view_rad
                for sc in scenarios
            ]
        ),
        "ranges": np.inf,
        "next_update": -np.inf,  # the sonars' next reading, s
        "prev_v": np.nan,
    }


class BatchState:
    """The arrays of ``n_runs`` runs (all start empty; :meth:`set_runs` fills them).

    Parameters
    ----------
    n_runs : int
        Runs.
    n_columns : int
        Obstacle columns.
    n_sensors : int
        Sonars per robot.
    """

    # the arrays, (n, ...) each; set in __init__ from the tables above
    run: np.ndarray
    x: np.ndarray
    y: np.ndarray
    h: np.ndarray
    t: np.ndarray
    lg: np.ndarray
    law: np.ndarray
    target: np.ndarray
    start: np.ndarray
    seg: np.ndarray
    seg_len2: np.ndarray
    disturbance: np.ndarray
    timeout_at_s: np.ndarray
    tolerance: np.ndarray
    half_field: np.ndarray
    ranges: np.ndarray
    next_update: np.ndarray
    prev_v: np.ndarray
    has_window: np.ndarray
    radius: np.ndarray
    present: np.ndarray
    moving: np.ndarray
    clear: np.ndarray
    cx: np.ndarray
    cy: np.ndarray
    sx: np.ndarray
    sy: np.ndarray

    def __init__(self, n_runs: int, n_columns: int, n_sensors: int):
        n, m = n_runs, n_columns
        self.n_columns = m
        self.run = np.arange(n)
        shapes = {
            "x": (), "y": (), "h": (), "t": (), "lg": (N_STATES,), "law": (6, m),
            "target": (2,), "start": (2,), "seg": (2,), "seg_len2": (),
            "disturbance": (4,), "timeout_at_s": (), "tolerance": (), "half_field": (),
            "ranges": (n_sensors,), "next_update": (), "prev_v": (2,),
        }  # fmt: skip
        self.names = ["run", *shapes, "has_window", *_COLUMN_PADDING]
        for name, shape in shapes.items():
            setattr(self, name, np.zeros((n, *shape)))
        self.has_window = np.zeros(n, dtype=bool)
        for name, pad in _COLUMN_PADDING.items():
            setattr(self, name, np.full((n, m), pad))

    def set_runs(self, runs: np.ndarray, arrays: dict) -> None:
        """Write ``arrays`` (name to values, or to one value for all) into the rows
        ``runs``, each array copied first.

        Parameters
        ----------
        runs : numpy.ndarray
            Row indices.
        arrays : dict
            Name to values.
        """
        for name, values in arrays.items():
            target = getattr(self, name).copy()
            target[runs] = values
            setattr(self, name, target)

    def widen(self, n_columns: int) -> None:
        """Room for ``n_columns`` obstacles per run (absent columns padded).

        Parameters
        ----------
        n_columns : int
            The new number of columns.
        """
        extra = n_columns - self.n_columns
        if extra <= 0:
            return
        self.law = np.pad(self.law, ((0, 0), (0, 0), (0, extra)))
        for name, pad in _COLUMN_PADDING.items():
            value = getattr(self, name)
            setattr(self, name, np.pad(value, ((0, 0), (0, extra)), constant_values=pad))
        self.n_columns = n_columns

    def keep(self, mask: np.ndarray) -> None:
        """Keep the rows ``mask`` selects (the ended runs dropped).

        Parameters
        ----------
        mask : numpy.ndarray, (n,) bool
            The rows to keep.
        """
        for name in self.names:
            setattr(self, name, getattr(self, name)[mask])

    def select(self, rows) -> SimpleNamespace:
        """The rows ``rows`` of what a logged row reads, as a namespace.

        Parameters
        ----------
        rows : array_like
            Row indices or a mask.

        Returns
        -------
        types.SimpleNamespace
        """
        return SimpleNamespace(**{name: getattr(self, name)[rows] for name in _ROW_FIELDS})
