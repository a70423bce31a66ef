"""How a recording's data go to rerun, through its public API: the two timelines, the
columns of many entities on the same rows (``rr.send_columns`` with the archetypes'
``columns``), and the static parts (``rr.log(..., static=True)``).

A recording sends whole columns, never one call per step: :class:`Columns` gathers the
columns of every entity that has a row at the same steps (a chunk of the log) and sends
them an entity at a time; :class:`Statics` gathers the static components (styles,
documents) and logs them at the end of a chunk.

``rerun`` is imported inside the functions: the command line imports the recordings for
their options on every call.
"""

from __future__ import annotations

import numpy as np

#: The simulated time, a duration (nanosecond resolution).
TIMELINE = "sim_time"
#: The second timeline: the log's row, the control step (row N of the ``--trace`` CSV,
#: the first row after its header being 0), to jump to a row of the trace.
STEP_TIMELINE = "step"


def time_indexes(time_s, steps) -> list:
    """The ``send_columns`` indexes of rows at ``time_s`` (s), the log's rows ``steps``.

    Parameters
    ----------
    time_s : array of float
        Simulated times (s).
    steps : array of int
        The log's rows at those times.
    """
    import rerun as rr

    nanos = np.round(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64)
    return [
        rr.TimeColumn(TIMELINE, duration=nanos.astype("timedelta64[ns]")),
        rr.TimeColumn(STEP_TIMELINE, sequence=np.asarray(steps, dtype=np.int64)),
    ]


def steps_at(log_time_s: np.ndarray, time_s) -> np.ndarray:
    """The log's row at each of ``time_s`` (the last at or before it).

    Parameters
    ----------
    log_time_s : array of float
        The log's times (s), rising.
    time_s : array of float
        The times to find.
    """
    rows = np.searchsorted(log_time_s, np.asarray(time_s, dtype=float) + 1e-9, side="right") - 1
    return np.clip(rows, 0, max(len(log_time_s) - 1, 0)).astype(np.int64)


class Columns:
    """The columns of many entities on the same rows (times ``time_s``, the log's rows
    ``steps``), sent with ``rr.send_columns``, one call an entity."""

    def __init__(self, time_s, steps):
        self.time_s = np.asarray(time_s, dtype=float)
        self.steps = np.asarray(steps, dtype=np.int64)
        self.n = len(self.time_s)
        self._entities: dict[str, list] = {}

    def add(self, entity: str, archetype: str, name: str, values, lengths=None) -> None:
        """The component ``name`` of the archetype ``archetype`` (``"Points2D"``...):
        one instance per row of ``values``, or ``lengths[i]`` of them in row i (0: the
        row clears it)."""
        import rerun as rr

        columns = getattr(rr, archetype).columns(**{name: values})
        if lengths is not None:
            columns = columns.partition(np.asarray(lengths, dtype=np.int64))
        self._entities.setdefault(entity, []).extend(columns)

    def add_columns(self, entity: str, columns) -> None:
        """Ready ``send_columns`` columns (``rr.ComponentColumn``) of ``entity``."""
        self._entities.setdefault(entity, []).extend(columns)

    def add_series(self, entity: str, values) -> None:
        """Scalars: ``values`` (rows, k) as k instances a row (a plot's k series)."""
        values = np.ascontiguousarray(values, dtype=np.float64)
        k = values.shape[1]
        self.add(entity, "Scalars", "scalars", values.reshape(-1), np.full(self.n, k))

    def send(self, rec) -> None:
        if not self.n:
            return
        indexes = time_indexes(self.time_s, self.steps)
        for entity, columns in self._entities.items():
            rec.send_columns(entity, indexes=indexes, columns=columns)
        self._entities = {}


class Statics:
    """Static components of many entities, logged together at the end of a chunk."""

    def __init__(self):
        self._logged: list[tuple[str, object]] = []

    def add(self, entity: str, archetype: str, **components) -> None:
        """Components of the archetype ``archetype`` (``"SeriesLines"``...) by name:
        those it has of one entity (a partial update, ``from_fields``)."""
        import rerun as rr

        self._logged.append((entity, getattr(rr, archetype).from_fields(**components)))

    def add_archetype(self, entity: str, archetype) -> None:
        """An ``rr`` archetype, whole."""
        self._logged.append((entity, archetype))

    def add_batches(self, entity: str, batches) -> None:
        """Component batches with their descriptors (``Batch(...).described(...)``):
        for an archetype whose ``from_fields`` needs a field not given (BarChart's)."""
        self._logged.append((entity, list(batches)))

    def send(self, rec) -> None:
        for entity, archetype in self._logged:
            rec.log(entity, archetype, static=True)
        self._logged = []
