"""A run's events marked on its time-series plots: the closest
approaches, the stretches inside the safe distance (where they begin and end), the
disturbance switched on and off and the end of the run, each a marker on the curves of
every plot at its time, beside the lanes and the log that say them in words.

Every plot has one entity more per kind of mark, ``<plot>/events/<key>``
(``/plots/distance/events/closest``...): rerun's ``Scalars`` at the events' times,
drawn as points (``SeriesPoints``) in the kind's colour and under its name
(:func:`mark_kinds`: a diamond for a closest approach, down and up triangles where a
stretch inside the safe distance begins and ends, right and left triangles for the
disturbance on and off, an asterisk for the target reached, a cross for a collision;
the shape logged with each row, the colour and the name once), so that each legend
entry has its kind's colour. A mark sits on
a curve of its plot, so that it is seen where the run was then and is inside the plot's
value range: an obstacle's own curve for that obstacle's events where the plot has one
(distance, obstacle angles, clearance), else the plot's first curve with a value at
that time (on the clearance panel never above the part shown); a plot with no value at
an event's time (the sensor ranges without an echo) has no mark there. The marks that
fall at the same times go out together.
"""

from __future__ import annotations

import numpy as np

from fuzzynav.app.figures.style import obstacle_label

from .sending import Columns
from .series import shared_views
from .style import BREACH, COLLISION, DISTURBANCE, EVENT, TARGET

#: The marks' size (rerun's marker size: a radius in UI points).
MARK_SIZE = 6.0
EVENTS_CHILD = "events"  # <plot>/events/<kind>


def mark_kinds(events, obstacle_ids) -> list[dict]:
    """Every kind of mark the run's events make, one colour and one legend entry each
    (at most four: a panel's legend has room for few): ``{"key", "name", "color",
    "marks": [(time_s, row or None, obstacle id or None, marker)]}``. A closest
    approach is a diamond in the events' colour (as in the world; it sits on its
    obstacle's curve where the plot has one), a stretch inside the safe distance a
    triangle down where it begins and up where it ends, the disturbance a triangle
    right when on and left when off, the end an asterisk (reached; grey: timeout) or a
    cross (collided)."""
    ids = list(obstacle_ids)
    kinds: dict[str, dict] = {}

    def add(key, name, color, mark):
        kinds.setdefault(key, {"key": key, "name": name, "color": color, "marks": []})[
            "marks"
        ].append(mark)

    last = events[-1] if events else None
    collided_row = last.row if last is not None and last.kind == "collided" else None
    for e in events:
        if e.kind == "closest" and e.obstacle in ids:
            if collided_row is not None and e.row == collided_row:
                continue  # the collision's mark says it (as in the world view)
            add("closest", "closest approach", EVENT, (e.time_s, e.row, e.obstacle, "diamond"))
        elif e.kind == "safe distance":
            name = "safe distance in / out"
            add("safe_distance", name, BREACH, (e.time_s, None, e.obstacle, "down"))
            add("safe_distance", name, BREACH, (e.end_s, None, e.obstacle, "up"))
        elif e.kind in ("disturbance on", "disturbance off"):
            marker = "right" if e.kind.endswith("on") else "left"
            add("disturbance", "disturbance on / off", DISTURBANCE, (e.time_s, None, None, marker))
    if last is not None and last.kind not in ("closest", "approaching at the end"):
        style = {
            "reached": ("asterisk", TARGET),
            "collided": ("cross", COLLISION),
        }.get(last.kind, ("asterisk", (110, 110, 110)))
        add("end", last.kind, style[1], (last.time_s, last.row, None, style[0]))
    for kind in kinds.values():
        kind["marks"].sort(key=lambda mark: mark[0])
    return list(kinds.values())


def _row_at(time_s: np.ndarray, t: float) -> int:
    """The log's row at time ``t`` (the last row at or before it)."""
    k = int(np.searchsorted(time_s, t + 1e-9, side="right")) - 1
    return min(max(k, 0), len(time_s) - 1)


def _plot_rows(writer, log, rows) -> dict[int, dict[str, tuple]]:
    """{row: {view path: (names, values)}} of every plot at each of ``rows``."""
    out = {}
    for k in sorted(set(rows)):
        series = writer._series(
            log,
            k,
            k + 1,
            log.pose[k : k + 1],
            log.target_xy[k : k + 1],
            log.ranges_m[k : k + 1],
            log.inputs[k : k + 1],
        )
        plots = {
            path: (list(names), np.asarray(cols, float)[0]) for path, names, _, _, cols in series
        }
        for view, paths in shared_views().items():  # (the angles: one panel, Fig. 14)
            parts = [plots.pop(p) for p in paths if p in plots]
            if parts:
                plots[view] = (
                    [n for names, _ in parts for n in names],
                    np.concatenate([v for _, v in parts]),
                )
        out[k] = {p: v for p, v in plots.items() if v[0]}
    return out


def _mark_value(names, values, obstacle, top) -> float:
    """Where a mark sits on a plot (its series ``names``, their ``values``): on the
    obstacle's curve if the plot has one, else on the first curve with a value; NaN if
    none has (no mark)."""
    label = None if obstacle is None else obstacle_label(obstacle)  # the series' name
    if label is not None and label in names:
        value = float(values[names.index(label)])
    else:
        finite = values[np.isfinite(values)]
        value = float(finite[0]) if finite.size else float("nan")
    return min(value, top) if np.isfinite(value) and top is not None else value


def send_plot_events(rec, writer, log, events, static) -> dict[str, int]:
    """Mark ``events`` (:func:`.events.run_events`) on every plot of ``writer`` (a
    :class:`~.columns.ColumnWriter` that sent ``log``), one child entity per kind of
    mark (``<plot>/events/<key>``), its shape, colour and name static; the styles go
    into ``static``. Returns ``{view path: legend entries added}`` for the legends'
    placement."""
    if not len(log) or not events:
        return {}
    from .series import CLEARANCE_SHOWN_M

    time_s = np.asarray(log.time_s, dtype=float)
    kinds = mark_kinds(events, log.obstacle_ids)
    if not kinds:
        return {}
    marks = [
        [
            (t, row if row is not None else _row_at(time_s, t), oid, marker)
            for t, row, oid, marker in kind["marks"]
        ]
        for kind in kinds
    ]
    values_at = _plot_rows(writer, log, [m[1] for kind in marks for m in kind])
    tops = {"/plots/clearance": 0.97 * CLEARANCE_SHOWN_M}
    first = marks[0][0][1]
    by_rows: dict[tuple, list] = {}  # the columns on the same rows: one batch
    entries: dict[str, int] = {}
    for path in values_at[first]:
        for kind, kind_marks in zip(kinds, marks):
            column = np.array(
                [
                    _mark_value(*values_at[row][path], oid, tops.get(path))
                    for _, row, oid, _ in kind_marks
                ]
            )
            keep = np.isfinite(column)
            if not keep.any():
                continue
            entity = f"{path}/{EVENTS_CHILD}/{kind['key']}"
            times = np.array([m[0] for m in kind_marks])[keep]
            rows = np.array([m[1] for m in kind_marks])[keep]
            shapes = [m[3] for m, kept in zip(kind_marks, keep) if kept]
            by_rows.setdefault((times.tobytes(), rows.tobytes()), [times, rows, []])[2].append(
                (entity, column[keep, None], shapes)
            )
            static.add(
                entity,
                "SeriesPoints",
                names=kind["name"],
                colors=kind["color"],
                marker_sizes=MARK_SIZE,
            )
            entries[path] = entries.get(path, 0) + 1
    for times, rows, columns in by_rows.values():
        batch = Columns(times, rows)
        for entity, column, shapes in columns:
            batch.add_series(entity, column)
            batch.add(entity, "SeriesPoints", "markers", shapes)
        batch.send(rec)
    return entries
