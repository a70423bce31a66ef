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

Speed (issue 2): a step does a few dozen small operations, so the loop works on plain
floats (perception, saturation and the log row build no small numpy arrays; only the
controller's ``inputs`` and the plant's ``[x; u]`` are arrays) and writes log rows in
blocks; the numbers are in docs/speed.md. Every operation on the numbers is the one the
straightforward code did, in the same order, so runs are the same to the bit.
"""

from __future__ import annotations

import contextlib
import math
import struct
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np

from fuzzynav.world import perception as _perception
from fuzzynav.world.arena import Arena, Collision
from fuzzynav.world.husky import HuskyModel
from fuzzynav.world.metrics import compute_metrics
from fuzzynav.world.robot import HUSKY, brief
from fuzzynav.world.scenario import Scenario
from fuzzynav.world.sensors import RangeSensorArray, SensorConfig

#: How a run ends: at the target, against an obstacle, or out of time.
Outcome = Literal["reached", "collided", "timeout"]
OUTCOMES: tuple[Outcome, ...] = get_args(Outcome)
#: The control period's bounds: below a millisecond the log of an ordinary run grows to
#: gigabytes (1e-5 s asked for 4.3 GB) for nothing the exact ZOH plant needs; above a
#: second the sensors (25 Hz) and the collision sub-steps lose their meaning.
MIN_CONTROL_PERIOD_S = 1e-3
MAX_CONTROL_PERIOD_S = 1.0
#: The most steps :meth:`Simulation.run` takes (duration / period): the log holds 24
#: floats a step plus 4 per obstacle, so 2 million steps of a run with a few obstacles
#: write under 0.6 GB to the log's spool (an hour at 2 ms; 1e-5 s asked 4.3 GB).
MAX_STEPS = 2_000_000
#: The size one run's log may reach (issue 26): a legal scenario of 1000 obstacles and
#: 3600 s reached 9.7 GB of memory. Checked before the first step with
#: :func:`log_bytes`; beyond :data:`LOG_BLOCK_BYTES` the log is on the disk.
MEMORY_BUDGET_BYTES = 2 * 1024**3
#: Floats the log keeps a step, besides those of the obstacles.
LOG_FLOATS_PER_STEP = 24
#: Floats the log keeps per obstacle and step: x, y, centre distance, clearance.
LOG_FLOATS_PER_OBSTACLE = 4
#: The log's peak over its final size when it was all in memory (its arrays grew by
#: doubling, and the result took a copy): kept as the bound's margin.
LOG_PEAK_FACTOR = 3


def check_loop_settings(control_period_s: float, voltage_limit_v: float) -> None:
    """ValueError naming the value when the control period is outside
    [:data:`MIN_CONTROL_PERIOD_S`, :data:`MAX_CONTROL_PERIOD_S`] or the voltage limit
    is not a positive number (both engines' check)."""
    if not (
        math.isfinite(control_period_s)
        and MIN_CONTROL_PERIOD_S <= control_period_s <= MAX_CONTROL_PERIOD_S
    ):
        raise ValueError(
            f"control_period_s = {control_period_s!r}: must be from "
            f"{MIN_CONTROL_PERIOD_S:g} to {MAX_CONTROL_PERIOD_S:g} s"
        )
    if not (math.isfinite(voltage_limit_v) and voltage_limit_v > 0):
        raise ValueError(f"voltage_limit_v = {voltage_limit_v!r}: must be positive")


#: The smallest slack of the timeout test (s): a run ends as ``timeout`` at the first
#: step whose accumulated time reaches its duration less the slack.
TIMEOUT_SLACK_S = 1e-9


def timeout_slack_s(duration_s, control_period_s):
    """How far short of ``duration_s`` the accumulated time may end and still be the
    duration [s]: :data:`TIMEOUT_SLACK_S`, or the rounding that adding the period
    ``duration_s / control_period_s`` times can gather (each sum rounds by at most half
    an ulp of ``duration_s``) when that is larger. 1 ns alone let a 2,000 s run at 1 ms
    fall 2e-9 s short and take one step past :data:`MAX_STEPS`; an ordinary run's slack
    stays 1 ns (150 s at 20 ms gather at most 5e-10 s). Works on arrays too."""
    rounding = 2.0 * np.finfo(float).eps * duration_s * (duration_s / control_period_s)
    return np.maximum(TIMEOUT_SLACK_S, rounding)


def log_bytes(steps: float, n_obstacles: int) -> float:
    """The peak memory [bytes] of the log of a run of ``steps`` steps among
    ``n_obstacles`` obstacles (float64 columns, growth by doubling and the result's
    copy included)."""
    floats = LOG_FLOATS_PER_STEP + LOG_FLOATS_PER_OBSTACLE * n_obstacles
    return LOG_PEAK_FACTOR * 8.0 * floats * steps


def check_run_size(duration_s: float, control_period_s: float, n_obstacles: int) -> float:
    """The steps of a run, or ValueError with the numbers when it would take more than
    :data:`MAX_STEPS` steps or its log more than :data:`MEMORY_BUDGET_BYTES`."""
    steps = duration_s / control_period_s
    if steps > MAX_STEPS:
        raise ValueError(
            f"control_period_s = {control_period_s!r} with duration_s = "
            f"{duration_s!r}: {steps:.3g} steps, more than one run may "
            f"take ({MAX_STEPS}); use a longer period or a shorter scenario"
        )
    need = log_bytes(steps, n_obstacles)
    if need > MEMORY_BUDGET_BYTES:
        raise ValueError(
            f"{steps:.0f} steps ({duration_s:g} s at {control_period_s:g} s) x {n_obstacles} "
            f"obstacles: the run's log would take about {need / 1024**3:.1f} GiB, more than "
            f"the {MEMORY_BUDGET_BYTES / 1024**3:g} GiB one run may use; use a shorter "
            "duration, a longer period or fewer obstacles"
        )
    return steps


#: The most the log of one run keeps in memory (issue 26): a longer run's rows go to an
#: unnamed temporary file a block at a time, and the finished log maps them back
#: (read-only pages the operating system may drop and read again), so a run's memory
#: does not grow with its length. Runs shorter than a block never touch the disk.
LOG_BLOCK_BYTES = 16 * 1024**2


def log_block_rows(n_obstacles: int) -> int:
    """Rows of the log's in-memory block (:data:`LOG_BLOCK_BYTES`) for ``n_obstacles``
    obstacle columns."""
    floats = LOG_FLOATS_PER_STEP + LOG_FLOATS_PER_OBSTACLE * max(1, n_obstacles)
    return max(_LOG_MIN_BLOCK_ROWS, LOG_BLOCK_BYTES // (8 * floats))


_LOG_MIN_BLOCK_ROWS = 1024
_FLOAT64 = np.dtype(np.float64)
_pack_into: Any = struct.pack_into  # numpy arrays are buffers


@dataclass
class SimulationLog:
    """Per-step arrays of one run (see the module docstring for the row convention)."""

    time_s: np.ndarray  # (N,)
    pose: np.ndarray  # (N, 3): x m, y m, heading rad (continuous, not wrapped)
    lg_state: np.ndarray  # (N, 6): w_LW, w_RW, v_MH, w_JH, i_L1, i_L2
    inputs: np.ndarray  # (N, 4): d_t, d_o, phi_t, phi_o as the controller saw them
    disturbance: np.ndarray  # (N,): the value added to every input
    controller_output_v: np.ndarray  # (N, 2): left, right before saturation
    voltages_v: np.ndarray  # (N, 2): left, right as applied
    ranges_m: np.ndarray  # (N, 3): left, front, right sensor readings
    target_xy: np.ndarray  # (N, 2)
    obstacle_xy: np.ndarray  # (N, n_obstacles, 2); NaN while an obstacle is absent
    obstacle_radii_m: np.ndarray  # (n_obstacles,)
    obstacle_ids: list[int]
    center_distance_m: np.ndarray  # (N, n_obstacles): robot centre to obstacle centre
    clearance_m: np.ndarray  # (N, n_obstacles): footprint to obstacle surface

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


class _LogBuffer:
    """Growable per-step arrays; obstacles may be added while the simulation runs.

    The per-step floats live in one wide matrix. Rows arrive as plain lists and are
    written into the matrices a block at a time (every ``_FLUSH_ROWS`` rows, and before
    :meth:`freeze`) by ``struct.pack_into``, instead of several numpy calls per step,
    which is where the loop's time went. The obstacles' centre distances are computed
    per block from the logged pose and centres (``np.hypot``, as before).
    """

    _FIELDS = {
        "time_s": 1,
        "pose": 3,
        "lg_state": 6,
        "inputs": 4,
        "disturbance": 1,
        "controller_output_v": 2,
        "voltages_v": 2,
        "ranges_m": 3,
        "target_xy": 2,
    }
    _FLUSH_ROWS = 512

    def __init__(self, capacity: int, block_rows: int):
        self.n = 0
        # block_rows: rows kept in memory at most; fuller blocks are written out to the
        # spool, a pair of unnamed temporary files.
        self.block_rows = max(block_rows, self._FLUSH_ROWS)
        self.capacity = max(min(capacity, self.block_rows), 16)
        self._spool: _LogSpool | None = None
        self._spilled = 0  # rows in the spool, before those in the matrices
        self.width = sum(self._FIELDS.values())
        self.rows = np.full((self.capacity, self.width), np.nan)
        self.obstacle_ids: list[int] = []
        self.obstacle_radii: list[float] = []
        # Per obstacle column: x, y, centre distance, clearance.
        self.obstacles = np.full((self.capacity, 0, 4), np.nan)
        self._written = 0  # rows already in the matrices
        self._pending = 0  # rows not yet written; their numbers, flattened:
        self._rows: list = []  # `width` per row
        self._xy: list = []  # x, y per obstacle column
        self._clearances: list = []  # one per obstacle column
        self._ids_seen: list[int] | None = None  # the ids list the pending obstacle data follows
        self._columns: list[int] = []
        self._direct = True  # those ids are exactly the columns, in order

    def _make_room(self, rows: int) -> None:
        while self._written + rows > self.capacity:
            if self.capacity >= self.block_rows:
                self._spill()
            else:
                self._grow()

    def _spill(self) -> None:
        """Write the matrices' rows to the spool and start the block again."""
        if self._spool is None:
            self._spool = _LogSpool()
        self._spool.append(self.rows[: self._written], self.obstacles[: self._written])
        self._spilled += self._written
        self._written = 0

    def _grow(self) -> None:
        self.capacity = min(2 * self.capacity, self.block_rows)
        self.rows = np.concatenate([self.rows, np.full_like(self.rows, np.nan)])
        self.obstacles = np.concatenate([self.obstacles, np.full_like(self.obstacles, np.nan)])

    def _set_columns(self, ids: list[int], radii) -> None:
        new = [(i, r) for i, r in zip(ids, radii) if i not in self.obstacle_ids]
        if new:
            self._flush()  # the pending rows have the old number of columns
            if self._spool is not None:
                self._spool.widen(
                    self._spilled, len(self.obstacle_ids), len(self.obstacle_ids) + len(new)
                )
            for obstacle_id, radius in new:
                self.obstacle_ids.append(obstacle_id)
                self.obstacle_radii.append(float(radius))
            self.obstacles = np.concatenate(
                [self.obstacles, np.full((self.capacity, len(new), 4), np.nan)], axis=1
            )
        self._columns = [self.obstacle_ids.index(i) for i in ids]
        self._direct = list(ids) == self.obstacle_ids
        self._ids_seen = ids

    def append(
        self, row: list[float], ids: list[int], radii, xy: list[float], clearances: list[float]
    ) -> None:
        """Log one row: ``row`` in ``_FIELDS`` order; per obstacle present (``ids``),
        its radius, its centre (in ``xy``, flat: x0, y0, x1, y1, ...) and clearance."""
        if ids is not self._ids_seen:
            self._set_columns(ids, radii)
        self._rows += row
        if self._direct:
            if ids:
                self._xy += xy
                self._clearances += clearances
        else:
            n_columns = len(self.obstacle_ids)
            padded_xy = [math.nan] * (2 * n_columns)
            padded_clearances = [math.nan] * n_columns
            for j, column in enumerate(self._columns):
                padded_xy[2 * column] = xy[2 * j]
                padded_xy[2 * column + 1] = xy[2 * j + 1]
                padded_clearances[column] = clearances[j]
            self._xy += padded_xy
            self._clearances += padded_clearances
        self.n += 1
        self._pending += 1
        if self._pending >= self._FLUSH_ROWS:
            self._flush()

    def _flush(self) -> None:
        m = self._pending
        if not m:
            return
        self._make_room(m)
        start, stop = self._written, self._written + m
        # struct packs the flat lists straight into the arrays' memory: a plain float
        # loop, several times cheaper than numpy's conversion of nested lists.
        _pack_into(f"{m * self.width}d", self.rows, start * self.width * 8, *self._rows)
        rows = self.rows[start:stop]
        n_columns = len(self.obstacle_ids)
        if n_columns and self._xy:
            xy = np.empty((m, n_columns, 2))
            _pack_into(f"{m * n_columns * 2}d", xy, 0, *self._xy)
            clearances = np.empty((m, n_columns))
            _pack_into(f"{m * n_columns}d", clearances, 0, *self._clearances)
            block = self.obstacles[start:stop]
            block[:, :, 0:2] = xy
            block[:, :, 3] = clearances
            block[:, :, 2] = np.hypot(block[:, :, 0] - rows[:, 1:2], block[:, :, 1] - rows[:, 2:3])
        self._written = stop
        self._pending = 0
        self._rows, self._xy, self._clearances = [], [], []

    def freeze(self) -> SimulationLog:
        """The log so far, the caller's to keep: copies of the arrays (or, once rows
        have left memory, copy-on-write maps of the spool)."""
        return self._snapshot(copy=True)

    def view(self) -> SimulationLog:
        """The log so far without a copy: views of the arrays, valid until the next row
        is appended (what a recorder reading the new rows now and then needs)."""
        return self._snapshot(copy=False)

    def _snapshot(self, copy: bool) -> SimulationLog:
        self._flush()
        if self._spool is not None:
            return self._freeze_spooled()
        n = self.n
        return self._log_of(self.rows[:n], self.obstacles[:n], copy=copy)

    def _freeze_spooled(self) -> SimulationLog:
        """The log as views of the spool's memory maps (copy-on-write: a consumer
        that writes into an array changes its own pages, never the file)."""
        self._spill()
        assert self._spool is not None  # _spill made it
        rows, obstacles = self._spool.maps(self.n, self.width, len(self.obstacle_ids))
        return self._log_of(rows, obstacles, copy=False)

    def _log_of(self, rows: np.ndarray, obstacles: np.ndarray, copy: bool) -> SimulationLog:
        """A SimulationLog of the (n, width) per-step matrix and (n, columns, 4) obstacle
        block."""

        def take(array):
            return array.copy() if copy else array

        fields, start = {}, 0
        for name, width in self._FIELDS.items():
            column = rows[:, start : start + width]
            fields[name] = take(column[:, 0] if name in ("time_s", "disturbance") else column)
            start += width
        return SimulationLog(
            **fields,
            obstacle_xy=take(obstacles[:, :, 0:2]),
            obstacle_radii_m=np.asarray(self.obstacle_radii, dtype=float),
            obstacle_ids=list(self.obstacle_ids),
            center_distance_m=take(obstacles[:, :, 2]),
            clearance_m=take(obstacles[:, :, 3]),
        )


def _spool_file():
    return tempfile.TemporaryFile(prefix="fuzzynav-log-")


@contextlib.contextmanager
def _spool_errors():
    """An OSError of the log's spool (a full disk) said as what it is and where."""
    try:
        yield
    except OSError as exc:
        raise OSError(
            exc.errno,
            f"{exc.strerror or exc}: the run's log did not fit in memory's block "
            f"({LOG_BLOCK_BYTES / 1024**2:g} MiB) and the rest could not be written to its "
            "temporary file in this folder; free space there, or set TMPDIR to a folder "
            "with room",
            tempfile.gettempdir(),
        ) from exc


class _LogSpool:
    """The rows of a long run's log that left memory: per-step floats in one unnamed
    temporary file, per obstacle column (x, y, centre distance, clearance) in another,
    row after row as float64 (the bytes of the arrays, so the values are the same to the
    bit). Unnamed: nothing is left behind however the process ends; the space is freed
    when the last map of it is gone. The directory is Python's temporary one
    (``TMPDIR``)."""

    def __init__(self):
        with _spool_errors():
            self.rows_file = _spool_file()
            self.obstacles_file = _spool_file()

    def append(self, rows: np.ndarray, obstacles: np.ndarray) -> None:
        with _spool_errors():
            self.rows_file.write(np.ascontiguousarray(rows).data)
            if obstacles.size:
                self.obstacles_file.write(np.ascontiguousarray(obstacles).data)

    def widen(self, spooled_rows: int, old_columns: int, new_columns: int) -> None:
        """An obstacle appeared: the ``spooled_rows`` rows get NaN columns for it (a new
        file, written a block at a time; maps of the old one stay valid)."""
        old = self.obstacles_file
        with _spool_errors():
            old.flush()
            old.seek(0)
            new = _spool_file()
            block = max(1, LOG_BLOCK_BYTES // (new_columns * 4 * 8))
            done = 0
            while done < spooled_rows:
                m = min(block, spooled_rows - done)
                wide = np.full((m, new_columns, 4), np.nan)
                if old_columns:
                    part = np.frombuffer(old.read(m * old_columns * 4 * 8), dtype=np.float64)
                    wide[:, :old_columns] = part.reshape(m, old_columns, 4)
                new.write(wide.data)
                done += m
        self.obstacles_file = new
        old.close()

    def maps(self, n: int, width: int, n_columns: int) -> tuple[np.ndarray, np.ndarray]:
        """The first ``n`` rows: ``(n, width)`` per-step floats, ``(n, n_columns, 4)``
        per obstacle."""
        with _spool_errors():
            self.rows_file.flush()
            self.obstacles_file.flush()
        rows = np.memmap(self.rows_file, dtype=np.float64, mode="c", shape=(n, width))
        obstacles: np.ndarray
        if n_columns:
            obstacles = np.memmap(
                self.obstacles_file, dtype=np.float64, mode="c", shape=(n, n_columns, 4)
            )
        else:
            obstacles = np.empty((n, 0, 4))
        return rows, obstacles


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
        self._log = _LogBuffer(capacity, log_block_rows(len(sc.obstacles)))
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
            left, right = np.asarray(raw, dtype=float).reshape(2).tolist()
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
        if math.hypot(target_xy[0] - x, target_xy[1] - y) <= self.scenario.tolerance_m:
            self.outcome = "reached"
        elif new_contacts and self.stop_on_collision:
            self.outcome = "collided"
        elif arena.time_s >= self._timeout_at_s:
            self.outcome = "timeout"
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
