"""The paper's figures for a run, as PNG and SVG (matplotlib, no display needed).

``write_run_figures(result, out_dir)`` writes, for one run (the paper's numbering for
scenario 1; scenarios 2 and 3 repeat the set as Figs. 17-21 and 22-26):

==================  =======================================================================
``trajectory``      Fig. 12: the path, start, target, the obstacles with their 0.25 m
                    safe-distance circles, the moving obstacles' paths, the straight
                    start-target line, footprint outlines every few seconds, collisions
``distances``       Fig. 13: distance to the target and to each obstacle (centre to
                    centre, as the paper); below it, our footprint clearance and 0.25 m
``angles``          Fig. 14: the target angle phi_t and the heading
``obstacle_angles`` Fig. 15: the bearing of each obstacle from the heading
``voltages``        Fig. 16: left and right wheel voltages with the +-12 V limit
==================  =======================================================================

and, when the controller is fuzzy (it has a ``fis``, or fuzzynav's blocks), the membership
functions of every input and output (the paper's Figs. 6-11): ``membership_<variable>``
(fuzzynav: ``phi_t``, ``d_t``, ``left``, ``front``, ``right``, ``side``, and
``goal_speed``, ``goal_turn``, ``avoid_speed``, ``avoid_turn``).

``write_comparison_figure`` draws the paper's Fig. 27: the trajectories of several
controllers side by side, one row per scenario.

Figures are drawn on ``matplotlib.figure.Figure`` with the Agg canvas: no pyplot state,
no backend switch, safe beside the viewer.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzynav.resources import escape_controls
from fuzzynav.safe_files import atomic_output, write_text_atomically
from fuzzynav.world.geometry import footprint_outlines, obstacle_bearings, target_geometry

SAFE_DISTANCE_M = 0.25
FORMATS = ("png", "svg")
RUN_FIGURES = ("trajectory", "distances", "angles", "obstacle_angles", "voltages")
DPI = 150
FOOTPRINT_EVERY_S = 5.0

ROBOT = "#1f77b4"
TARGET = "#2ca02c"
OBSTACLE = "#d62728"
SAFE = "#555555"
MOVING = "#9467bd"
WHEEL_LEFT = "#1f77b4"
# Red, orange, purple... mean obstacles 0, 1, 2... everywhere (figures and recordings):
# the right wheel and the heading take colours no obstacle has.
WHEEL_RIGHT = "#222222"
HEADING = "#008c78"  # teal, as the recording's heading arrow
EVENT = "#222222"
DISTURBANCE = "#f2a900"
OBSTACLE_COLORS = [
    "#d62728",
    "#ff7f0e",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
    "#7f7f7f",
]


# ---------------------------------------------------------------------------------------
# Files


def check_writable_dir(path, option: str = "--figures") -> Path:
    """Create ``path`` if needed and make sure files can be written in it; ValueError
    with the reason otherwise."""
    from fuzzynav.safe_files import refuse_installed

    path = Path(path)
    refuse_installed(path, option)  # never among the shipped rule bases and scenarios
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {path}: exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot create it ({exc.strerror or exc})") from None
    try:
        fd, probe = tempfile.mkstemp(prefix=".fuzzynav-probe-", dir=path)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)
    return path


def _new_figure(width_in: float, height_in: float, rows: int = 1, cols: int = 1, **kw):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False, **kw)
    return fig, axes


def _save(fig, out_dir: Path, name: str, formats=FORMATS) -> list[Path]:
    paths = []
    for ext in formats:
        path = out_dir / f"{name}.{ext}"
        # whole or not at all: a full disk left a truncated PNG over the good one
        with atomic_output(path) as tmp:
            fig.savefig(tmp, dpi=DPI, format=ext, metadata=_metadata(ext))
        paths.append(path)
        # The layout is done (it is the costly part of a save): keep it for the others.
        fig.set_layout_engine("none")
    return paths


def _metadata(ext: str) -> dict:
    # Reproducible files: no creation date (SVG) and no software timestamp (PNG).
    if ext == "svg":
        return {"Date": None}
    if ext == "png":
        return {"Software": None}
    return {}


# ---------------------------------------------------------------------------------------
# Run figures


def _obstacle_label(log, col: int) -> str:
    return f"obstacle {log.obstacle_ids[col]}"


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


def _mark_closest(ax, result, *, label: bool) -> None:
    """A dotted vertical line at each obstacle's closest approach (its colour)."""
    log = result.log
    for col, row, distance in closest_approaches(result):
        ax.axvline(
            log.time_s[row],
            color=OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)],
            ls=":",
            lw=0.9,
            zorder=0.5,
            gid="closest",
            label=(
                f"closest to {_obstacle_label(log, col)}: {distance:.2f} m, {log.time_s[row]:.1f} s"
            )
            if label
            else None,
        )


def scenario_stem(scenario) -> str:
    """A scenario's short name: its file's stem (s1) or its name."""
    source = getattr(scenario, "source", "") or ""
    return Path(source).stem if source and source != "<memory>" else scenario.name


def numbered_scenario(scenario) -> str | None:
    """The shipped scenario's name (s1) when the run drove a shipped file, whose figures
    have the paper's numbers; None for any other (a copy named s2.toml elsewhere too)."""
    from fuzzynav.world.scenario import SCENARIO_DIR

    source = getattr(scenario, "source", "") or ""
    if not source or source == "<memory>":
        return None
    try:
        shipped = Path(source).resolve().parent == SCENARIO_DIR.resolve()
    except OSError:
        return None
    return Path(source).stem if shipped else None


def run_figure_stem(scenario, kind: str, controller: str) -> str:
    """A run figure's file name: ``fig17_s2_trajectory_paper`` for a shipped s1-s3 (the
    report's names), ``<stem>_<kind>_<controller>`` for any other scenario."""
    shipped = numbered_scenario(scenario)
    if shipped is not None:
        return paper_figure_stem(shipped, kind, controller)
    return f"{scenario_stem(scenario)}_{kind}_{controller}"


def _figure_prefix(result, kind: str) -> str:
    """``Fig. 18. `` for s2's distances: the paper's number, one numbering everywhere."""
    shipped = numbered_scenario(result.scenario)
    number = paper_figure_number(shipped, kind) if shipped else None
    return f"Fig. {number}. " if number is not None else ""


def _run_title(result, controller_label: str | None) -> str:
    """Two lines: the scenario; then the controller, the geometry and the outcome."""
    who = f"{controller_label} controller, " if controller_label else ""
    return f"{result.scenario.name}\n{who}{_geometry_label(result)} ({result.outcome})"


def _geometry_label(result) -> str:
    return f"{getattr(result, 'geometry', 'husky')} geometry"


def disturbance_window_s(scenario) -> tuple[float, float] | None:
    """(start, stop) seconds of the scenario's input disturbance, or None."""
    d = getattr(scenario, "disturbance", None)
    return None if d is None else (float(d.start_s), float(d.stop_s))


def _shade_disturbance(ax, scenario) -> None:
    """Shade the disturbance window on a time axis (a patch with gid ``disturbance``)."""
    window = disturbance_window_s(scenario)
    if window is None:
        return
    ax.axvspan(
        *window,
        facecolor=DISTURBANCE,
        alpha=0.22,
        lw=0,
        zorder=0,
        gid="disturbance",
        label=f"disturbance ({window[0]:g}–{window[1]:g} s)",
    )


def _time_axes(ax, ylabel: str, scenario=None, *, xlabel: bool = True) -> None:
    if xlabel:
        ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, lw=0.3, alpha=0.6)
    if scenario is not None:
        _shade_disturbance(ax, scenario)


def _legend_outside(ax) -> None:
    # Beside the axes, never over the curves.
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _break_at_wraps(angles: np.ndarray) -> np.ndarray:
    """A copy with NaN where an angle wraps between +pi and -pi, so that no vertical
    line is drawn across the axes there."""
    out = np.array(angles, dtype=float, copy=True)
    jumps = np.abs(np.diff(out, axis=0)) > math.pi
    out[1:][jumps] = np.nan
    return out


def run_figure(
    kind: str,
    result,
    *,
    controller_label: str | None = None,
    footprint_m=None,
    voltage_limit_v: float = 12.0,
):
    """One of the paper's run figures (``kind`` in :data:`RUN_FIGURES`) as a matplotlib
    ``Figure``, not saved. Titles name the scenario, controller and geometry; every time
    axis of a scenario with a disturbance has the window shaded (gid ``disturbance``)."""
    if kind not in RUN_FIGURES:
        raise ValueError(f"figure kind {kind!r}: not one of {', '.join(RUN_FIGURES)}")
    log = result.log
    scenario = result.scenario
    t = log.time_s
    title = _run_title(result, controller_label)
    paper_geometry = getattr(result, "geometry", "husky") == "paper"

    if kind == "trajectory":
        fig, ax = _new_figure(6.4, 6.0)
        draw_trajectory(
            ax[0, 0],
            result,
            footprint_m=footprint_m or _default_footprint(),
            footprints=not paper_geometry,
            title=f"{_figure_prefix(result, 'trajectory')}Trajectory — {title}",
        )
        return fig

    if kind == "distances":
        fig, ax = _new_figure(7.6, 5.6, 2, 1, sharex=True)
        top, bottom = ax[0, 0], ax[1, 0]
        d_t = np.hypot(log.target_xy[:, 0] - log.pose[:, 0], log.target_xy[:, 1] - log.pose[:, 1])
        top.plot(t, d_t, color=TARGET, lw=1.6, label="to the target")
        for col in range(len(log.obstacle_ids)):
            color = OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)]
            name = _obstacle_label(log, col)
            top.plot(t, log.center_distance_m[:, col], color=color, lw=1.2, label=f"to {name}")
            bottom.plot(t, log.clearance_m[:, col], color=color, lw=1.2, label=name)
        safe_label = f"{SAFE_DISTANCE_M} m safe distance"
        if paper_geometry:  # the paper's point robot: safety is judged centre to centre
            top.axhline(SAFE_DISTANCE_M, color="0.4", ls="--", lw=0.9, label=safe_label)
        else:
            bottom.axhline(SAFE_DISTANCE_M, color="0.4", ls="--", lw=0.9, label=safe_label)
        bottom.axhline(0.0, color="k", lw=0.6)
        _mark_closest(top, result, label=True)
        _mark_closest(bottom, result, label=False)
        _time_axes(top, "distance, centre to centre (m)", scenario, xlabel=False)
        _time_axes(
            bottom,
            "centre to obstacle surface (m)" if paper_geometry else "footprint clearance (m)",
            scenario,
        )
        top.set_title(f"{_figure_prefix(result, 'distances')}Distances — {title}", fontsize=9)
        for a in (top, bottom):
            _legend_outside(a)
        return fig

    if kind == "angles":
        fig, ax = _new_figure(7.6, 5.6, 2, 1, sharex=True)
        top, bottom = ax[0, 0], ax[1, 0]
        phi_t = target_geometry(log.pose, log.target_xy)[1]
        if disturbance_window_s(scenario) is not None and len(log):
            top.plot(
                t,
                log.inputs[:, 2],
                color="0.55",
                lw=0.7,
                label="phi_t as the controller received it",
            )
        top.plot(t, phi_t, color=ROBOT, lw=1.4, label="phi_t")
        bottom.plot(t, log.pose[:, 2], color=HEADING, lw=1.4, label="heading")
        _time_axes(top, "target angle phi_t (rad)", scenario, xlabel=False)
        _time_axes(bottom, "heading (rad)", scenario)
        top.set_title(
            f"{_figure_prefix(result, 'angles')}Target angle and heading — {title}", fontsize=9
        )
        for a in (top, bottom):
            _legend_outside(a)
        return fig

    if kind == "obstacle_angles":
        fig, ax = _new_figure(7.6, 3.6)
        a = ax[0, 0]
        if len(log.obstacle_ids) and len(log):
            bearings = _break_at_wraps(obstacle_bearings(log.pose, log.obstacle_xy))
            for col in range(len(log.obstacle_ids)):
                a.plot(
                    t,
                    bearings[:, col],
                    color=OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)],
                    lw=1.2,
                    label=_obstacle_label(log, col),
                )
        else:
            a.text(0.5, 0.5, "no obstacles", ha="center", va="center", transform=a.transAxes)
        a.axhline(0.0, color="k", lw=0.6)
        _time_axes(a, "obstacle angle (rad)", scenario)
        a.set_title(
            f"{_figure_prefix(result, 'obstacle_angles')}Obstacle angles — {title}", fontsize=9
        )
        if a.get_legend_handles_labels()[0]:
            _legend_outside(a)
        return fig

    # voltages: one panel per wheel (neither hides the other) and their difference
    fig, ax = _new_figure(7.6, 6.4, 3, 1, sharex=True, height_ratios=(1.0, 1.0, 0.75))
    limit = float(voltage_limit_v)
    for row, (name, color) in enumerate(
        (("left (v_s1)", WHEEL_LEFT), ("right (v_s2)", WHEEL_RIGHT))
    ):
        a = ax[row, 0]
        a.plot(
            t,
            log.controller_output_v[:, row],
            color=color,
            lw=0.7,
            alpha=0.4,
            label="before saturation",
        )
        a.plot(t, log.voltages_v[:, row], color=color, lw=1.4, label=f"{name}, applied")
        for sign in (1, -1):
            a.axhline(
                sign * limit,
                color="0.3",
                ls="--",
                lw=0.9,
                label=f"±{limit:g} V limit" if sign > 0 else None,
            )
        _time_axes(a, f"{name.split()[0]} wheel (V)", scenario, xlabel=False)
        _legend_outside(a)
    ax[1, 0].sharey(ax[0, 0])
    diff = ax[2, 0]
    diff.plot(
        t,
        log.voltages_v[:, 0] - log.voltages_v[:, 1],
        color="0.2",
        lw=1.1,
        label="left − right (applied)",
    )
    diff.axhline(0.0, color="k", lw=0.6)
    _time_axes(diff, "left − right (V)", scenario)
    _legend_outside(diff)
    ax[0, 0].set_title(f"{_figure_prefix(result, 'voltages')}Wheel voltages — {title}", fontsize=9)
    return fig


def write_run_figures(
    result,
    out_dir,
    controller=None,
    *,
    prefix: str = "",
    names=None,
    formats=FORMATS,
    footprint_m=None,
    voltage_limit_v: float = 12.0,
    membership: bool = True,
    controller_label: str | None = None,
) -> list[Path]:
    """Write the paper's figure set for one run (see the module docstring).

    Parameters
    ----------
    result : SimulationResult (finished or partial)
    out_dir : directory, created if needed
    controller : optional; with a ``fis`` the membership figures are written too
    prefix : put before every file name (e.g. ``"s1_paper_"``)
    names : optional mapping of figure kind to file stem (without extension), instead
        of ``prefix + kind`` (the report names files by the paper's figure number)
    formats : file types (default PNG and SVG)
    footprint_m : (length, width) of the outlines drawn on the trajectory; default the
        real Husky's (0.99 m x 0.67 m); none are drawn in the paper's geometry
    voltage_limit_v : the saturation drawn on the voltage figure
    membership : also write the controller's membership figures (when it is fuzzy)
    controller_label : the controller's name in titles (default: the controller's)

    Returns the files written, in order.
    """
    out_dir = check_writable_dir(out_dir, option="out_dir")
    label = controller_label or _controller_label(controller)
    written: list[Path] = []
    for kind in RUN_FIGURES:
        fig = run_figure(
            kind,
            result,
            controller_label=label,
            footprint_m=footprint_m,
            voltage_limit_v=voltage_limit_v,
        )
        stem = names[kind] if names is not None else f"{prefix}{kind}"
        written += _save(fig, out_dir, stem, formats)
    fis = _fis(controller) if membership else None
    if fis is not None:
        written += write_membership_figures(fis, out_dir, prefix=prefix, formats=formats)
    return written


def _default_footprint() -> tuple[float, float]:
    try:
        from fuzzynav.world.husky import HuskyModel

        p = HuskyModel.default().parameters
        return (p.footprint_length_m, p.footprint_width_m)
    except Exception:  # the figures do not depend on the parameter file being readable
        return (0.99, 0.67)


def _fis(controller):
    """The controller's fuzzy system: its ``fis``, else (fuzzynav) its blocks merged into
    one (``merged``: every block's inputs and outputs, under names unique across them)."""
    if controller is None:
        return None
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    fis = getattr(inner, "fis", None)
    if fis is None and callable(getattr(inner, "rule_blocks", None)):
        fis = getattr(inner, "merged", None)
    return fis if fis is not None and hasattr(fis, "inputs") and hasattr(fis, "outputs") else None


def _controller_label(controller) -> str | None:
    if controller is None:
        return None
    name = getattr(controller, "name", None)
    return name if isinstance(name, str) and name else type(controller).__name__


# ---------------------------------------------------------------------------------------
# Membership functions (paper Figs. 6-11)


def membership_figure_names(fis) -> list[str]:
    return [f"membership_{v.name}" for v in tuple(fis.inputs) + tuple(fis.outputs)]


def write_membership_figures(
    fis,
    out_dir,
    *,
    prefix: str = "",
    formats=FORMATS,
    points: int = 1001,
    stem=None,
    title_suffix: str = "",
    numbers: dict | None = None,
) -> list[Path]:
    """One figure per input and output variable of a ``FuzzySystem``: every term's
    membership over the variable's range, named ``membership_<variable>`` (or
    ``stem(variable)`` when given), ``title_suffix`` added to each title."""
    out_dir = check_writable_dir(out_dir, option="out_dir")
    written = []
    variables = [("input", v) for v in fis.inputs] + [("output", v) for v in fis.outputs]
    for kind, var in variables:
        lo, hi = var.range
        x = np.linspace(lo, hi, points)
        fig, ax = _new_figure(7.6, 3.2 if title_suffix else 3.0)
        a = ax[0, 0]
        for _k, term in enumerate(var.terms):
            y = np.asarray(term(x), dtype=float)
            (line,) = a.plot(x, y, lw=1.6, label=f"{term.name} ({term.shape})")
            peak = int(np.argmax(y))
            # a peak at an end of the range (VL at 14 V) is labelled inward, not cut off
            where = (x[peak] - lo) / (hi - lo) if hi > lo else 0.5
            ha = "left" if where < 0.08 else "right" if where > 0.92 else "center"
            a.annotate(
                term.name,
                (x[peak], y[peak]),
                xytext=({"left": 3, "right": -3, "center": 0}[ha], 4),
                textcoords="offset points",
                ha=ha,
                fontsize=8,
                color=line.get_color(),
            )
        unit = f" ({var.unit})" if getattr(var, "unit", "") else ""
        a.set_xlim(lo, hi)
        a.set_ylim(-0.02, 1.12)
        a.set_xlabel(f"{var.name}{unit}")
        a.set_ylabel("membership")
        a.grid(True, lw=0.3, alpha=0.6)
        desc = getattr(var, "description", "")
        number = (numbers or {}).get(var.name)
        head = f"Fig. {number}. " if number is not None else ""
        a.set_title(
            f"{head}{kind} {var.name}" + (f": {desc}" if desc else "") + title_suffix, fontsize=9
        )
        a.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        name = stem(var.name) if stem is not None else f"{prefix}membership_{var.name}"
        written += _save(fig, out_dir, name, formats)
    return written


def write_membership_overview(
    fis, path, title: str, *, points: int = 1001, d_t_shown_m: float = 20.0
) -> Path:
    """All of a system's variables on one page (two columns), like the paper's Figs. 6-11
    side by side: the README's picture of a rule base. ``d_t`` is shown up to
    ``d_t_shown_m`` (its far terms are flat beyond)."""
    import matplotlib.pyplot as plt

    variables = list(fis.inputs) + list(fis.outputs)
    rows = (len(variables) + 1) // 2
    fig, axes = plt.subplots(rows, 2, figsize=(12, 2.8 * rows), squeeze=False)
    for a, var in zip(axes.ravel(), variables):
        lo, hi = var.range
        shown = min(hi, d_t_shown_m) if var.name == "d_t" else hi
        x = np.linspace(lo, shown, points)
        for term in var.terms:
            a.plot(x, np.asarray(term(x), dtype=float), lw=1.6, label=f"{term.name} ({term.shape})")
        unit = f" [{var.unit}]" if getattr(var, "unit", "") else ""
        note = f" (shown to {shown:g} of {hi:g})" if shown < hi else ""
        a.set_title(f"{var.name}{unit}{note}", fontsize=9)
        a.set_ylim(-0.02, 1.1)
        a.set_xlabel(f"{var.name}{unit}")
        a.set_ylabel("membership")
        a.grid(True, lw=0.3, alpha=0.6)
        a.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))  # not over a term
    for a in axes.ravel()[len(variables) :]:
        a.axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=90, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path


# ---------------------------------------------------------------------------------------
# Comparison (paper Fig. 27)


def _orient(results: dict) -> dict:
    """``{scenario: {controller: result}}``; a mapping given the other way round
    (``{controller: {scenario: result}}``) is recognised by its results' scenarios and
    transposed."""

    def names(inner):
        return {getattr(r.scenario, "name", None) for r in inner.values() if r is not None}

    outer_is_scenario = all(len(names(inner)) <= 1 for inner in results.values())
    if outer_is_scenario:
        return results
    flipped: dict = {}
    for outer, inner in results.items():
        for key, result in inner.items():
            flipped.setdefault(key, {})[outer] = result
    if all(len(names(inner)) <= 1 for inner in flipped.values()):
        return flipped
    return results


def comparison_figure(
    results_by_controller_by_scenario: dict,
    *,
    controllers=None,
    column_titles: dict | None = None,
    title: str | None = None,
    footprint_m=None,
):
    """The comparison grid as a matplotlib ``Figure`` (not saved): one row per scenario,
    one column per controller (``controllers`` fixes which and in what order; default
    every controller present, in order of appearance), each panel the trajectory of that
    controller in that scenario, same axes along a row, panels lettered (a), (b), ...
    row by row as the paper's Fig. 27. ``column_titles`` maps a controller to the name
    its panels carry (default the controller's label)."""
    grid = _orient(results_by_controller_by_scenario)
    scenarios = list(grid)
    if controllers is None:
        controllers = []
        for inner in grid.values():
            for c in inner:
                if c not in controllers:
                    controllers.append(c)
    controllers = list(controllers)
    if not scenarios or not controllers:
        raise ValueError("comparison figure: no results to draw")
    column_titles = column_titles or {}
    footprint_m = footprint_m or _default_footprint()
    rows, cols = len(scenarios), len(controllers)
    # wide enough for its title even with one column
    fig, axes = _new_figure(max(3.6 * cols + 0.4, 6.4), 3.5 * rows + 0.3, rows, cols)
    letters = "abcdefghijklmnopqrstuvwxyz"
    for i, scenario in enumerate(scenarios):
        row_results = [grid[scenario].get(c) for c in controllers]
        for j, (controller, result) in enumerate(zip(controllers, row_results)):
            ax = axes[i, j]
            index = i * cols + j
            tag = f"({letters[index]})" if index < len(letters) else f"({index + 1})"
            shown = column_titles.get(controller, controller)
            if result is None:
                ax.set_axis_off()
                ax.set_title(f"{tag} {shown}, {scenario}: not run", fontsize=8)
                continue
            m = result.metrics or {}
            length = m.get("path_length_m")
            extra = f", {length:.2f} m" if isinstance(length, (int, float)) else ""
            draw_trajectory(
                ax,
                result,
                footprint_m=footprint_m,
                footprints=False,
                legend=False,
                title=f"{tag} {shown}, {scenario}: {result.outcome}{extra}",
                events=False,
            )
            # which run a panel shows, for a reader of the Figure object (and the tests)
            ax.set_gid(f"{scenario}/{controller}")
    # One legend for every panel (each panel's own limits: sharing a row's squashed a
    # panel whose path is short beside a long one).
    handles = {}
    for ax in axes.ravel():
        for handle, text in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(text, handle)
    if handles:
        fig.legend(
            list(handles.values()),
            list(handles),
            loc="outside lower center",
            ncols=min(4, len(handles)),
            fontsize=7,
        )
    fig.suptitle(title or "Trajectories while reaching the target (paper Fig. 27)", fontsize=10)
    return fig


def write_comparison_figure(
    results_by_controller_by_scenario: dict,
    out_dir,
    *,
    name: str = "comparison",
    formats=FORMATS,
    footprint_m=None,
    controllers=None,
    column_titles: dict | None = None,
    title: str | None = None,
) -> list[Path]:
    """The paper's Fig. 27: one row per scenario, one column per controller, each panel
    the trajectory of that controller in that scenario (same axes along a row).

    ``results_by_controller_by_scenario`` maps a scenario label to a mapping of
    controller label to ``SimulationResult``, e.g. ``{"s1": {"baseline": r1, "paper":
    r2}, "s2": {...}}``; any number of either. (Given as ``{controller: {scenario:
    result}}`` it is recognised and transposed.) A missing pair is drawn as an empty
    panel. ``controllers``, ``column_titles`` and ``title`` as
    :func:`comparison_figure`. Returns the files written.
    """
    out_dir = check_writable_dir(out_dir, option="out_dir")
    fig = comparison_figure(
        results_by_controller_by_scenario,
        controllers=controllers,
        column_titles=column_titles,
        title=title,
        footprint_m=footprint_m,
    )
    return _save(fig, out_dir, name, formats)


# ---------------------------------------------------------------------------------------
# The paper's figure set, files named by the paper's figure numbers (``fuzzynav report``)

# Figs. 12-16 are s1's run figures in RUN_FIGURES order; s2 repeats them as 17-21, s3 as 22-26.
FIRST_RUN_FIGURE = {"s1": 12, "s2": 17, "s3": 22}
COMPARISON_FIGURE = 27
# Figs. 6-11: the membership functions of the paper's controller.
MEMBERSHIP_FIGURE = {"d_t": 6, "phi_t": 7, "d_o": 8, "phi_o": 9, "left": 10, "right": 11}
# Fig. 27's columns in the paper's order: (a) method of [19] s1, (b) proposed s1, (c) ...
FIG27_COLUMNS = ("baseline", "paper")
FIG27_TITLES = {"baseline": "ref. [19] stand-in (baseline)", "paper": "proposed (paper)"}
FIGURE_WHAT = {
    "trajectory": "trajectory of the robot's centre, obstacles and their safe distance",
    "distances": "distance to the target and to each obstacle over time",
    "angles": "target angle phi_t and heading over time",
    "obstacle_angles": "angle of each obstacle from the heading over time",
    "voltages": "wheel voltages, left (v_s1) and right (v_s2), and their difference",
    "membership": "membership functions of",
    "comparison": "trajectories in s1-s3, side by side",
}


def paper_figure_number(scenario: str, kind: str) -> int | None:
    """The paper's figure number of a run figure (Fig. 12 = s1's trajectory, ..., Fig. 26
    = s3's voltages), or None for a scenario the paper has no figures of."""
    first = FIRST_RUN_FIGURE.get(scenario)
    if first is None or kind not in RUN_FIGURES:
        return None
    return first + RUN_FIGURES.index(kind)


def paper_figure_stem(scenario: str, kind: str, controller: str) -> str:
    """The file name (no extension) of a run figure in the report: ``fig12_s1_trajectory_
    paper`` = Fig. 12, scenario s1, the trajectory, controller ``paper``; the geometry is
    the folder's name. Scenarios outside s1-s3 go without a number."""
    number = paper_figure_number(scenario, kind)
    head = f"fig{number:02d}_" if number is not None else ""
    return f"{head}{scenario}_{kind}_{controller}"


def membership_figure_stem(variable: str, controller: str) -> str:
    """``fig06_membership_d_t_paper`` for the paper controller's Figs. 6-11, else
    ``membership_<variable>_<controller>`` (the paper has no such figure)."""
    number = MEMBERSHIP_FIGURE.get(variable) if controller == "paper" else None
    head = f"fig{number:02d}_" if number is not None else ""
    return f"{head}membership_{variable}_{controller}"


@dataclass(frozen=True)
class IndexEntry:
    """One figure of the report's index (``figures/index.md``): its number in the paper
    ("12", "27", "27b", "" when the paper has none), what it shows, and its files
    (PNG, SVG)."""

    figure: str
    what: str
    scenario: str
    controller: str
    geometry: str
    files: tuple[Path, ...]


def write_paper_figures(
    results: dict,
    controllers: dict,
    root,
    geometry: str,
    *,
    formats=FORMATS,
    voltage_limit_v: float = 12.0,
) -> list[IndexEntry]:
    """The paper's Figs. 6-27 for one geometry into ``root/<geometry>/``.

    Parameters
    ----------
    results : ``{scenario: {controller name: SimulationResult}}`` (s1-s3 get the paper's
        numbers 12-26)
    controllers : ``{controller name: controller object}``; a fuzzy one also gets its
        membership figures (the paper controller's as Figs. 6-11)
    root : the figures folder; the geometry's subfolder is created
    geometry : ``husky`` or ``paper``, the folder's name and every title's
    formats, voltage_limit_v : as :func:`write_run_figures`

    Fig. 27 is the paper's 3 x 2: rows the scenarios, columns ``baseline`` (the stand-in
    for [19]) and ``paper`` (the proposed method), as far as they were run; every other
    controller (e.g. fuzzynav) gets Fig. "27b", laid out the same, beside it.

    Returns the index entries of every figure written, in order.
    """
    out_dir = check_writable_dir(Path(root) / geometry, option="out_dir")
    entries: list[IndexEntry] = []
    names_in_order: list[str] = []
    for scenario, inner in results.items():
        for name, result in inner.items():
            if name not in names_in_order:
                names_in_order.append(name)
            stems = {kind: paper_figure_stem(scenario, kind, name) for kind in RUN_FIGURES}
            files = write_run_figures(
                result,
                out_dir,
                names=stems,
                formats=formats,
                voltage_limit_v=voltage_limit_v,
                membership=False,
                controller_label=name,
            )
            for kind in RUN_FIGURES:
                number = paper_figure_number(scenario, kind)
                entries.append(
                    IndexEntry(
                        "" if number is None else str(number),
                        FIGURE_WHAT[kind],
                        scenario,
                        name,
                        geometry,
                        tuple(p for p in files if p.stem == stems[kind]),
                    )
                )
    for name in names_in_order:
        fis = _fis(controllers.get(name))
        if fis is None:
            continue
        files = write_membership_figures(
            fis,
            out_dir,
            formats=formats,
            stem=lambda var, name=name: membership_figure_stem(var, name),
            title_suffix=f"\n{name} controller, {geometry} geometry",
            numbers=MEMBERSHIP_FIGURE if name == "paper" else None,
        )
        for var in tuple(fis.inputs) + tuple(fis.outputs):
            stem = membership_figure_stem(var.name, name)
            number = MEMBERSHIP_FIGURE.get(var.name) if name == "paper" else None
            entries.append(
                IndexEntry(
                    "" if number is None else str(number),
                    f"{FIGURE_WHAT['membership']} {var.name}",
                    "—",
                    name,
                    geometry,
                    tuple(p for p in files if p.stem == stem),
                )
            )
    scenarios = list(results)
    pair = [c for c in FIG27_COLUMNS if c in names_in_order]
    others = [c for c in names_in_order if c not in FIG27_COLUMNS]
    for figure, columns, stem, what in (
        (str(COMPARISON_FIGURE), pair, "fig27_comparison", "the paper's 3 x 2"),
        (f"{COMPARISON_FIGURE}b", others, "fig27b_" + "_".join(others), "beside Fig. 27"),
    ):
        if not columns:
            continue
        who = " and ".join(FIG27_TITLES.get(c, c) for c in columns)
        files = write_comparison_figure(
            results,
            out_dir,
            name=stem,
            formats=formats,
            controllers=columns,
            column_titles=FIG27_TITLES,
            title=(
                f"Fig. {figure}, {geometry} geometry: trajectories while reaching the target\n{who}"
            ),
        )
        entries.append(
            IndexEntry(
                figure,
                f"{FIGURE_WHAT['comparison']} ({what})",
                ", ".join(scenarios),
                ", ".join(columns),
                geometry,
                tuple(files),
            )
        )
    return entries


def write_figure_index(entries, root) -> Path:
    """``root/index.md``: one row per figure (the paper's figure number, what it shows,
    scenario, controller, geometry) with links to its files, relative to ``root``."""
    root = Path(root)
    lines = [
        "# The paper's figures",
        "",
        "Files are named `fig<NN>_<scenario>_<figure>_<controller>` after the paper's figure",
        "numbers (s1: Figs. 12-16, s2: 17-21, s3: 22-26; Fig. 27 the comparison, 27b the",
        "other controllers beside it; the paper controller's membership functions Figs. 6-11),",
        "in one folder per geometry. Wheels: left = v_s1, right = v_s2 (Eqs. 3-4).",
        "",
        "| figure | what it shows | scenario | controller | geometry | files |",
        "|---|---|---|---|---|---|",
    ]
    geometries = list(dict.fromkeys(e.geometry for e in entries))

    def order(e: IndexEntry):
        # by geometry, then the paper's figure number (27b after 27; unnumbered last)
        digits = e.figure.rstrip("abcdefghijklmnopqrstuvwxyz")
        return (geometries.index(e.geometry), int(digits) if digits else 999, e.figure)

    for e in sorted(entries, key=order):
        links = " · ".join(f"[{p.suffix[1:]}]({p.relative_to(root).as_posix()})" for p in e.files)
        number = f"Fig. {e.figure}" if e.figure else "—"
        lines.append(
            f"| {number} | {e.what} | {e.scenario} | {e.controller} | {e.geometry} | {links} |"
        )
    path = root / "index.md"
    write_text_atomically(path, "\n".join(lines) + "\n")
    return path


# ---------------------------------------------------------------------------------------
# Command line: fuzzynav run ... --figures DIR


def add_run_options(parser) -> None:
    parser.add_argument(
        "--figures",
        type=Path,
        default=None,
        metavar="DIR",
        help="write the paper's figures of the run (PNG and SVG) into DIR",
    )


def run_hook(args, sim):
    out_dir = getattr(args, "figures", None)
    if out_dir is None:
        return None
    check_writable_dir(out_dir)

    def write(result, interrupted: bool) -> None:
        params = sim.model.parameters
        # Named as the report names them: by the paper's figure numbers (fig12_s1_...).
        name = _controller_label(sim.controller) or "controller"
        try:
            paths = write_run_figures(
                result,
                out_dir,
                controller=sim.controller,
                names={kind: run_figure_stem(result.scenario, kind, name) for kind in RUN_FIGURES},
                footprint_m=(params.footprint_length_m, params.footprint_width_m),
                voltage_limit_v=sim.voltage_limit_v,
                membership=False,
            )
            fis = _fis(sim.controller)
            if fis is not None:
                paths += write_membership_figures(
                    fis,
                    out_dir,
                    stem=lambda var: membership_figure_stem(var, name),
                    numbers=MEMBERSHIP_FIGURE if name == "paper" else None,
                )
        except OSError as exc:  # a full disk, a folder removed meanwhile
            raise ValueError(
                f"--figures {escape_controls(str(out_dir))}: the figures were not written "
                f"({exc.strerror or exc})"
            ) from None
        what = "partial run, " if interrupted else ""
        print(
            f"fuzzynav: {len(paths)} figure files ({what}PNG and SVG) written to "
            f"{escape_controls(str(out_dir))}",
            file=sys.stderr,
        )

    return write
