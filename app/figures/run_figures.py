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
functions of every input and output (the paper's Figs. 6-11, :mod:`.membership`). The
trajectory is drawn by :mod:`.trajectory`, the names and numbers are :mod:`.numbering`'s,
colours and files :mod:`.style`'s. ``run --figures DIR`` (:func:`run_hook`) writes them
under the paper's numbers.

Figures are drawn on ``matplotlib.figure.Figure`` with the Agg canvas: no pyplot state,
no backend switch, safe beside the viewer.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from fuzzynav.app.figures.membership import membership_figure_names, write_membership_figures
from fuzzynav.app.figures.numbering import (
    MEMBERSHIP_FIGURE,
    RUN_FIGURES,
    membership_figure_stem,
    numbered_scenario,
    paper_figure_number,
    run_figure_stem,
)
from fuzzynav.app.figures.style import (
    D_T,
    FORMATS,
    HEADING,
    OBSTACLE_COLORS,
    PHI_T,
    SAFE_DISTANCE_M,
    WHEEL_LEFT,
    WHEEL_RIGHT,
    _default_footprint,
    _legend_outside,
    _new_figure,
    _obstacle_label,
    _save,
    _time_axes,
    check_writable_dir,
    disturbance_window_s,
)
from fuzzynav.app.figures.trajectory import (
    closest_approaches,
    draw_trajectory,
    separate_labels,
)
from fuzzynav.app.recordings.internals import controller_fis
from fuzzynav.app.recordings.internals import controller_label as label_of
from fuzzynav.resources import escape_controls
from fuzzynav.safe_files import check_replaceable
from fuzzynav.world.geometry import obstacle_bearings, target_geometry


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
    title = _run_title(result, controller_label)
    paper_geometry = getattr(result, "geometry", "husky") == "paper"
    if kind == "trajectory":
        return _trajectory_figure(result, title, footprint_m, paper_geometry)
    if kind == "distances":
        return _distances_figure(result, title, paper_geometry)
    if kind == "angles":
        return _angles_figure(result, title)
    if kind == "obstacle_angles":
        return _obstacle_angles_figure(result, title)
    return _voltages_figure(result, title, voltage_limit_v)


def _trajectory_figure(result, title: str, footprint_m, paper_geometry: bool):
    """The trajectory figure (the paper's footprints drawn only for the Husky's)."""
    fig, ax = _new_figure(6.4, 6.0)
    draw_trajectory(
        ax[0, 0],
        result,
        footprint_m=footprint_m or _default_footprint(),
        footprints=not paper_geometry,
        title=f"{_figure_prefix(result, 'trajectory')}Trajectory — {title}",
    )
    separate_labels(fig)
    return fig


def _distances_figure(result, title: str, paper_geometry: bool):
    """Distances centre to centre (top) and the footprint's clearance (bottom)."""
    log, scenario = result.log, result.scenario
    t = log.time_s
    fig, ax = _new_figure(7.6, 5.6, 2, 1, sharex=True)
    top, bottom = ax[0, 0], ax[1, 0]
    d_t = np.hypot(log.target_xy[:, 0] - log.pose[:, 0], log.target_xy[:, 1] - log.pose[:, 1])
    top.plot(t, d_t, color=D_T, lw=1.6, label="to the target")
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


def _angles_figure(result, title: str):
    """The target angle (top; as received too, under a disturbance) and the heading."""
    log, scenario = result.log, result.scenario
    t = log.time_s
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
    top.plot(t, phi_t, color=PHI_T, lw=1.4, label="phi_t")
    bottom.plot(t, log.pose[:, 2], color=HEADING, lw=1.4, label="heading")
    _time_axes(top, "target angle phi_t (rad)", scenario, xlabel=False)
    _time_axes(bottom, "heading (rad)", scenario)
    top.set_title(
        f"{_figure_prefix(result, 'angles')}Target angle and heading — {title}", fontsize=9
    )
    for a in (top, bottom):
        _legend_outside(a)
    return fig


def _obstacle_angles_figure(result, title: str):
    """Each obstacle's bearing from the heading, broken where it wraps."""
    log, scenario = result.log, result.scenario
    t = log.time_s
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
    a.set_title(f"{_figure_prefix(result, 'obstacle_angles')}Obstacle angles — {title}", fontsize=9)
    if a.get_legend_handles_labels()[0]:
        _legend_outside(a)
    return fig


def _voltages_figure(result, title: str, voltage_limit_v: float):
    """The wheel voltages: one panel per wheel (neither hides the other) and their
    difference."""
    log, scenario = result.log, result.scenario
    t = log.time_s
    fig, ax = _new_figure(7.6, 6.4, 3, 1, sharex=True, height_ratios=(1.0, 1.0, 0.75))
    limit = float(voltage_limit_v)
    for row, (name, color) in enumerate(
        (("left (v_s1)", WHEEL_LEFT), ("right (v_s2)", WHEEL_RIGHT))
    ):
        a = ax[row, 0]
        before, label = _drawable_output(log.controller_output_v[:, row], limit)
        a.plot(t, before, color=color, lw=0.7, alpha=0.4, label=label)
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


def _drawable_output(values, limit_v: float) -> tuple[np.ndarray, str]:
    """A controller's output before saturation as the voltage figure draws it, and its
    label: within +-OUTPUT_DRAWN_FACTOR x the limit (a controller answering +-1e308
    made matplotlib's scaling overflow: RuntimeWarnings), the label saying
    so when it cut anything."""
    bound = OUTPUT_DRAWN_FACTOR * max(abs(limit_v), 1e-9)
    values = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        outside = np.abs(values) > bound
    if not outside.any():
        return values, "before saturation"
    return (
        np.clip(values, -bound, bound),
        f"before saturation (drawn within ±{bound:g} V)",
    )


#: The voltage figure draws a controller's output within this many times the limit.
OUTPUT_DRAWN_FACTOR = 10.0


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
    for path in run_figure_paths(
        out_dir, controller, prefix=prefix, names=names, formats=formats, membership=membership
    ):
        check_replaceable(path)  # within an OutputScope: before any figure is drawn
    label = controller_label or label_of(controller, unknown=None)
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
    fis = controller_fis(controller, merged=True) if membership else None
    if fis is not None:
        written += write_membership_figures(fis, out_dir, prefix=prefix, formats=formats)
    return written


def run_figure_paths(
    out_dir, controller=None, *, prefix="", names=None, formats=FORMATS, membership=True
) -> list[Path]:
    """The files :func:`write_run_figures` writes with these arguments, in order."""
    stems = [names[kind] if names is not None else f"{prefix}{kind}" for kind in RUN_FIGURES]
    fis = controller_fis(controller, merged=True) if membership else None
    if fis is not None:
        stems += [f"{prefix}{name}" for name in membership_figure_names(fis)]
    return [Path(out_dir) / f"{stem}.{ext}" for stem in stems for ext in formats]


def add_run_options(parser) -> None:
    parser.add_argument(
        "--figures",
        type=Path,
        metavar="DIR",
        help="write the paper's figures of the run (PNG and SVG) into DIR (a file of the "
        "same name already there is never replaced without --force)",
    )
    from fuzzynav.app.args import add_force_option

    add_force_option(parser, "figure files already in --figures DIR")


def _planned_paths(out_dir: Path, names: dict, membership_stem, fis) -> list[Path]:
    """The files ``run --figures`` writes, known before the run."""
    paths = run_figure_paths(out_dir, names=names, membership=False)
    if fis is not None:
        stems = [membership_stem(v.name) for v in (*fis.inputs, *fis.outputs)]
        paths += [out_dir / f"{stem}.{ext}" for stem in stems for ext in FORMATS]
    return paths


def run_hook(args, sim):
    from fuzzynav.safe_files import OutputScope

    out_dir = getattr(args, "figures", None)
    if out_dir is None:
        return None
    check_writable_dir(out_dir)
    # Named as the report names them: by the paper's figure numbers (fig12_s1_...).
    name = label_of(sim.controller, unknown="controller")
    names = {kind: run_figure_stem(sim.scenario, kind, name) for kind in RUN_FIGURES}

    def membership_stem(var: str) -> str:
        return membership_figure_stem(var, name)

    fis = controller_fis(sim.controller, merged=True)
    # none replaces a file this command did not write, unless --force: checked before the run
    outputs = OutputScope("--figures", overwrite=getattr(args, "force", False))
    outputs.check(_planned_paths(Path(out_dir), names, membership_stem, fis))

    def write(result, interrupted: bool) -> None:
        params = sim.model.parameters
        try:
            with outputs:
                paths = write_run_figures(
                    result,
                    out_dir,
                    controller=sim.controller,
                    names=names,
                    footprint_m=(params.footprint_length_m, params.footprint_width_m),
                    voltage_limit_v=sim.voltage_limit_v,
                    membership=False,
                )
                if fis is not None:
                    paths += write_membership_figures(
                        fis,
                        out_dir,
                        stem=membership_stem,
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
