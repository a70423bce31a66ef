"""The recordings' time series, declared once: :data:`PLOTS`, one :class:`Plot` per
plot entity.

An entry says everything about its plot: the entity's path, the panel that shows it
(title, tab, place in the tab, legend, value range, the paper's figure it draws), its
series (names, colours, widths: the legend's) and the function that computes its
columns from the simulation's log, and, optionally, how the viewer's Signals tab shows
it live (:class:`Live`). Everything else is derived from the table:

- :func:`plot_spec` and :meth:`.columns.ColumnWriter._series` (what a recording holds:
  one entity per entry, in the table's order, one instance per series);
- the blueprint's panels (:func:`tab_panels`, read by :mod:`.blueprint`);
- the entities that share a panel (:func:`shared_views`: the legends' placement and the
  events' marks read them as one plot);
- the viewer's signal plots (:func:`live_plots`, read by ``app.viewer.plots``).

A new time series is one entry here when the quantity is in the log already
(``world.simulation.SimulationLog``); a quantity the simulation does not log yet is
logged there first, and a live plot of a value the viewer does not gather yet needs it
gathered (``app.viewer.driver``'s ``SIGNAL_COLUMNS``). The ``--trace`` CSV
(:mod:`.trace`) is a fixed, documented format of its own and is not derived from here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.world.geometry import obstacle_bearings, target_geometry

from .style import (
    DISTURBANCE,
    HEADING,
    INPUT_COLORS,
    LIMIT,
    OBSTACLE_NAMES,
    RIGHT,
    SAFE,
    SAFE_DISTANCE_M,
    SENSOR_COLORS,
    SERIES_PALETTE,
    TARGET,
    obstacle_color,
)

#: The tabs of the recording's layout that hold plots, in their order (a tab an entry
#: names that is not here comes after them). The first has the events' lanes on top.
PAPER, PLANT, SENSING = "paper figures", "plant and inputs", "sensors and safety"
TABS = (PAPER, PLANT, SENSING)

#: The clearance panel shows at most this much (m): the 0.25 m safe distance must be
#: seen, and a clearance of 10 m would flatten it onto zero.
CLEARANCE_SHOWN_M = 2.0


@dataclass(frozen=True)
class Setup:
    """What a plot's series and its panel's title may depend on: the run's obstacles
    (their ids, in the log's column order) and range sensors, the voltage limit and the
    perception (the blueprint knows the obstacles and the perception only)."""

    obstacle_ids: Sequence[int] = ()
    sensor_names: Sequence[str] = ()
    voltage_limit_v: float = 12.0
    perception: str | None = None

    @property
    def obstacles(self) -> list[str]:
        """``obstacle <id + 1>`` of every obstacle (:func:`obstacle_label`): the series
        names of a plot with one series an obstacle."""
        return [obstacle_label(i) for i in self.obstacle_ids]

    @property
    def obstacle_colors(self) -> list:
        """Every obstacle's colour (app.palette's, by column)."""
        return [obstacle_color(c) for c in range(len(self.obstacle_ids))]


class Rows:
    """Rows [start, end) of a run's log, as a plot's ``columns`` function reads them:
    ``log``, ``start``, ``end``, ``n``; ``pose``, ``target``, ``ranges``, ``inputs``
    (the rows' slices, already read); ``voltage_limit_v``; the target's distance and
    bearing and the obstacles' bearings, computed once for every plot that asks."""

    def __init__(self, log, start, end, pose, target, ranges, inputs, voltage_limit_v):
        self.log, self.start, self.end, self.n = log, start, end, end - start
        self.pose, self.target, self.ranges, self.inputs = pose, target, ranges, inputs
        self.voltage_limit_v = voltage_limit_v

    def logged(self, name: str) -> np.ndarray:
        """The log's array ``name`` over the rows.

        Parameters
        ----------
        name : str
            An array of ``world.simulation.SimulationLog`` (``clearance_m``, ...).
        """
        return getattr(self.log, name)[self.start : self.end]

    def constant(self, value: float) -> np.ndarray:
        """A column (n, 1) of ``value``: a line drawn across the plot (a limit).

        Parameters
        ----------
        value : float
            The line's value.
        """
        return value * np.ones((self.n, 1))

    @cached_property
    def target_geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """(d_t, phi_t): the target's distance and bearing from the pose, centre to
        centre, without the disturbance."""
        return target_geometry(self.pose, self.target)

    @cached_property
    def bearings(self) -> np.ndarray:
        """(n, obstacles): every obstacle's bearing from the heading."""
        if not len(self.log.obstacle_ids):
            return np.zeros((self.n, 0))
        return obstacle_bearings(self.pose, self.logged("obstacle_xy"))


@dataclass(frozen=True)
class LiveLine:
    """One line of a live plot: a column of the viewer's live signal rows (its name in
    ``app.viewer.driver.SIGNAL_COLUMNS``) or a constant ``value``; uPlot's label,
    stroke (CSS colour), width and dash."""

    label: str
    stroke: str
    column: str | None = None
    value: float | None = None
    width: float = 2.0
    dash: tuple[int, ...] | None = None


@dataclass(frozen=True)
class Live:
    """How the viewer's Signals tab shows a plot while the run plays: a uPlot titled
    ``title`` with ``lines``, a fixed value range, or one computed from the scenario
    (the plot is rebuilt when it changes), at position ``order`` in the tab."""

    title: str
    lines: tuple[LiveLine, ...]
    y_range: tuple[float, float] | Callable[[object], tuple[float, float]]
    order: float = 0.0


Values = Sequence | Callable[[Setup], Sequence]


@dataclass(frozen=True)
class Plot:
    """One plot entity of a recording, and the panel that shows it.

    ``path``: the entity. ``title``: the panel's name (a string, or a function of the
    :class:`Setup`). ``tab``: the layout's tab. ``names``, ``colors``, ``widths``: one
    per series (lists, or functions of the :class:`Setup`). ``columns``: a function of
    :class:`Rows` that returns (rows, series). ``view``: the panel's origin when several
    entities share one panel (its title, legend and range are the first entity's).
    ``legend``: False hides it (the title says which series is which). ``value_range``:
    a function of the data's range (or None) that fixes the panel's value range.
    ``share``: the panel's height share in its tab. ``place``: its rank in the tab
    (lower first; equal ranks keep the table's order). ``figure``: the kind of the
    paper's figure it draws (``app.figures.numbering``: the panel's name gets its
    number). ``live``: its plot in the viewer's Signals tab, if any."""

    path: str
    title: str | Callable[[Setup], str]
    tab: str
    names: Values
    colors: Values
    widths: Values
    columns: Callable[[Rows], np.ndarray] = field(repr=False)
    view: str | None = None
    legend: bool = True
    value_range: Callable[[tuple | None], tuple[float, float]] | None = None
    share: float | None = None
    place: int = 0
    figure: str | None = None
    live: Live | None = None

    @property
    def origin(self) -> str:
        """The panel's origin: the shared view, or the entity itself."""
        return self.view or self.path

    def series(self, setup: Setup) -> tuple[list, list, list]:
        """(names, colors, widths) of the plot's series in a run.

        Parameters
        ----------
        setup : Setup
            The run's obstacles, sensors and voltage limit.
        """
        return tuple(  # type: ignore[return-value]
            list(v(setup) if callable(v) else v) for v in (self.names, self.colors, self.widths)
        )

    def panel_title(self, setup: Setup) -> str:
        """The panel's name in a run (without the paper's figure number).

        Parameters
        ----------
        setup : Setup
            The run's obstacles and perception.
        """
        return self.title(setup) if callable(self.title) else self.title


def distance_colours(obstacle_ids) -> str:
    """``obstacle 1 (red), obstacle 2 (orange)...``: the distance panel's key.

    Parameters
    ----------
    obstacle_ids : sequence of int
        The run's obstacles, in the log's column order.
    """
    parts = [
        f"{obstacle_label(oid)} ({OBSTACLE_NAMES[col % len(OBSTACLE_NAMES)]})"
        for col, oid in enumerate(obstacle_ids)
    ]
    return ", ".join(parts) if parts else "no obstacle"


def clearance_range(data_range) -> tuple[float, float]:
    """The clearance panel's value range: from the data's lowest value (or just below
    zero) to the highest, at most :data:`CLEARANCE_SHOWN_M`, and always with room on
    both sides of the safe distance's line.

    Parameters
    ----------
    data_range : (float, float) or None
        The data's range with 5 % of its span each side (the legends' ``#data``), or
        None before there are data.
    """
    if data_range is None:
        return (-0.05, 1.0)
    lo_p, hi_p = float(data_range[0]), float(data_range[1])
    pad = (hi_p - lo_p) / 22.0  # (the data's range came with 5 % of its span each side)
    lo, hi = lo_p + pad, hi_p - pad
    hi = min(max(hi_p, 3.0 * SAFE_DISTANCE_M), CLEARANCE_SHOWN_M)
    lo = min(lo - 0.05 * (hi - min(lo, 0.0)), -0.05)
    return (lo, hi)


def _distance_top(scenario) -> tuple[float, float]:
    """The live distance plot's range: up to the start-target distance, rounded up, at
    least 4 m."""
    span = math.dist(scenario.start, scenario.target)
    return (0.0, float(max(4.0, math.ceil(span + 0.5))))


def _voltage_series(s: Setup) -> list[str]:
    # (the two limits share one name: one legend entry)
    limit = f"±{s.voltage_limit_v:g} V limit"
    return ["left", "right", "left, before limit", "right, before limit", limit, limit]


def _voltage_columns(r: Rows) -> np.ndarray:
    limit = r.voltage_limit_v
    return np.column_stack(
        [
            r.logged("voltages_v"),
            r.logged("controller_output_v"),
            r.constant(limit),
            r.constant(-limit),
        ]
    )


_P = SERIES_PALETTE
_ONE = [1.5]
_TWO = [1.5] * 2

#: Every plot of a recording, in the order its entities are sent (keep it: the order is
#: the recordings'). A new time series is a new entry (see the module's docstring).
PLOTS: list[Plot] = [
    Plot(
        "/plots/distance",
        lambda s: (
            "distance to the target (green) and to "
            + distance_colours(s.obstacle_ids)
            + ", centre to centre, m"
        ),
        PAPER,
        lambda s: ["target"] + s.obstacles,
        lambda s: [TARGET] + s.obstacle_colors,
        lambda s: [2.0] + [1.5] * len(s.obstacle_ids),
        lambda r: np.column_stack([r.target_geometry[0], r.logged("center_distance_m")]),
        # No legend: rerun draws it over the plot, and the room made for it stretched
        # the axis to about twice the data's span; the name says which colour is which.
        legend=False,
        share=1.2,
        figure="distances",
    ),
    Plot(
        "/plots/angles/phi_t",
        "target angle phi_t and heading, rad",
        PAPER,
        ["phi_t"],
        [INPUT_COLORS["phi_t"]],
        _ONE,
        lambda r: r.target_geometry[1][:, None],
        view="/plots/angles",  # one panel with the heading, as the paper's Fig. 14
        share=1.15,
        figure="angles",
    ),
    Plot(
        "/plots/angles/heading",
        "",
        PAPER,
        ["heading"],
        [HEADING],
        _ONE,
        lambda r: r.pose[:, 2:3],
        view="/plots/angles",
    ),
    Plot(
        "/plots/obstacle_angles",
        "obstacle angles from the heading, rad",
        PAPER,
        lambda s: s.obstacles,
        lambda s: s.obstacle_colors,
        lambda s: [1.5] * len(s.obstacle_ids),
        lambda r: r.bearings,
        share=1.15,
        figure="obstacle_angles",
    ),
    Plot(
        "/plots/voltage",
        # Five series: a legend would cover the start; the name says which is which.
        "wheel voltages, V: blue left, black right (pale: before the limit), grey ±12 V",
        PAPER,
        _voltage_series,
        [_P[0], RIGHT, (150, 190, 230), (150, 150, 150), LIMIT, LIMIT],
        [2.0, 2.0, 1.0, 1.0, 1.0, 1.0],
        _voltage_columns,
        legend=False,
        share=1.35,
        figure="voltages",
        live=Live(
            "Wheel voltages (V, after the 12 V limit)",
            (
                LiveLine("left", "#7c3aed", column="v_left"),
                LiveLine("right", "#059669", column="v_right"),
            ),
            (-12.5, 12.5),
            order=2.0,
        ),
    ),
    Plot(
        "/plots/inputs/distances",
        "inputs d_t, d_o, m, as the controller saw them (d_o gap: nothing sensed)",
        PLANT,
        ["d_t", "d_o"],
        [INPUT_COLORS["d_t"], INPUT_COLORS["d_o"]],
        _TWO,
        lambda r: r.inputs[:, [0, 1]],
        place=1,
        live=Live(
            "Distances (m)",
            (
                LiveLine("d_t target", "#2563eb", column="d_t"),
                LiveLine("d_o obstacle", "#dc2626", column="d_o"),
                LiveLine(
                    f"safe {SAFE_DISTANCE_M:g}",
                    "#f59e0b",
                    value=SAFE_DISTANCE_M,
                    width=1,
                    dash=(5, 4),
                ),
            ),
            _distance_top,
            order=0.0,
        ),
    ),
    Plot(
        "/plots/inputs/angles",
        "inputs phi_t, phi_o, rad, as the controller saw them (phi_o gap: nothing sensed)",
        PLANT,
        ["phi_t", "phi_o"],
        [INPUT_COLORS["phi_t"], INPUT_COLORS["phi_o"]],
        _TWO,
        lambda r: r.inputs[:, [2, 3]],
        place=1,
        live=Live(
            "Bearings (rad, + = to the left)",
            (
                LiveLine("φ_t target", "#2563eb", column="phi_t"),
                LiveLine("φ_o obstacle", "#dc2626", column="phi_o"),
            ),
            (-3.2, 3.2),
            order=1.0,
        ),
    ),
    Plot(
        "/plots/clearance",
        f"footprint clearance, m, up to {CLEARANCE_SHOWN_M:g} m shown, obstacles in their "
        f"colours, grey the {SAFE_DISTANCE_M:g} m safe distance",
        SENSING,
        lambda s: s.obstacles + [f"safe {SAFE_DISTANCE_M} m"],
        lambda s: s.obstacle_colors + [SAFE],
        lambda s: [1.5] * len(s.obstacle_ids) + [2.0],
        lambda r: np.column_stack([r.logged("clearance_m"), r.constant(SAFE_DISTANCE_M)]),
        legend=False,
        value_range=clearance_range,
        place=1,
    ),
    Plot(
        "/plots/wheels",
        "wheel speeds w_LW, w_RW, rad/s",
        PLANT,
        ["w_LW (rad/s)", "w_RW (rad/s)"],
        [_P[0], RIGHT],
        _TWO,
        lambda r: r.logged("lg_state")[:, 0:2],
    ),
    Plot(
        "/plots/velocity",
        "v_MH, m/s, and w_JH, rad/s",
        PLANT,
        ["v_MH (m/s)", "w_JH (rad/s)"],
        [_P[0], HEADING],
        _TWO,
        lambda r: r.logged("lg_state")[:, 2:4],
    ),
    Plot(
        "/plots/current",
        "motor currents i_L1, i_L2, A",
        PLANT,
        ["i_L1 left (A)", "i_L2 right (A)"],
        [_P[0], RIGHT],
        _TWO,
        lambda r: r.logged("lg_state")[:, 4:6],
    ),
    Plot(
        "/plots/ranges",
        lambda s: (
            "sensor ranges, m (gap: no echo)"
            + (
                " — not used: ideal perception drives on the true obstacles"
                if s.perception == "ideal"
                else ""
            )
        ),
        SENSING,
        lambda s: [f"{m} (m)" for m in s.sensor_names],
        lambda s: [SENSOR_COLORS.get(m, (120, 120, 120)) for m in s.sensor_names],
        lambda s: [1.5] * len(s.sensor_names),
        lambda r: np.where(np.isinf(r.ranges), np.nan, r.ranges),
    ),
    Plot(
        "/plots/disturbance",
        "disturbance added to every input (m on d_t, d_o; rad on phi_t, phi_o)",
        SENSING,
        ["disturbance"],
        [DISTURBANCE],
        _ONE,
        lambda r: r.logged("disturbance")[:, None],
        legend=False,
        place=1,
    ),
]


def plot_spec(setup: Setup) -> list[tuple[Plot, list, list, list]]:
    """(entry, names, colors, widths) of every plot of :data:`PLOTS` in a run, in the
    table's order.

    Parameters
    ----------
    setup : Setup
        The run's obstacles, sensors and voltage limit.
    """
    return [(plot, *plot.series(setup)) for plot in PLOTS]


def shared_views() -> dict[str, list[str]]:
    """``{view: [entity, ...]}`` of the panels that show several entities (the target
    angle and the heading), in the table's order."""
    views: dict[str, list[str]] = {}
    for plot in PLOTS:
        if plot.view is not None:
            views.setdefault(plot.view, []).append(plot.path)
    return {view: paths for view, paths in views.items() if len(paths) > 1}


def paper_kinds() -> dict[str, str]:
    """``{panel origin: kind}`` of the panels that draw a paper's figure
    (``app.figures.numbering``'s kinds)."""
    return {plot.origin: plot.figure for plot in PLOTS if plot.figure}


def tab_panels() -> dict[str, list[Plot]]:
    """``{tab: [the first entry of each panel, ...]}``: the tabs of :data:`TABS` and
    then any other an entry names, each panel in ``place`` order (then the table's)."""
    firsts: dict[str, Plot] = {}
    for plot in PLOTS:
        firsts.setdefault(plot.origin, plot)
    tabs: dict[str, list[Plot]] = {tab: [] for tab in TABS}
    for plot in firsts.values():
        tabs.setdefault(plot.tab, []).append(plot)
    return {tab: sorted(panels, key=lambda p: p.place) for tab, panels in tabs.items()}


def live_plots() -> list[Plot]:
    """The entries the viewer's Signals tab shows live, in their ``live.order``."""
    return sorted((p for p in PLOTS if p.live is not None), key=lambda p: p.live.order)  # type: ignore[union-attr]
