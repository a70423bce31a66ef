"""The world in a recording: the robot, the target, the obstacles, the sensors' beams
(or, for ideal perception, the line to the obstacle the controller reacts to) and the
static parts of the map (its y-up mirror, the start, the straight line, a scale).

:class:`SceneColumns` is the part of the column writer
(:class:`~fuzzynav.app.recordings.columns.ColumnWriter`) that sends them; the geometry
(footprint outlines, beam cones, circles) is :mod:`world.geometry`'s, as the viewer and
the figures draw it.
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

from .sending import Statics
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
    SCALE,
    SENSED,
    SENSOR_COLORS,
    START,
    TARGET,
    TRAIL,
    TRAIL_ORDER,
    obstacle_color,
)

#: The trail's segments inside the disturbance window, under the trail.
TRAIL_DISTURBED_PATH = "/world/robot/trail_disturbed"


class SceneColumns:
    """The world's entities, rows [start, end) at a time. A part of
    :class:`~fuzzynav.app.recordings.columns.ColumnWriter`, whose state it uses: the
    stream and the styles (``_send``, ``_style``), the robot's footprint, the sensors,
    the target's tolerance and the geometry, and what the last chunk left (``_target``,
    ``_obstacles``)."""

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


def static_world(static: Statics, scenario) -> None:
    """The y-up mirror of /world, the start and the straight start-target line."""
    import rerun as rr

    static.add_archetype("/world", rr.Transform3D(scale=[1.0, -1.0, 1.0]))
    # Light, with a dark rim: visible on rerun's dark theme and on a light one.
    static.add_archetype(
        "/world/start",
        rr.Points2D(
            positions=[scenario.start, scenario.start],
            radii=[0.12, 0.08],
            colors=[(20, 20, 20), START],
            labels=["", "start"],
        ),
    )
    # A scale: a 1 m bar with 10 cm ticks, just below and left of the start (the view's
    # bounds always hold the start with a 1 m margin).
    x0, bar_y = scenario.start[0] - 0.8, scenario.start[1] - 0.75
    strips = [[(x0 + 0.3, bar_y), (x0 + 1.3, bar_y)]]
    strips += [
        [(x0 + 0.3 + 0.1 * k, bar_y), (x0 + 0.3 + 0.1 * k, bar_y + (0.1 if k % 5 == 0 else 0.05))]
        for k in range(11)
    ]
    static.add_archetype(
        "/world/scale",
        rr.LineStrips2D(
            strips=strips, colors=[SCALE] * len(strips), radii=0.012, labels=["1 m"] + [""] * 10
        ),
    )
    static.add_archetype(
        "/world/ideal_line",
        rr.LineStrips2D(
            strips=[[scenario.start, scenario.target]], colors=[(170, 170, 170)], radii=0.01
        ),
    )
