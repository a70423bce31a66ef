"""The figures' shared style: colours, sizes and file types, a figure on the Agg canvas,
files written whole, time axes, and legends (what a figure asks of a controller, its fuzzy
system and name, is app.recordings.internals's).

The colours are :mod:`app.palette`'s: red, orange, purple... mean obstacles 1, 2, 3...
(ids 0, 1, 2...) everywhere (figures, recordings, viewer); the right wheel and the heading
take colours no obstacle has. What a person reads is :func:`obstacle_label`'s, 1-based
everywhere; ids, entity paths and data stay 0-based.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from fuzzynav.app import palette
from fuzzynav.safe_files import atomic_output

SAFE_DISTANCE_M = 0.25
FORMATS = ("png", "svg")
DPI = 150

# Colours: app.palette's, one palette for the figures, the recordings and the viewer.
ROBOT = palette.ROBOT
TARGET = palette.TARGET
SAFE = palette.SAFE
WHEEL_LEFT = palette.WHEEL_LEFT
WHEEL_RIGHT = palette.WHEEL_RIGHT
HEADING = palette.HEADING
EVENT = palette.EVENT
DISTURBANCE = palette.DISTURBANCE
BREACH = palette.BREACH
PHI_T = palette.PHI_T
D_T = palette.D_T
TERMS = palette.TERMS
OBSTACLE_COLORS = list(palette.OBSTACLES)


def check_writable_dir(path, option: str = "--figures") -> Path:
    """Create ``path`` if needed and make sure files can be written in it; ValueError
    with the reason otherwise."""
    from fuzzynav.safe_files import as_path, refuse_installed

    path = as_path(path, option)
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


def obstacle_label(obstacle_id: int) -> str:
    """What a person reads for an obstacle, everywhere (figures, recordings, viewer,
    docs): ``obstacle 1`` for id 0, as the viewer and the paper count them.

    Parameters
    ----------
    obstacle_id : int
        The obstacle's id (0-based: the scenario's ``obstacles[k]`` has id k), as in
        entity paths, JSON fields and the trace's columns.

    Returns
    -------
    str
        ``obstacle <id + 1>``.
    """
    return f"obstacle {int(obstacle_id) + 1}"


def _obstacle_label(log, col: int) -> str:
    return obstacle_label(log.obstacle_ids[col])


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


def _default_footprint() -> tuple[float, float]:
    """The robot's footprint (:data:`fuzzynav.world.robot.HUSKY`), length and width, m."""
    from fuzzynav.world.robot import HUSKY

    return HUSKY.footprint_m
