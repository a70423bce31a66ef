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
from pathlib import Path

import numpy as np

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
    path = Path(path)
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
        fig.savefig(path, dpi=DPI, format=ext, metadata=_metadata(ext))
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


def _footprint(pose, length_m: float, width_m: float) -> np.ndarray:
    hl, hw = 0.5 * length_m, 0.5 * width_m
    corners = np.array([(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw), (hl, hw)])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack(
        [
            pose[0] + c * corners[:, 0] - s * corners[:, 1],
            pose[1] + s * corners[:, 0] + c * corners[:, 1],
        ]
    )


def draw_trajectory(
    ax,
    result,
    *,
    footprint_m=(0.99, 0.67),
    footprints: bool = True,
    legend: bool = True,
    title: str | None = None,
) -> None:
    """The paper's trajectory figure on ``ax`` (also used for the comparison grid)."""
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
    for col in range(len(log.obstacle_ids)):
        radius = float(log.obstacle_radii_m[col])
        pts = log.obstacle_xy[:, col]
        present = np.all(np.isfinite(pts), axis=1)
        if not present.any():
            continue
        color = OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)]
        first, last = pts[present][0], pts[present][-1]
        if col in moving:
            ax.plot(
                pts[present, 0],
                pts[present, 1],
                color=MOVING,
                lw=1.2,
                ls=":",
                label="moving obstacle's path" if col == min(moving) else None,
                zorder=2,
            )
            ax.add_patch(
                Circle(first, radius, facecolor="none", edgecolor=color, lw=0.8, ls="--", zorder=2)
            )
        ax.add_patch(Circle(last, radius, facecolor=color, edgecolor=color, alpha=0.75, zorder=3))
        ax.add_patch(
            Circle(
                last,
                radius + SAFE_DISTANCE_M,
                facecolor="none",
                edgecolor=SAFE,
                lw=0.9,
                ls="--",
                zorder=3,
                label=f"{SAFE_DISTANCE_M} m safe distance" if col == 0 else None,
            )
        )
        ax.annotate(
            _obstacle_label(log, col),
            last,
            xytext=(6, 6),
            textcoords="offset points",
            fontsize=7,
            color=color,
        )
    if footprints and len(log) > 1:
        period = max(1, int(round(FOOTPRINT_EVERY_S / max(result.control_period_s, 1e-9))))
        for k in list(range(0, len(log), period)) + [len(log) - 1]:
            outline = _footprint(log.pose[k], *footprint_m)
            ax.plot(outline[:, 0], outline[:, 1], color=ROBOT, lw=0.5, alpha=0.35, zorder=4)
    ax.plot(xy[:, 0], xy[:, 1], color=ROBOT, lw=1.8, label="robot (centre)", zorder=5)
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
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(True, lw=0.3, alpha=0.6)
    if title is not None:
        ax.set_title(title, fontsize=9)
    if legend:
        ax.legend(fontsize=7, loc="best", framealpha=0.85)


def _run_title(result, controller_label: str | None) -> str:
    who = f" — {controller_label}" if controller_label else ""
    return f"{result.scenario.name}{who} ({result.outcome})"


def _time_axes(ax, ylabel: str) -> None:
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, lw=0.3, alpha=0.6)


def _bearings(log) -> np.ndarray:
    dx = log.obstacle_xy[:, :, 0] - log.pose[:, 0:1]
    dy = log.obstacle_xy[:, :, 1] - log.pose[:, 1:2]
    return np.mod(np.arctan2(dy, dx) - log.pose[:, 2:3] + math.pi, 2 * math.pi) - math.pi


def write_run_figures(
    result,
    out_dir,
    controller=None,
    *,
    prefix: str = "",
    formats=FORMATS,
    footprint_m=None,
    voltage_limit_v: float = 12.0,
) -> list[Path]:
    """Write the paper's figure set for one run (see the module docstring).

    Parameters
    ----------
    result : SimulationResult (finished or partial)
    out_dir : directory, created if needed
    controller : optional; with a ``fis`` the membership figures are written too
    prefix : put before every file name (e.g. ``"s1_paper_"``)
    formats : file types (default PNG and SVG)
    footprint_m : (length, width) of the outlines drawn on the trajectory; default the
        real Husky's (0.99 m x 0.67 m)
    voltage_limit_v : the saturation drawn on the voltage figure

    Returns the files written, in order.
    """
    out_dir = check_writable_dir(out_dir, option="out_dir")
    log = result.log
    t = log.time_s
    label = _controller_label(controller)
    title = _run_title(result, label)
    footprint_m = footprint_m or _default_footprint()
    written: list[Path] = []

    # Fig. 12: trajectory
    fig, ax = _new_figure(6.4, 6.0)
    draw_trajectory(ax[0, 0], result, footprint_m=footprint_m, title=f"Trajectory — {title}")
    written += _save(fig, out_dir, f"{prefix}trajectory", formats)

    # Fig. 13: distances
    fig, ax = _new_figure(7.0, 5.6, 2, 1, sharex=True)
    d_t = np.hypot(log.target_xy[:, 0] - log.pose[:, 0], log.target_xy[:, 1] - log.pose[:, 1])
    ax[0, 0].plot(t, d_t, color=TARGET, lw=1.6, label="to the target")
    for col in range(len(log.obstacle_ids)):
        color = OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)]
        ax[0, 0].plot(
            t,
            log.center_distance_m[:, col],
            color=color,
            lw=1.2,
            label=f"to {_obstacle_label(log, col)}",
        )
        ax[1, 0].plot(
            t, log.clearance_m[:, col], color=color, lw=1.2, label=_obstacle_label(log, col)
        )
    ax[1, 0].axhline(
        SAFE_DISTANCE_M, color="0.4", ls="--", lw=0.9, label=f"{SAFE_DISTANCE_M} m safe distance"
    )
    ax[1, 0].axhline(0.0, color="k", lw=0.6)
    _time_axes(ax[0, 0], "distance, centre to centre (m)")
    _time_axes(ax[1, 0], "footprint clearance (m)")
    ax[0, 0].set_title(f"Distances — {title}", fontsize=9)
    for a in ax[:, 0]:
        a.legend(fontsize=7, loc="best")
    written += _save(fig, out_dir, f"{prefix}distances", formats)

    # Fig. 14: target angle and heading
    fig, ax = _new_figure(7.0, 5.6, 2, 1, sharex=True)
    phi_t = (
        np.mod(
            np.arctan2(log.target_xy[:, 1] - log.pose[:, 1], log.target_xy[:, 0] - log.pose[:, 0])
            - log.pose[:, 2]
            + math.pi,
            2 * math.pi,
        )
        - math.pi
    )
    ax[0, 0].plot(t, phi_t, color="#1f77b4", lw=1.4)
    ax[1, 0].plot(t, log.pose[:, 2], color="#d62728", lw=1.4)
    _time_axes(ax[0, 0], "target angle phi_t (rad)")
    _time_axes(ax[1, 0], "heading (rad)")
    ax[0, 0].set_title(f"Target angle and heading — {title}", fontsize=9)
    written += _save(fig, out_dir, f"{prefix}angles", formats)

    # Fig. 15: obstacle angles
    fig, ax = _new_figure(7.0, 3.6)
    a = ax[0, 0]
    if len(log.obstacle_ids) and len(log):
        bearings = _bearings(log)
        for col in range(len(log.obstacle_ids)):
            a.plot(
                t,
                bearings[:, col],
                color=OBSTACLE_COLORS[col % len(OBSTACLE_COLORS)],
                lw=1.2,
                label=_obstacle_label(log, col),
            )
        a.legend(fontsize=7, loc="best")
    else:
        a.text(0.5, 0.5, "no obstacles", ha="center", va="center", transform=a.transAxes)
    a.axhline(0.0, color="k", lw=0.6)
    _time_axes(a, "obstacle angle (rad)")
    a.set_title(f"Obstacle angles — {title}", fontsize=9)
    written += _save(fig, out_dir, f"{prefix}obstacle_angles", formats)

    # Fig. 16: voltages
    fig, ax = _new_figure(7.0, 3.6)
    a = ax[0, 0]
    limit = float(voltage_limit_v)
    a.plot(
        t,
        log.controller_output_v[:, 0],
        color="#1f77b4",
        lw=0.8,
        alpha=0.35,
        label="left, before saturation",
    )
    a.plot(
        t,
        log.controller_output_v[:, 1],
        color="#d62728",
        lw=0.8,
        alpha=0.35,
        label="right, before saturation",
    )
    a.plot(t, log.voltages_v[:, 0], color="#1f77b4", lw=1.4, label="left (v_s1)")
    a.plot(t, log.voltages_v[:, 1], color="#d62728", lw=1.4, label="right (v_s2)")
    for sign in (1, -1):
        a.axhline(
            sign * limit,
            color="0.3",
            ls="--",
            lw=0.9,
            label=f"±{limit:g} V limit" if sign > 0 else None,
        )
    _time_axes(a, "voltage (V)")
    a.set_title(f"Wheel voltages — {title}", fontsize=9)
    a.legend(fontsize=7, loc="best", ncols=2)
    written += _save(fig, out_dir, f"{prefix}voltages", formats)

    fis = _fis(controller)
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
    fis, out_dir, *, prefix: str = "", formats=FORMATS, points: int = 1001
) -> list[Path]:
    """One figure per input and output variable of a ``FuzzySystem``: every term's
    membership over the variable's range, named ``membership_<variable>``."""
    out_dir = check_writable_dir(out_dir, option="out_dir")
    written = []
    variables = [("input", v) for v in fis.inputs] + [("output", v) for v in fis.outputs]
    for kind, var in variables:
        lo, hi = var.range
        x = np.linspace(lo, hi, points)
        fig, ax = _new_figure(6.4, 3.0)
        a = ax[0, 0]
        for _k, term in enumerate(var.terms):
            y = np.asarray(term(x), dtype=float)
            (line,) = a.plot(x, y, lw=1.6, label=f"{term.name} ({term.shape})")
            peak = int(np.argmax(y))
            a.annotate(
                term.name,
                (x[peak], y[peak]),
                xytext=(0, 4),
                textcoords="offset points",
                ha="center",
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
        a.set_title(f"{kind} {var.name}" + (f": {desc}" if desc else ""), fontsize=9)
        a.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        written += _save(fig, out_dir, f"{prefix}membership_{var.name}", formats)
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
    fig, axes = plt.subplots(rows, 2, figsize=(10, 2.6 * rows), squeeze=False)
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
        a.grid(True, lw=0.3, alpha=0.6)
        a.legend(fontsize=7)
    for a in axes.ravel()[len(variables) :]:
        a.axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
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


def write_comparison_figure(
    results_by_controller_by_scenario: dict,
    out_dir,
    *,
    name: str = "comparison",
    formats=FORMATS,
    footprint_m=None,
) -> list[Path]:
    """The paper's Fig. 27: one row per scenario, one column per controller, each panel
    the trajectory of that controller in that scenario (same axes along a row).

    ``results_by_controller_by_scenario`` maps a scenario label to a mapping of
    controller label to ``SimulationResult``, e.g. ``{"s1": {"baseline": r1, "paper":
    r2}, "s2": {...}}``; any number of either. (Given as ``{controller: {scenario:
    result}}`` it is recognised and transposed.) A missing pair is drawn as an empty
    panel. Returns the files written.
    """
    out_dir = check_writable_dir(out_dir, option="out_dir")
    grid = _orient(results_by_controller_by_scenario)
    scenarios = list(grid)
    controllers: list = []
    for inner in grid.values():
        for c in inner:
            if c not in controllers:
                controllers.append(c)
    if not scenarios or not controllers:
        raise ValueError("write_comparison_figure: no results to draw")
    footprint_m = footprint_m or _default_footprint()
    rows, cols = len(scenarios), len(controllers)
    fig, axes = _new_figure(3.6 * cols + 0.4, 3.5 * rows + 0.3, rows, cols)
    letters = "abcdefghijklmnopqrstuvwxyz"
    for i, scenario in enumerate(scenarios):
        row_results = [grid[scenario].get(c) for c in controllers]
        for j, (controller, result) in enumerate(zip(controllers, row_results)):
            ax = axes[i, j]
            index = i * cols + j
            tag = f"({letters[index]})" if index < len(letters) else f"({index + 1})"
            if result is None:
                ax.set_axis_off()
                ax.set_title(f"{tag} {controller}, {scenario}: not run", fontsize=8)
                continue
            m = result.metrics or {}
            length = m.get("path_length_m")
            extra = f", {length:.2f} m" if isinstance(length, (int, float)) else ""
            draw_trajectory(
                ax,
                result,
                footprint_m=footprint_m,
                footprints=False,
                legend=(i == 0 and j == 0),
                title=f"{tag} {controller}, {scenario}: {result.outcome}{extra}",
            )
        _share_limits([axes[i, j] for j in range(cols) if row_results[j] is not None])
    fig.suptitle("Trajectories while reaching the target (paper Fig. 27)", fontsize=10)
    return _save(fig, out_dir, name, formats)


def _share_limits(axes) -> None:
    if not axes:
        return
    for ax in axes:
        ax.autoscale_view()
    xs = [ax.get_xlim() for ax in axes]
    ys = [ax.get_ylim() for ax in axes]
    xlim = (min(x[0] for x in xs), max(x[1] for x in xs))
    ylim = (min(y[0] for y in ys), max(y[1] for y in ys))
    for ax in axes:
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)


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
        paths = write_run_figures(
            result,
            out_dir,
            controller=sim.controller,
            footprint_m=(params.footprint_length_m, params.footprint_width_m),
            voltage_limit_v=sim.voltage_limit_v,
        )
        what = "partial run, " if interrupted else ""
        print(
            f"fuzzynav: {len(paths)} figure files ({what}PNG and SVG) written to {out_dir}",
            file=sys.stderr,
        )

    return write
