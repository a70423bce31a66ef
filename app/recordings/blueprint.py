"""The recording's default layout (its rerun blueprint) and its application id.

The world on the left, the paper's figures stacked on the right, with tabs for the
plant, the sensors, the rules and the run's documents. The time series' tabs and panels
are those the table of plots declares (:data:`.series.PLOTS`: title, tab, place,
legend, value range). A live recording sends the
layout first, so that a viewer opening the stream uses it at once, and again at the end
with the legends placed where the data leave room (:func:`.legend.legend_placement`);
``record_run``, whose file appears whole, once at the end. The application id
(:func:`application_id`) is ``fuzzynav-<scenario>-<controller>-<geometry>-<key of the
scenario's content>``, so recordings whose layouts differ keep their own in a viewer.
"""

from __future__ import annotations

import re

import numpy as np

from fuzzynav.app.figures.numbering import numbered_scenario, paper_figure_number, scenario_stem
from fuzzynav.world.metrics import row_blocks

from .events import EVENTS_LANES, EVENTS_LOG_PATH
from .fuzzy import FUZZY_PATH, FUZZY_W
from .internals import (
    INTERNAL_FLAGS_PATH,
    INTERNALS_PATH,
    RULES_HEATMAP_PATH,
    RULES_PATH,
    RULES_STRONGEST_PATH,
    RULES_TEXT_PATH,
    controller_label,
    has_internals,
    heatmap_bounds,
    rule_system,
)
from .scene import TRAIL_DISTURBED_PATH
from .sending import TIMELINE
from .series import CLEARANCE_SHOWN_M as CLEARANCE_SHOWN_M
from .series import PAPER, Setup, panel_name, paper_kinds, tab_panels
from .series import clearance_range as clearance_range
from .series import distance_colours as distance_colours

APPLICATION_ID = "fuzzynav"
#: How far below the start the world view reaches at least (m): the scale bar (0.75 m
#: below) and its label, under it, inside the view's 1 m margin.
SCALE_BELOW_START_M = 1.2


def world_bounds(scenario, log=None) -> tuple[list[float], list[float]]:
    """The world view's bounds: the robot's whole path (or, before it has one, the
    start), the target, and the obstacles near them, with a 1 m margin. A moving
    obstacle counts only where it comes within 2 m of that area, so a long run's view
    is the robot's, not the path of an obstacle that left for the horizon."""
    # (the start, its label and the 1 m scale bar below it, with its label: scene.py)
    xs = [scenario.start[0], scenario.target[0], scenario.start[0] - 0.8]
    ys = [scenario.start[1], scenario.target[1], scenario.start[1] - SCALE_BELOW_START_M]
    # A block of rows at a time (the metrics' blocks): a long run's log may be mapped
    # from the disk (world.simulation.LOG_BLOCK_BYTES), and its obstacle columns
    # reshaped whole were several copies of them.
    blocks = row_blocks(len(log)) if log is not None else []
    for start, stop in blocks:
        xy = np.asarray(log.pose[start:stop, :2])
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if len(xy):
            xs += [float(xy[:, 0].min()), float(xy[:, 0].max())]
            ys += [float(xy[:, 1].min()), float(xy[:, 1].max())]
    near = 2.0
    lo_x, hi_x, lo_y, hi_y = min(xs) - near, max(xs) + near, min(ys) - near, max(ys) + near

    def keep(points, radii):
        for (x, y), r in zip(points, radii):
            if lo_x <= x <= hi_x and lo_y <= y <= hi_y:
                xs.extend((x - r, x + r))
                ys.extend((y - r, y + r))

    keep([o.position for o in scenario.obstacles], [o.radius_m for o in scenario.obstacles])
    if blocks and log.obstacle_xy.size:
        for start, stop in blocks:
            block = np.asarray(log.obstacle_xy[start:stop])
            radii = np.broadcast_to(log.obstacle_radii_m[None, :], block.shape[:2]).reshape(-1)
            points = block.reshape(-1, 2)
            finite = np.all(np.isfinite(points), axis=1)
            inside = (
                finite
                & (points[:, 0] >= lo_x)
                & (points[:, 0] <= hi_x)
                & (points[:, 1] >= lo_y)
                & (points[:, 1] <= hi_y)
            )
            if inside.any():
                p, r = points[inside], radii[inside]
                xs += [float((p[:, 0] - r).min()), float((p[:, 0] + r).max())]
                ys += [float((p[:, 1] - r).min()), float((p[:, 1] + r).max())]
    margin = 1.0
    return [min(xs) - margin, max(xs) + margin], [min(ys) - margin, max(ys) + margin]


def figure_number(scenario_label: str, path: str) -> int | None:
    """18 for s2's distance panel: the paper's number of the figure a panel draws
    (:func:`app.figures.numbering.paper_figure_number`, one numbering everywhere), or None."""
    kind = paper_kinds().get(path)
    return paper_figure_number(scenario_label, kind) if kind else None


def _world_view(rrb, scenario, obstacle_ids, log):
    """The world on the left: the robot's trail and the obstacles' paths over the whole
    run, within :func:`world_bounds`."""
    x_range, y_range = world_bounds(scenario, log)
    # The view's origin is "/", where /world's mirror applies: scene y = -world y.
    bounds = rrb.VisualBounds2D(x_range=x_range, y_range=[-y_range[1], -y_range[0]])
    everything = rrb.VisibleTimeRanges(
        timeline=TIMELINE,
        start=rrb.TimeRangeBoundary.infinite(),
        end=rrb.TimeRangeBoundary.cursor_relative(),
    )
    overrides = {"/world/robot/trail": everything, TRAIL_DISTURBED_PATH: everything}
    for oid in obstacle_ids:
        overrides[f"/world/obstacles/{oid}/path"] = everything
    return rrb.Spatial2DView(
        origin="/",
        contents=["/world/**"],
        name="world (y up)",
        visual_bounds=bounds,
        overrides=overrides,
    )


def _plotter(rrb, whole_run, placements, label):
    """``plot(origin, name, ...)``: a time-series panel over the whole run, its legend
    and value range from ``placements`` (:func:`.legend.legend_placement`'s corners)."""

    def plot(origin, name, *, contents=None, legend=True, value_range=None, unit="", **kw):
        # (Linking the axes to the global range would drop this view range in 0.41.)
        axis = rrb.TimeAxis(view_range=whole_run)
        placement = placements.get(origin)
        corner, fixed = None, value_range
        if placement is not None:
            corner, value_range = placement if isinstance(placement, tuple) else (placement, None)
        if not legend:  # the panel's name says what its series are
            kw["plot_legend"] = rrb.PlotLegend(visible=False)
            value_range = placements.get(f"{origin}#data", value_range)
        elif corner is not None:
            kw["plot_legend"] = rrb.PlotLegend(corner=corner)
        if fixed is not None:  # (a panel sized for what it must show: the clearance)
            value_range = fixed
        if value_range is not None:
            kw["axis_y"] = rrb.ScalarAxis(range=value_range)
        if contents is not None:
            kw["contents"] = contents
        name = panel_name(name, unit, figure_number(label, origin))
        return rrb.TimeSeriesView(origin=origin, name=name, axis_x=axis, **kw)

    return plot


#: The height share of the events' lanes above the paper's figures.
LANES_SHARE = 1.15


def _panel(plot, entry, placements, setup):
    """The panel of ``entry`` (:class:`.series.Plot`: the first of its panel's entities)."""
    kw = {"unit": entry.unit}
    if entry.view is not None:
        kw["contents"] = [f"{entry.view}/**"]
    if not entry.legend:
        kw["legend"] = False
    if entry.value_range is not None:
        kw["value_range"] = entry.value_range(placements.get(f"{entry.origin}#data"))
    return plot(entry.origin, entry.panel_title(setup), **kw)


def _plot_tabs(rrb, plot, whole_run, placements, setup):
    """The tabs of time series, one panel per entry of :data:`.series.PLOTS` (entities
    that share a view: one panel); the paper's figures under the events' lanes."""
    tabs = []
    for name, entries in tab_panels().items():
        if not entries:
            continue
        shares = [entry.share or 1.0 for entry in entries]
        panels, kw = [], {}
        if name == PAPER:
            # The lanes over the whole run too, as the plots below them (without a time
            # range rerun shows a window around the cursor: the last ~27 s of a run at
            # opening).
            panels.append(
                rrb.StateTimelineView(
                    origin=EVENTS_LANES,
                    name="events: closest approach (centre to centre), safe distance, "
                    "disturbance, outcome",
                    time_view=rrb.TimeAxis(view_range=whole_run),
                )
            )
            kw["row_shares"] = [LANES_SHARE] + shares
        elif any(entry.share is not None for entry in entries):
            kw["row_shares"] = shares
        panels += [_panel(plot, entry, placements, setup) for entry in entries]
        tabs.append(rrb.Vertical(*panels, name=name, **kw))
    return tabs


def _firing_view(rrb, when: str):
    """The rules' firing strengths as a bar chart."""
    # The axis from 0 to 1 at every instant: a grey bar of 1 at abscissa 0
    # (RULES_SCALE_PATH, in the view as the origin's child), as rerun 0.41's bar
    # chart has no axis range and fitted its axis to the strongest rule of the moment.
    return rrb.BarChartView(
        origin=RULES_PATH,
        name=f"rule firing strength {when}, axis 0 to 1 (the grey bar at 0 is 1), bar k = rule Rk",
        plot_legend=rrb.PlotLegend(visible=False),
    )


def _rules_tabs(rrb, n_rules: int, whole_run) -> list:
    """The strongest rule over time, the firing at the cursor and the rules; in a tab
    of its own, as tall as the window, the heatmap (a name beside every row)."""
    heat_x, heat_y = heatmap_bounds(n_rules)
    rules = rrb.Vertical(
        rrb.StateTimelineView(
            origin=RULES_STRONGEST_PATH,
            name="the strongest rule at each decision",
            time_view=rrb.TimeAxis(view_range=whole_run),
        ),
        _firing_view(rrb, "at the time cursor"),
        rrb.TextDocumentView(origin=RULES_TEXT_PATH, name="the rules"),
        row_shares=[1, 2, 2],
        name="rules",
    )
    heatmap = rrb.Spatial2DView(
        origin=RULES_HEATMAP_PATH,
        # (the image and its names; not the tensor, which holds the values)
        contents=[f"+ {RULES_HEATMAP_PATH}/**", f"- {RULES_HEATMAP_PATH}"],
        name="rule firing over the run: rows R1 (top) to Rn, time across, dark 0 to yellow 1",
        visual_bounds=rrb.VisualBounds2D(x_range=heat_x, y_range=heat_y),
    )
    return [rules, rrb.Vertical(heatmap, name="heatmap")]


def _fuzzy_tab(rrb, fuzzy):
    """The inference at the time cursor, as the viewer's inference view."""
    views = [
        rrb.Spatial2DView(
            origin="/",
            contents=[f"{FUZZY_PATH}/{name}/**"],
            name=f"{name.replace('/', ' ')} at the cursor",
            visual_bounds=rrb.VisualBounds2D(x_range=[-0.6, FUZZY_W + 0.6], y_range=[-1.45, 0.25]),
        )
        for name in fuzzy
    ]
    return rrb.Vertical(
        rrb.Grid(*views, grid_columns=2),
        _firing_view(rrb, "at the cursor"),
        row_shares=[3, 1],
        name="fuzzy logic",
    )


def blueprint(
    scenario,
    obstacle_ids=(),
    n_rules: int = 0,
    log=None,
    internals: bool = False,
    legend_corners=None,
    fuzzy=(),
    perception: str | None = None,
):
    """The default layout: the world on the left, the paper's plots stacked on the right
    (further tabs: plant, sensors, rules, internals, run information).

    It depends on the run only through what the recording's application id already
    fixes (:func:`application_id`: the scenario's content, the geometry and the
    controller: obstacle ids, whether rules and internals exist) and through the world's
    bounds and the legends' corners, so that two recordings opened in one viewer do not
    share, or fight over, one layout."""
    import rerun.blueprint as rrb

    world = _world_view(rrb, scenario, obstacle_ids, log)
    # Every plot shows the whole run, like the paper's figures (the viewer would
    # otherwise show a window around the time cursor): unbounded both ways, so that the
    # layout holds for any run, not only this one's time span.
    whole_run = rrb.TimeRange(
        start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite()
    )
    placements = dict(legend_corners or {})
    label = numbered_scenario(scenario) or ""  # the paper's numbers for s1-s3 only
    plot = _plotter(rrb, whole_run, placements, label)
    setup = Setup(obstacle_ids=tuple(obstacle_ids), perception=perception)
    tabs = _plot_tabs(rrb, plot, whole_run, placements, setup)
    if n_rules:
        tabs += _rules_tabs(rrb, n_rules, whole_run)
    if fuzzy:  # the inference at the time cursor, as the viewer's inference view
        tabs.append(_fuzzy_tab(rrb, fuzzy))
    if internals:
        tabs.append(
            rrb.Vertical(
                plot(
                    INTERNALS_PATH,
                    "fuzzynav: avoidance weight alpha (0 to 1), planner offset",
                    unit="1, rad",
                ),
                rrb.StateTimelineView(
                    origin=INTERNAL_FLAGS_PATH,
                    name="fuzzynav's flags: yield or pass first, following an edge, "
                    "target reading doubted",
                    time_view=rrb.TimeAxis(view_range=whole_run),
                ),
                row_shares=[2, 1],
                name="internals",
            )
        )
    tabs.append(
        rrb.Tabs(
            *[
                rrb.TextDocumentView(origin=f"/meta/{name}", name=name)
                for name in ("run", "metrics", "scenario", "rules", "robot")
            ],
            name="run information",
        )
    )
    right = rrb.Tabs(*tabs, active_tab=0)
    left = rrb.Vertical(
        world,
        rrb.Tabs(
            rrb.TextDocumentView(origin="/meta/summary", name="summary"),
            rrb.TextLogView(origin=EVENTS_LOG_PATH, name="events"),
            active_tab=0,
        ),
        row_shares=[5, 3],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[1, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE, state="collapsed", play_state="following"),
        auto_views=False,
    )


def _id_part(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]+", "_", str(text)).strip("_")[:60] or "run"


def application_id(
    scenario,
    controller,
    geometry: str = "husky",
    *,
    perception: str | None = None,
    seed=None,
    noise_std_m: float = 0.0,
    control_period_s: float | None = None,
    voltage_limit_v: float = 12.0,
    parameters=None,
) -> str:
    """``fuzzynav-<scenario>-<controller>-<geometry>-<key>``: rerun keeps one layout per
    application id, and a layout holds value ranges sized from its run's data, so every
    recording whose data can differ gets its own. The scenario is its file's stem (s1)
    or its name; ``key`` is 8 hex digits of a sha256 over everything that changes what
    the layout shows: the scenario's content (two ``layout.toml`` files in different
    folders differ here), the geometry, the controller's rules and parameters
    (:func:`app.runs.rules_digest`), its rule count and internals (the rules tab),
    the perception, the seed, the sensor noise, the control period, the voltage limit
    and the robot's parameters (two runs that shared a layout had the later one's ranges
    clip the first's curves)."""
    import hashlib

    from fuzzynav.app.runs import rules_digest, scenario_digest

    label = scenario_stem(scenario)
    name = controller_label(controller)
    n_rules = len(getattr(rule_system(controller), "rules", ()))
    layout = "|".join(
        str(part)
        for part in (
            scenario_digest(scenario),
            geometry,
            name,
            n_rules,
            has_internals(controller),
            rules_digest(controller),
            perception,
            seed,
            repr(float(noise_std_m)),
            None if control_period_s is None else repr(float(control_period_s)),
            repr(float(voltage_limit_v)),
            parameters,
        )
    )
    key = hashlib.sha256(layout.encode("utf-8")).hexdigest()[:8]
    # (rerun 0.41 takes letters, digits, "-" and "_" in an application id.)
    parts = (APPLICATION_ID, _id_part(label), _id_part(name), _id_part(geometry), key)
    return "-".join(parts)


def recording_name(
    scenario,
    controller,
    geometry: str = "husky",
    *,
    perception: str | None = None,
    seed=None,
    noise_std_m: float = 0.0,
    control_period_s: float | None = None,
) -> str:
    """The name a viewer lists a recording under: the scenario and the controller, then
    what tells two runs of them apart (the perception; the geometry, the noise and its
    seed, the control period where not the default), so that two recordings of s2 with
    different perception are not listed under one name."""
    parts = [scenario.name, controller_label(controller)]
    if perception:
        parts.append(f"{perception} perception")
    if geometry != "husky":
        parts.append(f"{geometry} geometry")
    if float(noise_std_m or 0.0) > 0.0:
        parts.append(f"noise {float(noise_std_m):g} m, seed {seed}")
    if control_period_s is not None and abs(float(control_period_s) - 0.02) > 1e-12:
        parts.append(f"dt {float(control_period_s):g} s")
    return " · ".join(parts)
