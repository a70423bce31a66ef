"""The trajectory panel (the paper's Fig. 12, and every panel of Fig. 27): the path, start,
target, the obstacles with their 0.25 m safe-distance circles, the moving obstacles'
paths, the straight start-target line, footprint outlines every few seconds, the
disturbance window, collisions and each obstacle's closest approach.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.figures.style import (
    DISTURBANCE,
    EVENT,
    OBSTACLE_COLORS,
    ROBOT,
    SAFE,
    SAFE_DISTANCE_M,
    TARGET,
    _default_footprint,
    _obstacle_label,
    disturbance_window_s,
)
from fuzzynav.world.geometry import footprint_outlines

FOOTPRINT_EVERY_S = 5.0


def _moving_columns(log) -> list[int]:
    """Obstacle columns whose centre changes during the run."""
    moving = []
    for col in range(len(log.obstacle_ids)):
        xy = log.obstacle_xy[:, col]
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if len(xy) > 1 and np.any(np.ptp(xy, axis=0) > 1e-9):
            moving.append(col)
    return moving


def draw_trajectory(
    ax,
    result,
    *,
    footprint_m=None,
    footprints: bool = True,
    legend: bool = True,
    title: str | None = None,
    events: bool = True,
) -> None:
    """The paper's trajectory figure on ``ax`` (also used for the comparison grid);
    ``events``: mark each obstacle's closest approach (time and centre distance)."""
    log = result.log
    scenario = result.scenario
    start, target = scenario.start, (log.target_xy[-1] if len(log) else scenario.target)
    ax.plot(
        [start[0], target[0]],
        [start[1], target[1]],
        color="0.6",
        lw=0.8,
        ls="--",
        label="straight line",
        zorder=1,
    )
    moving = set(_moving_columns(log)) if len(log) else set()
    # (text, where, colour): placed once the limits are known
    labels = _draw_obstacles(ax, result, moving)
    _draw_path(ax, result, footprint_m=footprint_m, footprints=footprints)
    _draw_ends_and_collisions(ax, result, start, target)
    if events:
        labels += _draw_closest_approaches(ax, result, moving)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.autoscale_view()
    _place_labels(ax, labels)
    ax.grid(True, lw=0.3, alpha=0.6)
    if title is not None:
        ax.set_title(title, fontsize=9)
    if legend:
        ax.legend(fontsize=7, loc="best", framealpha=0.85)


def _draw_obstacles(ax, result, moving) -> list:
    """Each obstacle where it ends, with its safe-distance circle (a moving one also its
    path and where it started); returns the obstacles' labels, to be placed."""
    from matplotlib.patches import Circle

    log = result.log
    labels = []
    paper_geometry = getattr(result, "geometry", "husky") == "paper"
    safe_label = f"{SAFE_DISTANCE_M} m safe distance" + (
        ", centre to centre" if paper_geometry else ""
    )
    for col in range(len(log.obstacle_ids)):
        radius = float(log.obstacle_radii_m[col])
        pts = log.obstacle_xy[:, col]
        present = np.all(np.isfinite(pts), axis=1)
        if not present.any():
            continue
        color = OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)]
        first, last = pts[present][0], pts[present][-1]
        if col in moving:
            # above the straight line (s2's obstacle moves along it), in its own colour
            ax.plot(
                pts[present, 0],
                pts[present, 1],
                color=color,
                lw=2.2,
                ls=(0, (1, 1.5)),
                label=f"{_obstacle_label(log, col)}'s path (moving)",
                zorder=2.5,
            )
            ax.add_patch(
                Circle(
                    first,
                    radius,
                    facecolor="none",
                    edgecolor=color,
                    lw=0.9,
                    ls="--",
                    zorder=2.5,
                    label=f"{_obstacle_label(log, col)} at the start",
                )
            )
        ax.add_patch(Circle(last, radius, facecolor=color, edgecolor=color, alpha=0.75, zorder=3))
        ax.add_patch(
            Circle(
                last,
                # the paper's point robot is judged centre to centre, the Husky's footprint
                # from the obstacle's surface
                SAFE_DISTANCE_M if paper_geometry else radius + SAFE_DISTANCE_M,
                facecolor="none",
                edgecolor=SAFE,
                lw=0.9,
                ls="--",
                zorder=3,
                label=(safe_label if col == 0 else None),
            )
        )
        labels.append((_obstacle_label(log, col), last, color))
    return labels


def _draw_path(ax, result, *, footprint_m, footprints: bool) -> None:
    """The robot's footprint every :data:`FOOTPRINT_EVERY_S`, its path, and the stretch
    driven during the disturbance."""
    log = result.log
    xy = log.pose[:, :2]
    if footprints and len(log) > 1:
        period = max(1, int(round(FOOTPRINT_EVERY_S / max(result.control_period_s, 1e-9))))
        shown = list(range(0, len(log), period)) + [len(log) - 1]
        for outline in footprint_outlines(log.pose[shown], *(footprint_m or _default_footprint())):
            ax.plot(outline[:, 0], outline[:, 1], color=ROBOT, lw=0.5, alpha=0.35, zorder=4)
    ax.plot(xy[:, 0], xy[:, 1], color=ROBOT, lw=1.8, label="robot (centre)", zorder=5)
    window = disturbance_window_s(result.scenario)
    if window is not None and len(log):
        during = (log.time_s >= window[0]) & (log.time_s <= window[1])
        if during.any():
            ax.plot(
                xy[during, 0],
                xy[during, 1],
                color=DISTURBANCE,
                lw=4.0,
                alpha=0.6,
                solid_capstyle="butt",
                label=f"during the disturbance ({window[0]:g}–{window[1]:g} s)",
                zorder=4.5,
            )


def _draw_ends_and_collisions(ax, result, start, target) -> None:
    """The start, the target with its tolerance, and a cross at each collision."""
    from matplotlib.patches import Circle

    ax.plot(*start, marker="o", color="k", ms=5, ls="none", label="start", zorder=6)
    ax.add_patch(Circle(target, result.scenario.tolerance_m, facecolor=TARGET, alpha=0.3, zorder=5))
    ax.plot(*target, marker="*", color=TARGET, ms=12, ls="none", label="target", zorder=6)
    for c in result.collisions:
        ax.plot(
            *c.robot_xy,
            marker="x",
            color="k",
            ms=8,
            mew=2,
            ls="none",
            zorder=7,
            label="collision" if c is result.collisions[0] else None,
        )


def _draw_closest_approaches(ax, result, moving) -> list:
    """Each obstacle's closest approach on the path (a moving obstacle where it was
    then); returns their labels (distance and time), to be placed."""
    from matplotlib.patches import Circle

    log = result.log
    xy = log.pose[:, :2]
    labels = []
    for k, (col, row, distance) in enumerate(closest_approaches(result)):
        ax.plot(
            *xy[row],
            marker="o",
            ms=4.5,
            mfc="white",
            mec=EVENT,
            ls="none",
            zorder=7,
            label="closest approach (centre to centre)" if k == 0 else None,
        )
        if col in moving:  # the moving obstacle where it was then
            ax.add_patch(
                Circle(
                    log.obstacle_xy[row, col],
                    float(log.obstacle_radii_m[col]),
                    facecolor=OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)],
                    alpha=0.35,
                    edgecolor="none",
                    zorder=3,
                    label=f"{_obstacle_label(log, col)} at its closest approach",
                )
            )
        labels.append((f"{distance:.2f} m, {log.time_s[row]:.1f} s", xy[row], EVENT))
    return labels


def closest_approaches(result) -> list[tuple[int, int, float]]:
    """(obstacle column, row, centre distance m) of each obstacle's closest approach."""
    log = result.log
    out = []
    if not len(log):
        return out
    for col in range(len(log.obstacle_ids)):
        d = np.where(
            np.isfinite(log.center_distance_m[:, col]), log.center_distance_m[:, col], np.inf
        )
        row = int(np.argmin(d))
        if math.isfinite(d[row]):
            out.append((col, row, float(d[row])))
    return out


LABEL_GID = "trajectory-label"
# Where a label may go from its point: the eight compass directions at growing distances
# (points); the first candidate is the side facing the axes' middle.
_DIRECTIONS = ((1, 1), (1, -1), (-1, 1), (-1, -1), (1, 0), (-1, 0), (0, 1), (0, -1))
_RADII_PT = (6.0, 13.0, 22.0, 32.0)


def _place_labels(ax, labels) -> None:
    """Annotate each (text, point, colour) on the side that faces the axes' middle (a
    first guess; :func:`separate_labels` moves them apart once the figure's layout is
    known). The labels take no part in the layout."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for text, (x, y), color in labels:
        right = x > 0.5 * (x0 + x1)
        up = y < 0.5 * (y0 + y1)
        label = ax.annotate(
            text,
            (x, y),
            xytext=(-6 if right else 6, 6 if up else -6),
            textcoords="offset points",
            ha="right" if right else "left",
            va="bottom" if up else "top",
            fontsize=7,
            color=color,
            zorder=8,
            gid=LABEL_GID,
        )
        label.set_in_layout(False)


def _set_offset(label, dx: float, dy: float) -> None:
    label.xyann = (dx, dy)
    label.set_horizontalalignment("left" if dx > 0 else "right" if dx < 0 else "center")
    label.set_verticalalignment("bottom" if dy > 0 else "top" if dy < 0 else "center")


def _text_box(label, renderer):
    """The label's text alone (an Annotation's extent includes its leader line)."""
    from matplotlib.text import Text

    label.update_positions(renderer)
    return Text.get_window_extent(label, renderer)


def _overlap(a, b) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return w * h if w > 0 and h > 0 else 0.0


def separate_labels(fig) -> None:
    """Move every trajectory label (gid ``trajectory-label``) of ``fig`` to where it
    overlaps no other label and no legend, stays inside its axes and covers as little of
    the discs, markers and curves as it can; a label moved far from its point gets a
    leader line. Runs the figure's layout first (the labels take no part in it) and pins
    each axes legend where "best" put it, so that the next draw leaves both in place."""
    from matplotlib.patches import Circle

    labelled = [ax for ax in fig.axes if any(t.get_gid() == LABEL_GID for t in ax.texts)]
    if not labelled:
        return
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    for ax in labelled:
        frame = ax.get_window_extent(renderer)
        taken = []
        legend = ax.get_legend()
        if legend is not None:
            box = legend.get_window_extent(renderer)
            taken.append(box)
            # pinned: "best" would otherwise move it away from the labels' new places
            legend.set_loc(tuple(ax.transAxes.inverted().transform((box.x0, box.y0))))
        discs, rings = [], []
        for patch in ax.patches:
            box = patch.get_window_extent(renderer)
            filled = patch.get_fill() and patch.get_facecolor()[3] > 0
            (discs if filled or not isinstance(patch, Circle) else rings).append(box)
        points = []
        for line in ax.lines:
            xy = line.get_xydata()
            if len(xy):
                points.append(ax.transData.transform(xy[np.all(np.isfinite(xy), axis=1)]))
        points = np.concatenate(points) if points else np.empty((0, 2))
        scale = fig.dpi / 72.0
        for label in [t for t in ax.texts if t.get_gid() == LABEL_GID]:
            first = label.xyann
            order = sorted(
                _DIRECTIONS,
                key=lambda d: (
                    (np.sign(d[0]) != np.sign(first[0])) + (np.sign(d[1]) != np.sign(first[1]))
                ),
            )
            best = None
            for r_index, radius in enumerate(_RADII_PT):
                for d_index, (ux, uy) in enumerate(order):
                    norm = radius / math.hypot(ux, uy) if ux and uy else radius
                    _set_offset(label, ux * norm, uy * norm)
                    box = _text_box(label, renderer)
                    outside = (
                        box.x0 < frame.x0 + scale
                        or box.x1 > frame.x1 - scale
                        or box.y0 < frame.y0 + scale
                        or box.y1 > frame.y1 - scale
                    )
                    inside = (
                        (points[:, 0] >= box.x0)
                        & (points[:, 0] <= box.x1)
                        & (points[:, 1] >= box.y0)
                        & (points[:, 1] <= box.y1)
                    ).sum()
                    cost = (
                        1e9 * outside
                        + 1e6 * sum(_overlap(box, b) > 0 for b in taken)
                        + 50.0
                        * sum(_overlap(box, b) for b in discs)
                        / max(box.width * box.height, 1.0)
                        + 10.0 * sum(_overlap(box, b) > 0 for b in rings)
                        + 2.0 * inside
                        + 4.0 * r_index
                        + 0.5 * d_index
                    )
                    if best is None or cost < best[0]:
                        best = (cost, ux * norm, uy * norm)
                if best[0] < 4.0 * (r_index + 1):  # nothing better further out
                    break
            _, dx, dy = best
            _set_offset(label, dx, dy)
            if math.hypot(dx, dy) > _RADII_PT[1]:  # far from its point: a leader line
                label.remove()
                label = ax.annotate(
                    label.get_text(),
                    label.xy,
                    xytext=(dx, dy),
                    textcoords="offset points",
                    ha=label.get_horizontalalignment(),
                    va=label.get_verticalalignment(),
                    fontsize=label.get_fontsize(),
                    color=label.get_color(),
                    zorder=label.get_zorder(),
                    gid=LABEL_GID,
                    arrowprops=dict(
                        arrowstyle="-", lw=0.5, color=label.get_color(), shrinkA=1, shrinkB=2
                    ),
                )
                label.set_in_layout(False)
            taken.append(_text_box(label, renderer))
