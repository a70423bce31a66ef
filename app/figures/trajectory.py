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
    footprint_m=(0.99, 0.67),
    footprints: bool = True,
    legend: bool = True,
    title: str | None = None,
    events: bool = True,
) -> None:
    """The paper's trajectory figure on ``ax`` (also used for the comparison grid);
    ``events``: mark each obstacle's closest approach (time and centre distance)."""
    from matplotlib.patches import Circle

    log = result.log
    scenario = result.scenario
    xy = log.pose[:, :2]
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
    labels = []  # (text, where, colour): placed once the limits are known
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
    if footprints and len(log) > 1:
        period = max(1, int(round(FOOTPRINT_EVERY_S / max(result.control_period_s, 1e-9))))
        shown = list(range(0, len(log), period)) + [len(log) - 1]
        for outline in footprint_outlines(log.pose[shown], *footprint_m):
            ax.plot(outline[:, 0], outline[:, 1], color=ROBOT, lw=0.5, alpha=0.35, zorder=4)
    ax.plot(xy[:, 0], xy[:, 1], color=ROBOT, lw=1.8, label="robot (centre)", zorder=5)
    window = disturbance_window_s(scenario)
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
    ax.plot(*start, marker="o", color="k", ms=5, ls="none", label="start", zorder=6)
    ax.add_patch(Circle(target, scenario.tolerance_m, facecolor=TARGET, alpha=0.3, zorder=5))
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
    closest = closest_approaches(result) if events else []
    for k, (col, row, distance) in enumerate(closest):
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
                )
            )
        labels.append((f"{distance:.2f} m, {log.time_s[row]:.1f} s", xy[row], EVENT))
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


def _place_labels(ax, labels) -> None:
    """Annotate each (text, point, colour) on the side that faces the axes' middle, so
    that no label runs off the axes (a label at the right edge reads to the left)."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for text, (x, y), color in labels:
        right = x > 0.5 * (x0 + x1)
        up = y < 0.5 * (y0 + y1)
        ax.annotate(
            text,
            (x, y),
            xytext=(-6 if right else 6, 6 if up else -6),
            textcoords="offset points",
            ha="right" if right else "left",
            va="bottom" if up else "top",
            fontsize=7,
            color=color,
            zorder=8,
        )
