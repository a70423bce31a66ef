"""Run metrics: the paper's Eq. 15-17 and Table 4, plus safety numbers of our own.

``path_length_m``
    Eq. 15: the sum of the distances between successive logged positions.
``mad_m``, ``rmse_m``
    Eq. 16-17 with d_ideal = 0: mean absolute and root-mean-square distance of the
    logged positions from the ideal path, the straight segment from start to target.
``min_center_distance_m``
    The paper's "minimum distance to obstacles": centre to centre (the paper treats the
    robot and the obstacles as points).
``min_clearance_m``
    Ours: the smallest distance between the real footprint and an obstacle's surface
    (in the paper's geometry: between the point robot and an obstacle's surface).
``min_safety_distance_m``
    The distance the 25 cm safe distance is judged on: ``min_clearance_m`` for the Husky's
    footprint, ``min_center_distance_m`` in the paper's geometry (the paper measures
    centre to centre).
``voltage_jumps``
    Control steps at which either applied wheel voltage jumps by more than 2 V from the
    step before, outside the scenario's disturbance window (chatter; the paper's
    Figs. 16, 21 and 26 show smooth voltages).
``geometry``
    ``husky`` or ``paper`` (see :class:`world.simulation.Simulation`).
``time_to_target_s``
    Time of arrival, or None when the target was not reached.
``max_abs_voltage_v``
    The largest applied |voltage| (after saturation).
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.world.geometry import point_segment_distance


def path_length(xy: np.ndarray) -> float:
    steps = np.diff(np.asarray(xy, dtype=float), axis=0)
    return float(np.hypot(steps[:, 0], steps[:, 1]).sum())


def deviation_from_line(xy: np.ndarray, start, target) -> tuple[float, float]:
    """(MAD, RMSE) of the points' distances from the start-target segment."""
    d = point_segment_distance(xy, start, target)
    return float(np.mean(np.abs(d))), float(math.sqrt(np.mean(d * d)))


VOLTAGE_JUMP_V = 2.0


def voltage_jumps(time_s, voltages_v, window_s=None, jump_v: float = VOLTAGE_JUMP_V) -> int:
    """Control steps where either wheel's applied voltage jumps by more than ``jump_v``
    from the step before, not counting steps inside ``window_s`` ((start, end) seconds)."""
    v = np.asarray(voltages_v, dtype=float)
    t = np.asarray(time_s, dtype=float)
    ok = np.all(np.isfinite(v), axis=1)
    v, t = v[ok], t[ok]
    if len(v) < 2:
        return 0
    jumps = np.any(np.abs(np.diff(v, axis=0)) > jump_v, axis=1)
    if window_s is not None:
        jumps &= ~((t[1:] >= window_s[0]) & (t[1:] <= window_s[1]))
    return int(jumps.sum())


def _finite_min(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(finite.min()) if finite.size else None


def compute_metrics(result) -> dict:
    """The metrics of a :class:`world.simulation.SimulationResult` as a plain dict."""
    log = result.log
    if len(log) == 0:  # interrupted before the first step: nothing to measure yet
        return {
            "reached": False,
            "collided": False,
            "outcome": result.outcome,
            "time_to_target_s": None,
            "path_length_m": 0.0,
            "mad_m": None,
            "rmse_m": None,
            "min_center_distance_m": None,
            "min_clearance_m": None,
            "max_abs_voltage_v": 0.0,
            "sim_time_s": 0.0,
            "steps": 0,
            "wall_time_s": float(result.wall_time_s),
            "voltage_jumps": 0,
            "geometry": getattr(result, "geometry", "husky"),
            "min_safety_distance_m": None,
        }
    geometry = getattr(result, "geometry", "husky")
    xy = log.pose[:, :2]
    sc = result.scenario
    mad, rmse = deviation_from_line(xy, sc.start, sc.target)
    applied = log.voltages_v[np.isfinite(log.voltages_v)]
    reached = result.outcome == "reached"
    return {
        "reached": reached,
        "collided": bool(result.collisions),
        "outcome": result.outcome,
        "time_to_target_s": float(log.time_s[-1]) if reached else None,
        "path_length_m": path_length(xy),
        "mad_m": mad,
        "rmse_m": rmse,
        "min_center_distance_m": _finite_min(log.center_distance_m),
        "min_clearance_m": _finite_min(log.clearance_m),
        "max_abs_voltage_v": float(np.abs(applied).max()) if applied.size else 0.0,
        "sim_time_s": float(log.time_s[-1]),
        "steps": int(len(log) - 1),
        "wall_time_s": float(result.wall_time_s),
        "voltage_jumps": voltage_jumps(
            log.time_s,
            log.voltages_v,
            None if sc.disturbance is None else (sc.disturbance.start_s, sc.disturbance.stop_s),
        ),
        "geometry": geometry,
        "min_safety_distance_m": _finite_min(
            log.center_distance_m if geometry == "paper" else log.clearance_m
        ),
    }
