"""The column writer that :func:`~fuzzynav.app.recordings.record.record_run` and
:class:`~fuzzynav.app.recordings.live.LiveRecorder` share, and the recording's plots.

Every plot is one entity with one instance per series (named in the legend), in
:func:`plot_layout`'s order, declared with its columns in :data:`.series.PLOTS`; the
writer sends rows [start, end) of a run's log at a
time, the world through :class:`~fuzzynav.app.recordings.scene.SceneColumns` and the
controller's inside through :class:`~fuzzynav.app.recordings.internals.ControllerColumns`.
"""

from __future__ import annotations

import numpy as np

from .internals import (
    INTERNALS,
    INTERNALS_PATH,
    ControllerColumns,
    RuleHeat,
    has_internals,
    rule_system,
)
from .legend import LegendFit, legend_placement
from .scene import SceneColumns
from .sending import Columns, Statics
from .series import Rows, Setup, plot_spec, shared_views

#: Rows of the log read at a time to place the legends of a run recorded whole.
LEGEND_BLOCK_ROWS = 5000


def _plot_spec(obstacle_ids, sensor_names, voltage_limit_v: float = 12.0) -> list[tuple]:
    """(path, series names, colours, widths) of every plot but the rules: the table of
    :mod:`.series`, in its order."""
    setup = Setup(tuple(obstacle_ids), tuple(sensor_names), voltage_limit_v)
    return [(plot.path, *series) for plot, *series in plot_spec(setup)]


def plot_layout(obstacle_ids, sensor_names, voltage_limit_v: float = 12.0) -> dict[str, list[str]]:
    """Every plot entity of a recording and the names of its series, in instance order
    (instance j of a row of ``path`` is series ``names[j]``); a plot without series (no
    obstacles) is not logged."""
    return {
        path: names
        for path, names, _, _ in _plot_spec(obstacle_ids, sensor_names, voltage_limit_v)
        if names
    }


class ColumnWriter(SceneColumns, ControllerColumns):
    """Sends rows [start, end) of a SimulationLog as columns; remembers what it sent so
    that the next chunk continues it (trail segments, obstacle changes, styles). The
    world's entities are :class:`~fuzzynav.app.recordings.scene.SceneColumns`', the
    controller's inside :class:`~fuzzynav.app.recordings.internals.ControllerColumns`';
    this class holds the state they share, the plots and the chunk."""

    def __init__(
        self,
        rec,
        *,
        footprint_m,
        sensor_config,
        voltage_limit_v: float,
        fis=None,
        tolerance_m: float = 0.15,
        controller=None,
        perception: str | None = None,
        geometry: str = "husky",
        decisions: int | None = None,
        legends_from_log: bool = False,
    ):
        self.rec = rec
        # Ideal perception uses no range sensor: no beams are drawn, but the line to the
        # obstacle the controller reacts to (the nearest: by clearance, or centre to
        # centre in the paper's geometry).
        self.draw_beams = perception != "ideal"
        self.geometry = geometry
        self.controller = controller
        self.internals = has_internals(controller)
        # A decision: the voltages, the internals, then the inputs of the blocks' rules.
        blocks = rule_system(controller) if self.internals and fis is None else None
        self.blocks = blocks
        self.decision_width = 2 + len(INTERNALS) + (len(blocks.inputs) if blocks else 0)
        self.internals_source: str | None = None  # "decisions" or "replay", from chunk 1
        self.replica = None
        self.replica_error: str | None = None
        self._flag_states: dict[str, str] = {}  # each flag's lane state at the last row
        self.footprint_m = (float(footprint_m[0]), float(footprint_m[1]))
        self.sensor_config = sensor_config
        self.sensor_names = [m.name for m in sensor_config.mounts]
        self.voltage_limit_v = float(voltage_limit_v)
        self.fis = fis
        self.fis_error: str | None = None
        self.tolerance_m = float(tolerance_m)
        self.sent = 0
        self._styled: set[str] = set()
        self._plot_styles: dict[str, tuple] = {}
        self._static = self.static = Statics()
        self._obstacles: dict[int, tuple[bool, tuple[float, float]]] = {}
        self._target: tuple[float, float] | None = None
        self.obstacle_ids: list[int] = []
        self.n_rules = 0
        # the heatmap, sent at the end: binned as the rows come when the number of
        # decisions (rows with finite voltages) is known in advance (record_run)
        self.rule_heat = RuleHeat(decisions)
        self._legend_samples: dict[str, list[np.ndarray]] = {}
        # Of the plots made from the log only the value range is kept as the rows go,
        # and legend_corners reads the rows under the legends from the log again: for a
        # run whose length is known (record_run) and for a live recording, whose
        # simulation still has the log at its close (LiveRecorder). Otherwise every
        # plotted row is kept.
        self.legends_from_log = bool(legends_from_log)
        self._legend_ranges: dict[str, list] = {}  # path: [lo, hi, widths, rows]
        #: Legend entries a plot has beyond its series (view path: count): the events'
        #: marks (:func:`.plot_events.send_plot_events`), set before the legends' placement.
        self.legend_extra: dict[str, int] = {}

    # -- low level ---------------------------------------------------------------------

    def _send_sparse(self, path: str, time_s, archetype: str, name: str, values, lengths=None):
        """A component on rows of its own (where something changed: the target, the
        obstacles), sent at the chunk's end with every other column on the same rows in
        one record batch (a static obstacle's body, ring and translation, and the
        target, all at the first row: one batch, not a send_columns call each)."""
        time_s = np.asarray(time_s, dtype=float)
        steps = self._rows_start + np.searchsorted(self._rows_time, time_s)
        self._columns_at(time_s, steps).add(path, archetype, name, values, lengths=lengths)

    def _columns_at(self, time_s: np.ndarray, steps) -> Columns:
        """The chunk's columns on the rows at ``time_s`` (the log's rows ``steps``)."""
        key = np.asarray(time_s, dtype=float).tobytes()
        if key not in self._sparse:
            self._sparse[key] = Columns(time_s, steps)
        return self._sparse[key]

    def _style(self, path: str, archetype: str, **components) -> None:
        """Static styling of an entity, sent with the chunk's other styles."""
        if path not in self._styled:
            self._styled.add(path)
            self._static.add(path, archetype, **components)

    def _plot(self, path: str, names, colors, widths, columns) -> None:
        """One plot entity: ``columns`` (n, k) are k series, named ``names``."""
        if not names:  # e.g. obstacle angles without obstacles
            return
        style = (tuple(names), tuple(colors), tuple(widths))
        if self._plot_styles.get(path) != style:  # new, or obstacles were added
            self._plot_styles[path] = style
            self._static.add(
                path, "SeriesLines", names=list(names), colors=list(colors), widths=list(widths)
            )
        self._rows.add_series(path, columns)
        replayed = path == INTERNALS_PATH and self.internals_source != "decisions"
        if not self.legends_from_log or replayed:  # (a replay's state is in no log: kept)
            self._legend_samples.setdefault(path, []).append(np.array(columns, dtype=float))
            return
        values = np.asarray(columns, dtype=float)
        stats = self._legend_ranges.setdefault(path, [np.inf, -np.inf, set(), 0])
        stats[2].add(values.shape[1] if values.ndim == 2 else None)
        stats[3] += len(values)
        finite = values[np.isfinite(values)]
        if finite.size:
            stats[0] = min(stats[0], float(finite.min()))
            stats[1] = max(stats[1], float(finite.max()))

    def legend_corners(self, log=None) -> dict:
        """Per plot view, where its legend goes and the value range that leaves it room
        (:func:`legend_placement`): ``{view origin: (corner, range or None)}``. The
        entities that share a view (:func:`.series.shared_views`: /plots/angles, as
        Fig. 14 shows the target angle and the heading) are read as one plot. With
        ``legends_from_log`` (record_run, LiveRecorder) the plots made from the log are
        read again from ``log``, the rows under the legends only, a block at a time
        (:class:`LegendFit`: the same placements, without every row kept)."""
        samples = {}
        for path, parts in self._legend_samples.items():
            widths = {p.shape[1] for p in parts if p.ndim == 2}
            if len(widths) == 1:  # (obstacles added mid-run change the width: skip)
                samples[path] = np.concatenate(parts)
        for view, paths in shared_views().items():
            parts = [samples.pop(p) for p in paths if p in samples]
            if len(parts) == len(paths) and len({len(part) for part in parts}) == 1:
                samples[view] = np.hstack(parts)
        placements = {}
        for path, values in samples.items():
            placement = legend_placement(values, self._legend_entries(path))
            if placement is not None:
                placements[path] = placement
                finite = values[np.isfinite(values)]
                lo, hi = float(finite.min()), float(finite.max())
                pad = 0.05 * (hi - lo if hi > lo else max(abs(hi), 1.0))
                placements[f"{path}#data"] = (lo - pad, hi + pad)  # (a view without legend)
        if self._legend_ranges:
            if log is None:
                raise ValueError("legend_corners: the log is needed (legends_from_log)")
            placements.update(self._fitted_corners(log))
        return placements

    def _legend_entries(self, path: str) -> int:
        """How many entries the legend of the view ``path`` has: its series' names (of
        every entity it shows, :func:`.series.shared_views`) and its marks."""
        paths = shared_views().get(path, [path])
        names = {n for p in paths for n in self._plot_styles.get(p, ((),))[0]}
        return len(names) + self.legend_extra.get(path, 0)

    def _fitted_corners(self, log) -> dict:
        """:meth:`legend_corners` of the plots whose value ranges were kept."""
        ranges = {p: r for p, r in self._legend_ranges.items() if len(r[2]) == 1 and r[2] != {None}}
        views = shared_views()
        parts = {
            view: [ranges.pop(p) for p in paths if p in ranges] for view, paths in views.items()
        }
        members = {path: [path] for path in ranges}
        for view, kept in parts.items():
            if len(kept) == len(views[view]) and len({r[3] for r in kept}) == 1:
                lo, hi = min(r[0] for r in kept), max(r[1] for r in kept)
                ranges[view] = [lo, hi, None, kept[0][3]]
                members[view] = list(views[view])
        fits, rows = {}, {}
        for path, (lo, hi, _, n) in ranges.items():
            if n and lo <= hi:  # (no finite value: no placement)
                fits[path] = LegendFit(lo, hi, self._legend_entries(path))
                rows[path] = n
        for n in set(rows.values()):
            feeds = {}  # entity -> the fits its rows go to
            for path, fit in fits.items():
                if rows[path] == n:
                    for member in members[path]:
                        feeds.setdefault(member, []).append(fit)
            first, last = LegendFit.window(n)
            spans = [(0, first), (last, n)] if first < last else [(0, n)]
            for a, b in spans:
                for start in range(a, b, LEGEND_BLOCK_ROWS):
                    end = min(start + LEGEND_BLOCK_ROWS, b)
                    series = []
                    if set(feeds) - {INTERNALS_PATH}:
                        pose = log.pose[start:end]
                        target = log.target_xy[start:end]
                        series = self._series(
                            log,
                            start,
                            end,
                            pose,
                            target,
                            log.ranges_m[start:end],
                            log.inputs[start:end],
                        )
                    if INTERNALS_PATH in feeds:
                        series.append(
                            (INTERNALS_PATH, 0, 0, 0, self._logged_state(log, start, end))
                        )
                    for path, _, _, _, columns in series:
                        for fit in feeds.get(path, ()):
                            fit.add(n, start, columns)
        placements = {}
        for path, fit in fits.items():
            placements[path] = fit.placement()
            placements[f"{path}#data"] = (fit.lo - fit.pad, fit.hi + fit.pad)
        return placements

    def _series(self, log, start, end, pose, target, ranges, inputs):
        """(path, names, colors, widths, columns) of every plot, in :func:`plot_layout`'s
        order (:data:`.series.PLOTS`'); ``columns`` is (rows, series)."""
        limit = self.voltage_limit_v
        rows = Rows(log, start, end, pose, target, ranges, inputs, limit)
        setup = Setup(tuple(log.obstacle_ids), tuple(self.sensor_names), limit)
        return [
            (plot.path, names, colors, widths, plot.columns(rows))
            for plot, names, colors, widths in plot_spec(setup)
        ]

    # -- one chunk ---------------------------------------------------------------------

    def send(self, log, start: int, end: int, *, send_static: bool = True) -> None:
        """Send rows [start, end); with ``send_static`` also the static components
        collected so far (else the caller sends ``self.static``)."""
        if end <= start:
            return
        t = log.time_s[start:end]
        rows = self._rows = Columns(t, np.arange(start, end))
        self._sparse: dict[bytes, Columns] = {}
        self._rows_time, self._rows_start = t, start
        pose = log.pose[start:end]

        # -- the robot, and the target (only the rows where it moved)
        self._send_robot(log, start, pose, rows)
        target = log.target_xy[start:end]
        self._send_target(t, target)

        # -- the obstacles
        self.obstacle_ids = list(log.obstacle_ids)
        for col, oid in enumerate(log.obstacle_ids):
            self._send_obstacle(log, col, oid, start, end, t)

        # -- the sensors, or (ideal perception) the obstacle the controller reacts to
        ranges = log.ranges_m[start:end]
        if self.draw_beams:
            self._send_beams(pose, ranges, rows)
        else:
            self._send_sensed(log, start, end, pose, rows)

        # -- time series: one entity per plot, one instance (series) per column
        inputs = log.inputs[start:end]
        for path, names, colors, widths, columns in self._series(
            log, start, end, pose, target, ranges, inputs
        ):
            self._plot(path, names, colors, widths, columns)

        # -- rule firing strengths (rows with a decision: the last row has none)
        decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
        if self.fis is not None and self.fis_error is None:
            try:
                strengths = np.asarray(self.fis.firing_strengths(inputs), dtype=float)
            except Exception as exc:  # a fuzzy system of another shape: record why not
                self.fis_error = f"{type(exc).__name__}: {exc}"
            else:
                self._plot_rules(strengths, decided)
        if self.internals and self.replica_error is None:
            self._internals(log, start, end)
        if send_static:
            self._static.send(self.rec)
        rows.send(self.rec)
        for batch in self._sparse.values():
            batch.send(self.rec)
        self.sent = end
