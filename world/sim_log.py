"""The log of one run: its per-step arrays and how they are kept while the run goes on.

:class:`SimulationLog` is the finished log (row ``k`` holds the state at ``time_s[k]``;
see :mod:`world.simulation`). While a run goes on, :class:`_LogBuffer` collects its rows
as plain floats and writes them into wide matrices a block at a time; a long run's rows
beyond :data:`LOG_BLOCK_BYTES` go to :class:`_LogSpool`, a pair of unnamed temporary
files, and come back as copy-on-write memory maps, so a run's memory does not grow with
its length.
"""

from __future__ import annotations

import contextlib
import math
import struct
import tempfile
from dataclasses import dataclass
from typing import Any

import numpy as np

from fuzzynav.world.run_limits import LOG_FLOATS_PER_OBSTACLE, LOG_FLOATS_PER_STEP

#: The most the log of one run keeps in memory: a longer run's rows go to an
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
    ranges_m: np.ndarray  # (N, n_sensors): the range sensors' readings, in mount order
    target_xy: np.ndarray  # (N, 2)
    obstacle_xy: np.ndarray  # (N, n_obstacles, 2); NaN while an obstacle is absent
    obstacle_radii_m: np.ndarray  # (n_obstacles,)
    obstacle_ids: list[int]
    center_distance_m: np.ndarray  # (N, n_obstacles): robot centre to obstacle centre
    clearance_m: np.ndarray  # (N, n_obstacles): footprint to obstacle surface

    def __len__(self) -> int:
        return len(self.time_s)


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

    def __init__(self, capacity: int, block_rows: int, n_sensors: int = 3):
        self.n = 0
        #: ``_FIELDS`` with this run's number of range sensors
        self.fields = {**self._FIELDS, "ranges_m": n_sensors}
        # block_rows: rows kept in memory at most; fuller blocks are written out to the
        # spool, a pair of unnamed temporary files.
        self.block_rows = max(block_rows, self._FLUSH_ROWS)
        self.capacity = max(min(capacity, self.block_rows), 16)
        self._spool: _LogSpool | None = None
        self._spilled = 0  # rows in the spool, before those in the matrices
        self.width = sum(self.fields.values())
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
        """Log one row: ``row`` in ``fields`` order; per obstacle present (``ids``),
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
        for name, width in self.fields.items():
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
