"""The column writer that :func:`~fuzzynav.app.recordings.record.record_run` and
:class:`~fuzzynav.app.recordings.live.LiveRecorder` share: a run's rows [start, end)
at a time, as the world's entities (robot, target, obstacles, sensors; the geometry is
:mod:`world.geometry`'s, as the viewer and the figures draw it), the plots and the
controller's inside (rule firing, fuzzynav's state: :mod:`.internals`).

Every plot is one entity with one instance per series (named in the legend), in
:func:`plot_layout`'s order, declared with its columns in :data:`.series.PLOTS`.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.world.geometry import (
    beam_cones,
    beam_geometries,
    circle_points,
    footprint_outlines,
    points_along,
)

from .internals import (
    FLAG_COLORS,
    INTERNAL_FLAGS,
    INTERNAL_FLAGS_PATH,
    INTERNAL_WEIGHTS,
    INTERNALS,
    INTERNALS_PATH,
    RULES_HEATMAP_PATH,
    RULES_PATH,
    RULES_SCALE_PATH,
    RULES_STRONGEST_PATH,
    RULES_TEXT_PATH,
    RuleHeat,
    bar_chart_rows,
    controller_replica,
    has_internals,
    rule_system,
    send_heatmap_image,
)
from .legend import LegendFit, legend_placement
from .scene import TRAIL_DISTURBED_PATH
from .sending import Columns, Statics, time_indexes
from .series import Rows, Setup, plot_spec, shared_views
from .style import (
    BEAM_ORDER,
    DISTURBANCE,
    HEADING,
    HEADING_ARROW_M,
    HEADING_ORDER,
    OBSTACLE_ORDER,
    RING_SEGMENTS,
    ROBOT,
    ROBOT_ORDER,
    SAFE_DISTANCE_M,
    SAFE_RING,
    SENSED,
    SENSOR_COLORS,
    SERIES_PALETTE,
    TARGET,
    TRAIL,
    TRAIL_ORDER,
    obstacle_color,
)

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


class ColumnWriter:
    """Sends rows [start, end) of a SimulationLog as columns (:meth:`send`); remembers
    what it sent so that the next chunk continues it (trail segments, obstacle changes,
    the strongest rule, fuzzynav's flags, styles), and what the legends' placement and
    the rules' heatmap need at the end (:meth:`legend_corners`, :meth:`send_heatmap`)."""

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
        obstacles), sent at the chunk's end with every other column of the entity on
        the same rows (:meth:`_columns_at`)."""
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

    # -- the world: robot, target, obstacles, sensors -----------------------------------

    def _send_robot(self, log, start: int, pose, rows) -> None:
        """The footprint, the heading and the trail segment of every row."""

        self._style(
            "/world/robot/footprint",
            "LineStrips2D",
            colors=ROBOT,
            radii=0.015,
            draw_order=float(ROBOT_ORDER),
        )
        rows.add(
            "/world/robot/footprint",
            "LineStrips2D",
            "strips",
            footprint_outlines(pose, *self.footprint_m),
        )
        self._style(
            "/world/robot/heading",
            "Arrows2D",
            colors=HEADING,
            radii=0.035,
            draw_order=float(HEADING_ORDER),
        )
        heading = np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], axis=-1) * HEADING_ARROW_M
        rows.add(
            "/world/robot/heading",
            "Arrows2D",
            "origins",
            pose[:, :2],
        )
        rows.add(
            "/world/robot/heading",
            "Arrows2D",
            "vectors",
            heading,
        )
        previous = log.pose[start - 1, :2] if start > 0 else pose[0, :2]
        starts = np.vstack([previous[None, :], pose[:-1, :2]])
        self._style(
            "/world/robot/trail",
            "LineStrips2D",
            colors=TRAIL,
            radii=0.02,
            draw_order=float(TRAIL_ORDER),
        )
        rows.add(
            "/world/robot/trail",
            "LineStrips2D",
            "strips",
            np.stack([starts, pose[:, :2]], axis=1),
        )
        # The trail again, in the disturbance's colour, where the inputs were disturbed.
        disturbed = np.abs(log.disturbance[start : start + len(pose)]) > 0.0
        self._style(
            TRAIL_DISTURBED_PATH,
            "LineStrips2D",
            colors=DISTURBANCE,
            radii=0.045,
            draw_order=float(TRAIL_ORDER - 1),
        )
        rows.add(
            TRAIL_DISTURBED_PATH,
            "LineStrips2D",
            "strips",
            np.stack([starts[disturbed], pose[disturbed, :2]], axis=1),
            lengths=disturbed.astype(np.int32),
        )

    def _send_target(self, t, target) -> None:
        """The target, only at the rows where it moved (latest-at keeps it in between)."""
        keep = np.ones(len(t), bool)
        keep[1:] = np.any(target[1:] != target[:-1], axis=1)
        if self._target is not None:
            keep[0] = bool(np.any(target[0] != np.asarray(self._target)))
        if keep.any():
            k = np.flatnonzero(keep)
            self._style(
                "/world/target", "Points2D", colors=TARGET, radii=self.tolerance_m, labels="target"
            )
            self._send_sparse(
                "/world/target",
                t[k],
                "Points2D",
                "positions",
                target[k],
            )
        self._target = (float(target[-1, 0]), float(target[-1, 1]))

    def _send_sensed(self, log, start: int, end: int, pose, rows) -> None:
        """A line from the robot's centre to the centre of the obstacle the controller
        reacts to (the nearest, as ideal perception picks it), where it senses one."""
        d_o = log.inputs[start:end, 1]
        n = end - start
        if log.obstacle_xy.shape[1] == 0:
            sensed = np.zeros(n, bool)
            centres = np.zeros((n, 2))
        else:
            near = log.center_distance_m if self.geometry == "paper" else log.clearance_m
            near = np.where(np.isfinite(near[start:end]), near[start:end], np.inf)
            k = np.argmin(near, axis=1)
            centres = log.obstacle_xy[start:end][np.arange(n), k]
            sensed = np.isfinite(d_o) & np.all(np.isfinite(centres), axis=1)
        self._style(
            "/world/robot/sensed",
            "LineStrips2D",
            colors=SENSED,
            radii=0.025,
            draw_order=float(ROBOT_ORDER - 1),
        )
        strips = np.stack([pose[sensed, :2], centres[sensed]], axis=1)
        rows.add(
            "/world/robot/sensed",
            "LineStrips2D",
            "strips",
            strips,
            lengths=sensed.astype(np.int32),
        )

    def _send_beams(self, pose, ranges, rows) -> None:
        """The range sensors' cones, as long as their readings, and their echoes."""
        origins, directions = beam_geometries(pose, self.sensor_config.mounts)
        max_range = float(self.sensor_config.max_range_m)
        half = 0.5 * float(self.sensor_config.beam_width_rad)
        for k, name in enumerate(self.sensor_names):
            color = SENSOR_COLORS.get(name, (100, 100, 100))
            r = ranges[:, k]
            echo = np.isfinite(r)
            o, d = origins[:, k], directions[:, k]
            left, right = beam_cones(o, d, np.where(echo, r, max_range), half)
            self._style(
                f"/world/sensors/{name}/beam",
                "LineStrips2D",
                colors=(*color, 110),
                radii=0.006,
                draw_order=float(BEAM_ORDER),
            )
            rows.add(
                f"/world/sensors/{name}/beam",
                "LineStrips2D",
                "strips",
                np.stack([o, left, right, o], axis=1),
            )
            hits = points_along(o, d, np.where(echo, r, 0.0))[echo]
            self._style(f"/world/sensors/{name}/hit", "Points2D", colors=color, radii=0.06)
            rows.add(
                f"/world/sensors/{name}/hit",
                "Points2D",
                "positions",
                hits,
                lengths=echo.astype(np.int32),
            )

    def _send_obstacle(self, log, col: int, oid: int, start: int, end: int, t) -> None:
        xy = log.obstacle_xy[start:end, col]
        present = np.all(np.isfinite(xy), axis=1)
        radius = float(log.obstacle_radii_m[col])
        prev = self._obstacles.get(oid)
        # Rows where the obstacle appears, moves or vanishes (latest-at keeps the rest).
        changed = np.ones(len(xy), bool)
        same_presence = present[1:] == present[:-1]
        same_place = np.all(xy[1:] == xy[:-1], axis=1) | ~present[1:]
        changed[1:] = ~(same_presence & same_place)
        if prev is not None:
            was_present, was_xy = prev
            changed[0] = not (
                present[0] == was_present and (not present[0] or tuple(xy[0]) == was_xy)
            )
        rows = np.flatnonzero(changed)
        base = f"/world/obstacles/{oid}"
        if len(rows):
            lengths = present[rows].astype(np.int32)
            pos = xy[rows][present[rows]]
            # the obstacle's colour in every plot and figure (OBSTACLE_PALETTE by column)
            self._style(
                f"{base}/body",
                "Points2D",
                colors=obstacle_color(col),
                radii=radius,
                labels=obstacle_label(oid),
                draw_order=float(OBSTACLE_ORDER),
            )
            self._send_sparse(
                f"{base}/body",
                t[rows],
                "Points2D",
                "positions",
                pos,
                lengths,
            )
            # The safe ring, drawn around the obstacle at every row where it moves (a
            # circle moved by a transform was drawn where the obstacle ended, whatever
            # the time cursor said), none where it is absent.
            ring_path = f"{base}/safe_ring"
            self._style(ring_path, "LineStrips2D", colors=SAFE_RING, radii=0.01)
            circle = circle_points(radius + SAFE_DISTANCE_M, RING_SEGMENTS)
            self._send_sparse(
                ring_path,
                t[rows],
                "LineStrips2D",
                "strips",
                circle[None, :, :] + pos[:, None, :],
                lengths,
            )
            # The path: a segment for every move between two present rows.
            present_rows = rows[present[rows]]
            if len(present_rows):
                points = xy[present_rows]
                before = np.vstack([[np.nan, np.nan], points[:-1]])
                # A row right after an absence starts afresh (no segment across a gap).
                gap = np.ones(len(present_rows), bool)
                gap[1:] = np.diff(np.searchsorted(rows, present_rows)) != 1
                if prev is not None and prev[0]:
                    before[0] = prev[1]
                    gap[0] = rows[0] != present_rows[0]
                moved = ~gap & np.any(before != points, axis=1)
                if moved.any():
                    segs = np.stack([before[moved], points[moved]], axis=1)
                    # (the obstacle's own colour, paler: app.palette's)
                    self._style(
                        f"{base}/path",
                        "LineStrips2D",
                        colors=(*obstacle_color(col), 150),
                        radii=0.015,
                    )
                    self._send_sparse(
                        f"{base}/path",
                        t[present_rows[moved]],
                        "LineStrips2D",
                        "strips",
                        segs,
                    )
        last = len(xy) - 1
        self._obstacles[oid] = (
            bool(present[last]),
            (float(xy[last, 0]), float(xy[last, 1])) if present[last] else (math.nan, math.nan),
        )

    # -- the controller's inside: rule firing, fuzzynav's state ----------------------------

    def _plot_rules(self, strengths: np.ndarray, decided: np.ndarray) -> None:
        """Every rule's firing strength at every row with a decision as one bar chart
        (bar k-1 is rule Rk, its abscissa k; float32), taken into the run's heatmap
        (:class:`RuleHeat`, :meth:`send_heatmap`) and the strongest rule's lane. A row without a decision (the last) has no strengths:
        nothing is logged there, so the chart at the end shows the last decision's. One
        bar chart, not 40 lines in a 10-colour palette that made R1, R11 and R21 alike."""
        strengths = np.ascontiguousarray(strengths, dtype=np.float32)
        decided = np.asarray(decided, bool)
        self.n_rules = strengths.shape[1]
        if RULES_PATH not in self._styled:  # rule Rk at abscissa k (1 to n)
            import rerun as rr

            self._styled.add(RULES_PATH)
            numbers = np.arange(1, self.n_rules + 1, dtype=np.float32)
            self._static.add_batches(
                RULES_PATH,
                [
                    rr.components.ColorBatch([(230, 160, 40)]).described(
                        rr.BarChart.descriptor_color()
                    ),
                    rr.components.TensorDataBatch(numbers).described(
                        rr.BarChart.descriptor_abscissa()
                    ),
                ],
            )

            self._static.add_archetype(  # the chart's axis from 0 to 1, whatever fires
                RULES_SCALE_PATH,
                rr.BarChart(
                    np.array([1.0], dtype=np.float32),
                    abscissa=np.array([0.0], dtype=np.float32),
                    widths=np.array([0.35], dtype=np.float32),
                    color=(200, 200, 200),
                ),
            )
        times = np.asarray(self._rows_time, dtype=float)[decided]
        if decided.any():  # (only there: the chart at the final instant shows the last)
            steps = self._rows_start + np.flatnonzero(decided)
            self._columns_at(times, steps).add_columns(
                RULES_PATH, bar_chart_rows(strengths[decided])
            )
        steps = self._rows_start + np.flatnonzero(decided)
        self._send_strongest(times, steps, self.rule_heat.add(times, strengths[decided]))

    def _send_strongest(self, times: np.ndarray, steps, strengths: np.ndarray) -> None:
        """The strongest rule at each decision, where it changes (from the chunk before
        too): a labelled lane, sent a chunk at a time."""
        if not len(times):
            return
        import rerun as rr

        heat = self.rule_heat
        top = np.argmax(strengths, axis=1)
        fired = strengths[np.arange(len(top)), top] > 0
        state = np.where(fired, top, -1)
        change = np.ones(len(state), bool)
        change[1:] = state[1:] != state[:-1]
        change[0] = heat.last_state is None or state[0] != heat.last_state
        heat.last_state = int(state[-1])
        if not change.any():
            return
        labels = [f"R{k + 1}" if k >= 0 else "none fires" for k in state[change]]
        self.rec.send_columns(
            RULES_STRONGEST_PATH,
            indexes=time_indexes(times[change], steps[change]),
            columns=rr.StateChange.columns(state=labels),
            strict=True,
        )

    def send_heatmap(self, static: Statics) -> None:
        """The rule firing of the whole run as a heatmap: rules down, time across (at
        most :data:`HEATMAP_MAX_BINS` bins, each the max over its rows, so a brief
        firing stays visible), with the rules in words beside it (:class:`RuleHeat`
        collected it; the lane of the strongest rule went with the chunks)."""
        heat = self.rule_heat
        if not heat.calls:
            return
        import rerun as rr

        heatmap = heat.heatmap()
        bins = heatmap.shape[1]
        first, last = heat.first_s, heat.last_s
        span = f"{first:.2f} s to {last:.2f} s" if heat.count else "no rows"
        per_bin = (last - first) / max(bins - 1, 1) if heat.count > 1 else 0.0
        static.add_archetype(
            RULES_HEATMAP_PATH,
            rr.Tensor(
                heatmap,
                dim_names=[
                    f"rule R1-R{heatmap.shape[0]}",
                    f"time {span}, {per_bin:.3g} s a column",
                ],
                value_range=[0.0, 1.0],
            ),
        )
        if bins:
            send_heatmap_image(static, heatmap, first, per_bin)
        lines = [
            f"# Rule firing, {span}",
            "",
            f"Heatmap: row k, counted from 1 at the top, is rule Rk; {bins} columns over "
            f"the run ({heat.count} steps, the largest strength in each column).",
            "Bar chart: the bar at k (1 to n on its axis) is rule Rk, at the time cursor.",
            "",
        ]
        lines += [f"- **R{k + 1}**: {text}" for k, text in enumerate(self.rule_texts())]
        static.add_archetype(
            RULES_TEXT_PATH, rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN)
        )

    def rule_texts(self) -> list[str]:
        system = self.fis if self.fis is not None else self.blocks
        if system is None or not hasattr(system, "rule_text"):
            return [f"(rule {k + 1})" for k in range(self.n_rules)]
        return [system.rule_text(k) for k in range(min(self.n_rules, len(system.rules)))]

    def _internals(self, log, start: int, end: int) -> None:
        """Plot the controller's inner state on rows [start, end): from the decisions it
        logged while it drove (``decisions``), when they line up with the run (the same
        voltages, row for row), else by replaying the rows through the replica. Either
        way the state must come with exactly the voltages the run logged; if not (the
        controller was changed mid-run, say), nothing more is plotted and the metadata
        says why."""
        decided_v = log.controller_output_v[start:end]
        decided = np.all(np.isfinite(decided_v), axis=1)  # the last row has no decision
        out = np.full((end - start, len(INTERNALS)), np.nan)
        try:
            logged = self._logged_decisions(start, decided)
            decisions = logged if logged is not None else self._replay(log, start, decided)
        except ValueError as exc:  # decisions of another shape than this writer expects
            self.replica_error = f"its decisions do not fit ({exc})"
            return
        voltages, state = decisions[:, :2], decisions[:, 2 : 2 + len(INTERNALS)]
        # NaN (no decision to compare) counts as differing.
        differs = np.flatnonzero(~np.all(np.abs(voltages - decided_v[decided]) <= 1e-9, axis=1))
        if len(differs):
            k = start + np.flatnonzero(decided)[differs[0]]
            how = "logged decisions differ" if logged is not None else "replay differs"
            self.replica_error = f"its {how} from the run at t = {log.time_s[k]:.2f} s"
            return
        out[decided] = state
        weights = len(INTERNAL_WEIGHTS)
        self._plot(
            INTERNALS_PATH,
            list(INTERNAL_WEIGHTS),
            [SERIES_PALETTE[k % len(SERIES_PALETTE)] for k in range(weights)],
            [1.5] * weights,
            out[:, :weights],
        )
        self._send_flags(log, start, out[:, weights:], decided)
        if self.blocks is not None:
            strengths = np.full((end - start, len(self.blocks.rules)), np.nan)
            if decided.any():
                strengths[decided] = self.blocks.firing_strengths(
                    decisions[:, 2 + len(INTERNALS) :]
                )
            self._plot_rules(strengths, decided)

    def _logged_state(self, log, start: int, end: int) -> np.ndarray:
        """The inner state plotted on rows [start, end), read again from the driving
        controller's own decisions (as :meth:`_internals` plotted it from them; NaN at a
        row without a decision): for the legend of a run recorded whole."""
        decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
        out = np.full((end - start, len(INTERNAL_WEIGHTS)), np.nan)
        out[decided] = self._logged_decisions(start, decided)[:, 2 : 2 + len(INTERNAL_WEIGHTS)]
        return out

    def _send_flags(self, log, start: int, flags: np.ndarray, decided: np.ndarray) -> None:
        """Each flag of fuzzynav's state as a lane (:data:`INTERNAL_FLAGS`), where it
        changes (from the chunk before too); a row without a decision keeps the state."""
        import rerun as rr

        last = self._flag_states
        rows = np.flatnonzero(decided)
        for j, (lane, states) in enumerate(INTERNAL_FLAGS.items()):
            values = flags[rows, j]
            texts = [states.get(float(v), f"{v:g}") for v in values.tolist()]
            keep = [
                k for k, text in enumerate(texts) if text != (texts[k - 1] if k else last.get(lane))
            ]
            if texts:
                last[lane] = texts[-1]
            if not keep:
                continue
            steps = start + rows[keep]
            path = f"{INTERNAL_FLAGS_PATH}/{lane}"
            if path not in self._styled:  # each state's colour (rerun's own: by its text)
                self._styled.add(path)
                self._static.add_archetype(
                    path,
                    rr.StateConfiguration(
                        values=list(states.values()),
                        colors=[FLAG_COLORS.get(s, SERIES_PALETTE[0]) for s in states.values()],
                    ),
                )
            self.rec.send_columns(
                path,
                indexes=time_indexes(log.time_s[steps], steps),
                columns=rr.StateChange.columns(state=[texts[k] for k in keep]),
            )

    def _logged_decisions(self, start: int, decided: np.ndarray):
        """The driving controller's own decisions for the decided rows of [start, end)
        as an array (voltages, then the state); None to replay the rows instead (the
        first chunk chooses: a controller that did not log its decisions from the run's
        start is replayed throughout)."""
        inner = getattr(self.controller, "inner", self.controller)  # the viewer's wrapper
        decisions = getattr(inner, "decisions", None)
        rows = np.flatnonzero(decided) + start
        covered = isinstance(decisions, list) and (not len(rows) or rows[-1] < len(decisions))
        if self.internals_source is None:
            self.internals_source = "decisions" if covered and start == 0 else "replay"
        if self.internals_source == "replay":
            return None
        if not covered:  # swapped for another controller mid-run: nothing to line up
            return np.full((len(rows), self.decision_width), np.nan)
        return np.array([decisions[k] for k in rows], dtype=float).reshape(
            len(rows), self.decision_width
        )

    def _replay(self, log, start: int, decided: np.ndarray):
        """The decisions of the decided rows of [start, end), replayed through a copy
        of the controller (made at the first chunk); a replay that departs from the run
        stops there (its later rows are NaN)."""
        if self.replica is None:
            self.replica = controller_replica(self.controller)
        replica = self.replica
        rows = np.flatnonzero(decided) + start
        result = np.full((len(rows), self.decision_width), np.nan)
        for j, k in enumerate(rows):
            replica(log.inputs[k], ranges_m=log.ranges_m[k])
            result[j] = replica.decisions[-1]
            if np.any(np.abs(result[j, :2] - log.controller_output_v[k]) > 1e-9):
                break
        return result
