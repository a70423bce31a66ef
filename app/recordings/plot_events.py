"""A run's events marked on its time-series plots: the closest
approaches, the stretches inside the safe distance (where they begin and end), the
disturbance switched on and off and the end of the run, each a marker on the curves of
every plot at its time, beside the lanes and the log that say them in words.

Every plot has one more entity, ``<plot>/events`` (``/plots/distance/events``...):
rerun's ``Scalars`` at the events' times, drawn as points (``SeriesPoints``) whose
shape and colour are logged with each row (:func:`mark_kinds`: a diamond in the
obstacle's colour for a closest approach, down and up triangles where a stretch inside
the safe distance begins and ends, right and left triangles for the disturbance on and
off, an asterisk for the target reached, a cross for a collision), under one name,
"events" (one legend entry). A mark sits on a curve of its plot, so that it is seen
where the run was then and is inside the plot's value range: an obstacle's own curve
for that obstacle's events where the plot has one (distance, obstacle angles,
clearance), else the plot's first curve with a value at that time (on the clearance
panel never above the part shown); a plot with no value at an event's time (the sensor
ranges without an echo) has no mark there. The plots whose marks fall at the same
times go out in one record batch (one chunk per entity, as ``send_columns`` would
make): one batch for most runs, where a batch for each kind of event cost 3 ms apiece.
"""

from __future__ import annotations

import numpy as np

from fuzzynav.app.figures.style import obstacle_label

from .arrow import RowBatch
from .series import shared_views
from .style import BREACH, COLLISION, DISTURBANCE, TARGET, obstacle_color

#: The marks' size (rerun's marker size: a radius in UI points).
MARK_SIZE = 6.0
#: The one name every mark has (in a legend: one entry; a panel's legend has room for
#: few, and rerun 0.41 left out a fifth). Which event a mark is says its shape and
#: colour, and the lanes and the log at its time.
MARK_NAME = "events"
EVENTS_CHILD = "events"  # <plot>/events


def mark_kinds(events, obstacle_ids) -> list[dict]:
    """Every kind of mark the run's events make: ``{"key", "name", "marker", "color",
    "marks": [(time_s, row or None, obstacle id or None)]}``; ``name`` says the kind of
    event (every mark's legend name is :data:`MARK_NAME`)."""
    ids = list(obstacle_ids)
    kinds: dict[str, dict] = {}

    def add(key, name, marker, color, mark):
        kinds.setdefault(
            key, {"key": key, "name": name, "marker": marker, "color": color, "marks": []}
        )["marks"].append(mark)

    last = events[-1] if events else None
    collided_row = last.row if last is not None and last.kind == "collided" else None
    for e in events:
        if e.kind == "closest" and e.obstacle in ids:
            if collided_row is not None and e.row == collided_row:
                continue  # the collision's mark says it (as in the world view)
            color = obstacle_color(ids.index(e.obstacle))
            add(
                f"closest_{e.obstacle}",
                "closest approach",
                "diamond",
                color,
                (e.time_s, e.row, e.obstacle),
            )
        elif e.kind == "safe distance":
            add("safe_in", "safe distance in/out", "down", BREACH, (e.time_s, None, e.obstacle))
            add("safe_out", "safe distance in/out", "up", BREACH, (e.end_s, None, e.obstacle))
        elif e.kind in ("disturbance on", "disturbance off"):
            key = e.kind.replace(" ", "_")
            marker = "right" if e.kind.endswith("on") else "left"
            add(key, "disturbance on/off", marker, DISTURBANCE, (e.time_s, None, None))
    if last is not None and last.kind not in ("closest", "approaching at the end"):
        style = {
            "reached": ("asterisk", TARGET),
            "collided": ("cross", COLLISION),
        }.get(last.kind, ("asterisk", (110, 110, 110)))
        add("end", last.kind, style[0], style[1], (last.time_s, last.row, None))
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
    :class:`~.columns.ColumnWriter` that sent ``log``); the styles go into ``static``.
    Returns ``{view path: legend entries added}`` for the legends' placement."""
    import pyarrow as pa

    if not len(log) or not events:
        return {}
    from .series import CLEARANCE_SHOWN_M
    from .style import rgba

    time_s = np.asarray(log.time_s, dtype=float)
    marks = sorted(
        (
            (t, row if row is not None else _row_at(time_s, t), oid, kind)
            for kind in mark_kinds(events, log.obstacle_ids)
            for t, row, oid in kind["marks"]
        ),
        key=lambda mark: mark[0],
    )
    if not marks:
        return {}
    times = np.array([m[0] for m in marks], dtype=float)
    shapes = np.array([_marker(m[3]["marker"]) for m in marks], dtype=np.uint8)
    colors = np.array([rgba(m[3]["color"]) for m in marks], dtype=np.uint32)
    values_at = _plot_rows(writer, log, [m[1] for m in marks])
    tops = {"/plots/clearance": 0.97 * CLEARANCE_SHOWN_M}
    by_mask: dict[tuple, list] = {}  # plots with a mark at the same events: one batch
    for path in values_at[marks[0][1]]:
        column = np.array(
            [_mark_value(*values_at[row][path], oid, tops.get(path)) for _, row, oid, _ in marks]
        )
        mask = tuple(bool(x) for x in np.isfinite(column))
        if any(mask):
            by_mask.setdefault(mask, []).append((path, column))
    entries = {}
    for mask, plots in by_mask.items():
        keep = np.array(mask)
        batch = RowBatch(times[keep])
        shape_array, color_array = pa.array(shapes[keep]), pa.array(colors[keep])
        for path, column in plots:
            entity = f"{path}/{EVENTS_CHILD}"
            batch.add_series(entity, column[keep, None])
            batch.add(entity, "SeriesPoints", "markers", shape_array)
            batch.add(entity, "SeriesPoints", "colors", color_array)
            static.add(entity, "SeriesPoints", names=MARK_NAME, marker_sizes=MARK_SIZE)
            entries[path] = 1
        batch.send(rec)
    return entries


def _marker(name: str) -> int:
    import rerun as rr

    return int(rr.components.MarkerShape.auto(name).value)
