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
    (in the paper's geometry: between the point robot and an obstacle's surface): the
    smaller of the logged steps' and the arena's sweep between them (the true minimum,
    to 5 mm; see docs/robustness.md).
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

#: The metrics of the paper's Table 4, in its order (the comparison tables, the
#: recordings' summary).
TABLE4_ROWS = ("path_length_m", "mad_m", "rmse_m", "min_center_distance_m")


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
    jumps = voltage_jumped(v[:-1], v[1:], jump_v)
    if window_s is not None:
        jumps &= ~in_window(t[1:], window_s[0], window_s[1])
    return int(jumps.sum())


def voltage_jumped(previous, now, jump_v: float = VOLTAGE_JUMP_V) -> np.ndarray:
    """Whether either wheel's voltage jumps by more than ``jump_v`` from ``previous``
    to ``now`` (each (n, 2), V; a NaN ``previous`` is no jump): both engines' count."""
    return np.any(np.abs(now - previous) > jump_v, axis=1)


def in_window(t, start_s, stop_s):
    """Whether ``t`` lies in the disturbance's window, its end included (jumps there are
    not counted), floats or arrays."""
    return (start_s <= t) & (t <= stop_s)


def _finite_min(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(finite.min()) if finite.size else None


def _min_clearance(logged: float | None, swept: float | None) -> float | None:
    """The smaller of the logged clearances' minimum and the swept one (None: none)."""
    found = [v for v in (logged, swept) if v is not None and math.isfinite(v)]
    return min(found) if found else None


#: Rows :func:`compute_metrics` reads at a time: a long run's log may be mapped from the
#: disk (world.sim_log.LOG_BLOCK_BYTES), and whole-log temporaries grew with the run.
#: A log of at most this many rows is measured in one piece, as it always was.
METRICS_BLOCK_ROWS = 65_536


def row_blocks(n_rows: int) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` covering ``range(n_rows)`` in :data:`METRICS_BLOCK_ROWS`."""
    size = max(2, METRICS_BLOCK_ROWS)
    return [(start, min(start + size, n_rows)) for start in range(0, n_rows, size)]


def _min_or_none(a: float | None, b: float | None) -> float | None:
    return b if a is None else a if b is None else min(a, b)


class _LogSums:
    """The whole-log metrics accumulated a block of rows at a time. Every step between
    blocks is counted once (a block reads the row before it), so one block gives
    exactly what the functions above give on the whole log."""

    def __init__(self, n_rows: int):
        self.n_rows = n_rows
        self.path_length_m = 0.0
        self.sum_abs = 0.0
        self.sum_sq = 0.0
        self.min_center_distance_m: float | None = None
        self.min_clearance_m: float | None = None
        self.max_abs_voltage_v = 0.0
        self.voltage_jumps = 0
        # the last finite (time, voltages) row seen
        self._last_voltage: tuple[float, np.ndarray] | None = None

    @property
    def mad_m(self) -> float:
        return self.sum_abs / self.n_rows

    @property
    def rmse_m(self) -> float:
        return math.sqrt(self.sum_sq / self.n_rows)

    def add(self, log, start: int, stop: int, scenario) -> None:
        xy = np.asarray(log.pose[max(0, start - 1) : stop, :2], dtype=float)
        self.path_length_m += path_length(xy)
        d = point_segment_distance(xy[1:] if start else xy, scenario.start, scenario.target)
        self.sum_abs += float(np.add.reduce(np.abs(d)))
        self.sum_sq += float(np.add.reduce(d * d))
        self.min_center_distance_m = _min_or_none(
            self.min_center_distance_m, _finite_min(np.asarray(log.center_distance_m[start:stop]))
        )
        self.min_clearance_m = _min_or_none(
            self.min_clearance_m, _finite_min(np.asarray(log.clearance_m[start:stop]))
        )
        v = np.asarray(log.voltages_v[start:stop], dtype=float)
        applied = v[np.isfinite(v)]
        if applied.size:
            self.max_abs_voltage_v = max(self.max_abs_voltage_v, float(np.abs(applied).max()))
        t = np.asarray(log.time_s[start:stop], dtype=float)
        ok = np.all(np.isfinite(v), axis=1)
        v, t = v[ok], t[ok]
        if self._last_voltage is not None and len(v):
            t = np.concatenate([[self._last_voltage[0]], t])
            v = np.concatenate([self._last_voltage[1][None, :], v])
        window = scenario.disturbance
        self.voltage_jumps += voltage_jumps(
            t, v, None if window is None else (window.start_s, window.stop_s)
        )
        if len(v):
            self._last_voltage = (t[-1], v[-1])


def safety_distance(geometry: str, min_center_distance_m, min_clearance_m):
    """The distance the safe distance is judged on (module docstring): the centre
    distance in the paper's geometry, the clearance otherwise (floats or arrays)."""
    return min_center_distance_m if geometry == "paper" else min_clearance_m


def metrics_row(
    *,
    outcome: str,
    collided: bool,
    sim_time_s: float,
    path_length_m: float,
    mad_m: float | None,
    rmse_m: float | None,
    min_center_distance_m: float | None,
    min_clearance_m: float | None,
    max_abs_voltage_v: float,
    steps: int,
    voltage_jumps: int,
    geometry: str,
    wall_time_s: float | None = None,
) -> dict:
    """One run's metrics by name, both engines' (:func:`compute_metrics`,
    :meth:`world.batch_metrics.BatchResult.metrics`): None for a number that does not
    exist; ``wall_time_s`` only when given (the batch engine has none per run)."""
    reached = outcome == "reached"
    row = {
        "reached": reached,
        "collided": collided,
        "outcome": outcome,
        "time_to_target_s": sim_time_s if reached else None,
        "path_length_m": path_length_m,
        "mad_m": mad_m,
        "rmse_m": rmse_m,
        "min_center_distance_m": min_center_distance_m,
        "min_clearance_m": min_clearance_m,
        "max_abs_voltage_v": max_abs_voltage_v,
        "sim_time_s": sim_time_s,
        "steps": steps,
    }
    if wall_time_s is not None:
        row["wall_time_s"] = wall_time_s
    row["voltage_jumps"] = voltage_jumps
    row["geometry"] = geometry
    row["min_safety_distance_m"] = safety_distance(geometry, min_center_distance_m, min_clearance_m)
    return row


def compute_metrics(result) -> dict:
    """The metrics of a :class:`world.simulation.SimulationResult` as a plain dict."""
    log = result.log
    geometry = getattr(result, "geometry", "husky")
    if len(log) == 0:  # interrupted before the first step: nothing to measure yet
        return metrics_row(
            outcome=result.outcome, collided=False, sim_time_s=0.0, path_length_m=0.0,
            mad_m=None, rmse_m=None, min_center_distance_m=None, min_clearance_m=None,
            max_abs_voltage_v=0.0, steps=0, voltage_jumps=0, geometry=geometry,
            wall_time_s=float(result.wall_time_s),
        ) | {"reached": False, "time_to_target_s": None}  # fmt: skip
    sums = _LogSums(len(log))
    for start, stop in row_blocks(len(log)):
        sums.add(log, start, stop, result.scenario)
    return metrics_row(
        outcome=result.outcome,
        collided=bool(result.collisions),
        sim_time_s=float(log.time_s[-1]),
        path_length_m=sums.path_length_m,
        mad_m=sums.mad_m,
        rmse_m=sums.rmse_m,
        min_center_distance_m=sums.min_center_distance_m,
        min_clearance_m=_min_clearance(
            sums.min_clearance_m, getattr(result, "swept_min_clearance_m", None)
        ),
        max_abs_voltage_v=sums.max_abs_voltage_v,
        steps=int(len(log) - 1),
        voltage_jumps=sums.voltage_jumps,
        geometry=geometry,
        wall_time_s=float(result.wall_time_s),
    )


# --------------------------------------------------------------------------- benchmark
#
# Judged against the shortest collision-free path (world/shortest_path.py), as the BARN
# benchmark judges against its A* path (Perille et al., "Benchmarking Metric Ground
# Navigation", 2020): ``score = success * optimal_time / clip(time, 2 * optimal_time,
# 8 * optimal_time)`` with ``optimal_time = shortest_path_m / top speed``. The top speed
# is the plant's own steady forward speed at the saturation voltage on both sides
# (0.617 m/s for the paper's Husky at 12 V): the fastest any controller can drive it
# straight. A run that keeps up the top speed along the shortest path would score 1 /
# 2 = 0.5 (the clip caps every score at 0.5, as BARN's does at 1/4); a successful run
# that takes 8 x the optimal time or more scores 1/8 = 0.125; a failure scores 0.
# The start heading is not counted in the optimum (a turn on the spot is not free), so
# a score near 0.5 is out of reach; the numbers compare controllers on the same layouts.

BENCHMARK_KEYS = ("shortest_path_m", "path_ratio", "optimal_time_s", "time_ratio", "score")
SCORE_CLIP = (2.0, 8.0)


def top_speed_mps(model, voltage_limit_v: float) -> float:
    """Steady forward speed [m/s] of ``model`` (a :class:`world.husky.HuskyModel`) with
    ``voltage_limit_v`` on both sides."""
    from fuzzynav.world.husky_params import STATE_NAMES

    state = model.steady_state(np.array([voltage_limit_v, voltage_limit_v], float))
    return float(state[STATE_NAMES.index("v_MH")])


def benchmark_metrics(
    *,
    success: bool,
    path_length_m: float,
    time_to_target_s: float | None,
    shortest_path_m: float,
    top_speed_mps: float,
) -> dict:
    """The benchmark numbers of one run (see the comment above :data:`BENCHMARK_KEYS`).

    ``path_ratio = path_length_m / shortest_path_m`` and ``time_ratio = time /
    optimal_time_s`` of a successful run (None otherwise); ``score`` for every run (0
    for a failure). All None when no collision-free path exists (``shortest_path_m``
    inf): that layout has no reference, and its score is undefined.
    """
    if not (top_speed_mps > 0 and math.isfinite(top_speed_mps)):
        raise ValueError(f"top_speed_mps = {top_speed_mps!r}: must be finite and > 0")
    if not math.isfinite(shortest_path_m) or shortest_path_m <= 0.0:
        return dict.fromkeys(BENCHMARK_KEYS)
    optimal_time_s = shortest_path_m / top_speed_mps
    out = {
        "shortest_path_m": float(shortest_path_m),
        "path_ratio": None,
        "optimal_time_s": optimal_time_s,
        "time_ratio": None,
        "score": 0.0,
    }
    if success and time_to_target_s is not None:
        low, high = SCORE_CLIP
        clipped = min(max(time_to_target_s, low * optimal_time_s), high * optimal_time_s)
        out["path_ratio"] = path_length_m / shortest_path_m
        out["time_ratio"] = time_to_target_s / optimal_time_s
        out["score"] = optimal_time_s / clipped
    return out
