"""Recordings a reviewer reads at 1600 px without a squint: each test reads a recording
back (rerun's SDK) and checks what the viewer will draw from it: the angles broken at
the +-pi wrap, units where a cut name keeps them, a moving obstacle's ring where it is
at each moment, events only from their time on, the disturbance on the trail, each
mark's legend its own colour, fuzzynav's flags apart from its weights, every rule row
named, the fuzzy tab's labels apart, the step timeline, the git tree's state.

No number a run produces is written here: every expectation comes from the run's log."""

from __future__ import annotations

import re

import numpy as np
import pyarrow as pa
import pytest

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402
from test_recording import Recording, _views, nanos  # noqa: E402

from fuzzynav.app.recordings import documents  # noqa: E402
from fuzzynav.app.recordings.record import record_simulation  # noqa: E402
from fuzzynav.app.recordings.style import SAFE_DISTANCE_M  # noqa: E402
from fuzzynav.app.runs import build_simulation  # noqa: E402
from fuzzynav.world.geometry import obstacle_bearings  # noqa: E402


def _record(tmp_path_factory, scenario, controller):
    sim = build_simulation(scenario, controller)
    result = sim.run()
    path = tmp_path_factory.mktemp("rrd") / f"{scenario}_{controller}.rrd"
    record_simulation(sim, result, path)
    return sim, result, Recording(path), path


@pytest.fixture(scope="module")
def s2_fuzzynav(tmp_path_factory):
    """s2 with fuzzynav: a moving obstacle, and obstacle 1 behind the robot late in the
    run (its bearing crosses +-pi)."""
    return _record(tmp_path_factory, "s2", "fuzzynav")


@pytest.fixture(scope="module")
def s3_fuzzynav(tmp_path_factory):
    """s3 with fuzzynav: the disturbance window (25 s to 35 s)."""
    return _record(tmp_path_factory, "s3", "fuzzynav")


@pytest.fixture(scope="module")
def s1_paper(tmp_path_factory):
    return _record(tmp_path_factory, "s1", "paper")


# ---------------------------------------------------------------------------------------
# The obstacles' angles: broken at the wrap, as Fig. 20


def test_obstacle_angles_are_broken_where_they_cross_the_wrap(s2_fuzzynav):
    """A bearing that goes from near +pi to near -pi between two rows was joined by a
    stroke the height of the panel (s2 fuzzynav at 28.5 s): the recording holds a gap
    (NaN) at that row, and nowhere else does a curve jump by more than pi."""
    _, result, rec, _ = s2_fuzzynav
    log = result.log
    bearings = obstacle_bearings(log.pose, log.obstacle_xy)
    wraps = np.abs(np.diff(bearings, axis=0)) > np.pi
    assert wraps.any(), "the run no longer crosses the wrap: pick another"
    times, values = rec.scalars("/plots/obstacle_angles")
    assert np.array_equal(times, nanos(log.time_s))
    gap = np.zeros_like(wraps, shape=bearings.shape)
    gap[1:] = wraps
    assert np.all(np.isnan(values[gap]))
    assert np.array_equal(values[~gap], bearings[~gap])  # nothing else lost
    with np.errstate(invalid="ignore"):
        assert not np.any(np.abs(np.diff(values, axis=0)) > np.pi)


def test_the_wrap_is_broken_across_a_chunk_boundary():
    """A live recording sends its rows in chunks: a wrap between two chunks is broken
    too (the row before the chunk is read from the log)."""
    from fuzzynav.app.recordings.series import broken_at_wrap

    angles = np.array([[3.1], [-3.1], [-3.0]])
    assert np.isnan(broken_at_wrap(angles)[1, 0])
    chunk = broken_at_wrap(angles[1:], before_rad=angles[0])
    assert np.isnan(chunk[0, 0]) and chunk[1, 0] == -3.0
    assert not np.isnan(broken_at_wrap(angles[1:])).any()


# ---------------------------------------------------------------------------------------
# Units and figure numbers that survive a cut name


def test_every_plot_starts_its_name_with_its_figure_and_unit(s2_fuzzynav):
    """At 1600 px a long name was cut at its end ("...centre to centre >"), and the unit
    and the paper's figure number with it: they now open the name, in at most 20
    characters (s2's distance panel: "Fig. 18 [m] ...")."""
    from fuzzynav.app.figures.numbering import paper_figure_number

    views = _views(s2_fuzzynav[3])
    plots = {
        v["ViewBlueprint:space_origin"][0]: n
        for n, v in views.items()
        if v["ViewBlueprint:class_identifier"] == ["TimeSeries"]
    }
    assert len(plots) >= 12
    for name in plots.values():
        head = re.match(r"^(Fig\. (\d+) )?\[([^\]]+)\] ", name)
        assert head is not None and len(head.group(0)) <= 20, name
    for origin, kind in (
        ("/plots/distance", "distances"),
        ("/plots/angles", "angles"),
        ("/plots/obstacle_angles", "obstacle_angles"),
        ("/plots/voltage", "voltages"),
    ):
        number = paper_figure_number("s2", kind)
        assert plots[origin].startswith(f"Fig. {number} ["), plots[origin]
    assert plots["/plots/distance"].startswith("Fig. 18 [m] ")
    assert plots["/plots/voltage"].startswith("Fig. 21 [V] ")


# ---------------------------------------------------------------------------------------
# The world at the time cursor


def _latest_at(times: np.ndarray, t_ns: int) -> int:
    return int(np.searchsorted(times, t_ns, side="right")) - 1


def test_a_moving_obstacles_safe_ring_is_where_the_obstacle_is_then(s2_fuzzynav):
    """The ring was one circle moved by a transform, and was drawn where the obstacle
    ended: now, at any time, the ring the viewer shows (the latest row at or before
    it) is a circle of the radius plus the safe distance about the obstacle then."""
    _, result, rec, _ = s2_fuzzynav
    log = result.log
    moving = [c for c in range(len(log.obstacle_ids)) if np.ptp(log.obstacle_xy[:, c, 0]) > 0]
    assert moving
    for col in moving:
        oid = log.obstacle_ids[col]
        times, rings = rec.rows(f"/world/obstacles/{oid}/safe_ring", "LineStrips2D:strips")
        assert len(times) > len(log) // 2  # a row wherever it moved
        ring_m = log.obstacle_radii_m[col] + SAFE_DISTANCE_M
        for k in np.linspace(0, len(log) - 1, 25).astype(int):
            j = _latest_at(times, nanos(log.time_s[k]))
            [strip] = rings[j]
            points = np.asarray(strip)
            radii = np.hypot(*(points - log.obstacle_xy[k, col]).T)
            assert np.allclose(radii, ring_m, atol=1e-5), (k, log.time_s[k])
        assert not rec.rows(f"/world/obstacles/{oid}/safe_ring", "Transform3D:translation")[1]


def test_closest_approaches_appear_only_from_their_time_on(s2_fuzzynav):
    """The world showed every closest approach from the start of the run: each is now
    logged at its own time (and row), so before it the viewer shows nothing of it."""
    from fuzzynav.app.recordings.events import run_events

    _, result, rec, _ = s2_fuzzynav
    events = [e for e in run_events(result) if e.kind == "closest"]
    assert events
    for e in events:
        for child in ("", "/label"):
            entity = f"/world/events/closest/{e.obstacle}{child}"
            assert entity not in rec.static or "Points2D:positions" not in rec.static[entity]
            times, positions = rec.rows(entity, "Points2D:positions")
            assert list(times) == [nanos(e.time_s)] and len(positions[0]) == 1, entity
    assert not any(
        "Points2D:positions" in rec.static.get(e, {})
        for e in rec.entities
        if e.startswith("/world/events/closest")
    )


def test_the_disturbance_window_is_drawn_on_the_trail(s3_fuzzynav):
    """The trail's segments in the disturbance window are drawn again, in the
    disturbance's colour, under the trail (shown over the whole run as the trail is):
    one segment on each row with a disturbance, none elsewhere."""
    from fuzzynav.app.recordings.scene import TRAIL_DISTURBED_PATH
    from fuzzynav.app.recordings.style import DISTURBANCE, rgba

    _, result, rec, path = s3_fuzzynav
    log = result.log
    times, strips = rec.rows(TRAIL_DISTURBED_PATH, "LineStrips2D:strips")
    assert np.array_equal(times, nanos(log.time_s))
    disturbed = np.abs(log.disturbance) > 0
    assert disturbed.any()
    assert [len(s) for s in strips] == list(disturbed.astype(int))
    window = result.scenario.disturbance
    inside = (log.time_s >= window.start_s) & (log.time_s <= window.stop_s)
    assert not np.any(disturbed & ~inside) and disturbed[inside].mean() > 0.9
    ends = np.array([s[0][1] for s in strips if s])
    assert np.allclose(ends, log.pose[disturbed, :2], atol=1e-5)
    assert rec.static[TRAIL_DISTURBED_PATH]["LineStrips2D:colors"] == [rgba(DISTURBANCE)]
    ranges = _entity_overrides(path, TRAIL_DISTURBED_PATH)
    assert ranges and ranges == _entity_overrides(path, "/world/robot/trail")
    assert ranges[0][0]["range"]["start"] is None  # from the start of the run


def _entity_overrides(path, entity: str) -> list:
    """The time ranges the stored layouts give ``entity`` (any view)."""
    reader = RrdReader(path)
    found = []
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            if f"/overrides{entity}/" in chunk.entity_path:
                batch = chunk.to_record_batch()
                if "VisibleTimeRanges:ranges" in batch.schema.names:
                    found += batch.column("VisibleTimeRanges:ranges").to_pylist()
    return found


# ---------------------------------------------------------------------------------------
# The plots' marks, fuzzynav's internals, the rules, the fuzzy tab


def test_each_kind_of_mark_has_its_own_legend_entry_and_colour(s3_fuzzynav):
    """Every mark was one entity named "events", whose legend swatch took the first
    event's colour (an obstacle's red): each kind of mark is now its own entity, its
    colour and name stored once (a legend entry in that colour), at most four kinds
    (a panel's legend has room for few), its marks' shapes a row each."""
    from fuzzynav.app.recordings.events import run_events
    from fuzzynav.app.recordings.plot_events import mark_kinds
    from fuzzynav.app.recordings.style import rgba

    _, result, rec, _ = s3_fuzzynav
    kinds = mark_kinds(run_events(result), result.log.obstacle_ids)
    assert 3 <= len(kinds) <= 4  # closest approaches, the disturbance, the end (, safety)
    colours = [rgba(k["color"]) for k in kinds]
    assert len(set(colours)) == len(colours)
    for origin in ("/plots/distance", "/plots/angles", "/plots/voltage"):
        names = []
        for kind in kinds:
            entity = f"{origin}/events/{kind['key']}"
            style = rec.static[entity]
            assert style["SeriesPoints:colors"] == [rgba(kind["color"])], entity
            assert all("SeriesPoints:colors" not in columns for _, columns in rec._temporal[entity])
            names += style["SeriesPoints:names"]
            times, _ = rec.scalars(entity)
            assert list(times) == [nanos(m[0]) for m in kind["marks"]], entity
            _, shapes = rec.rows(entity, "SeriesPoints:markers")
            want = [rr.components.MarkerShape.auto(m[3]).value for m in kind["marks"]]
            assert [s[0] for s in shapes] == want, entity
        assert len(set(names)) == len(names) == len(kinds), names


def test_fuzzynavs_flags_have_their_own_view_apart_from_its_weights(s2_fuzzynav):
    """The flags (0/1, yield -1/1) shared an axis with alpha and the planner offset and
    hid one another: the time series hold the two numbers, each flag is a lane of its
    own in a view of its own."""
    from fuzzynav.app.recordings.internals import (
        INTERNAL_FLAGS,
        INTERNAL_FLAGS_PATH,
        INTERNAL_WEIGHTS,
        INTERNALS_PATH,
    )

    sim, result, rec, path = s2_fuzzynav
    assert rec.static[INTERNALS_PATH]["SeriesLines:names"] == list(INTERNAL_WEIGHTS)
    assert rec.scalars(INTERNALS_PATH)[1].shape[1] == 2
    decisions = np.array([d[4:7] for d in sim.controller.decisions])
    for j, (lane, states) in enumerate(INTERNAL_FLAGS.items()):
        times, values = rec.rows(f"{INTERNAL_FLAGS_PATH}/{lane}", "StateChange:state")
        assert len(times) >= 1
        k = np.searchsorted(times, nanos(result.log.time_s[:-1]), side="right") - 1
        shown = [values[i][0] for i in k]
        assert shown == [states[v] for v in decisions[:, j]], lane
    views = {v["ViewBlueprint:space_origin"][0]: v for v in _views(path).values()}
    assert views[INTERNALS_PATH]["ViewBlueprint:class_identifier"] == ["TimeSeries"]
    assert views[INTERNAL_FLAGS_PATH]["ViewBlueprint:class_identifier"] == ["StateTimeline"]


def test_the_rule_heatmap_names_every_row_each_a_label_high(s1_paper):
    """The heatmap named R1, R5, R10... (R9 was read as R10): every row is named now,
    and in its own tab each row is drawn at least a label's height."""
    from fuzzynav.app.recordings.internals import (
        HEATMAP_ROWS_PATH,
        LABEL_HEIGHT_PX,
        heatmap_row_px,
    )

    sim, _, rec, _ = s1_paper
    n_rules = len(sim.controller.fis.rules)
    assert n_rules >= 30
    labels = rec.static[HEATMAP_ROWS_PATH]["Points2D:labels"]
    assert labels == [f"R{k}" for k in range(1, n_rules + 1)]
    assert heatmap_row_px(n_rules) >= LABEL_HEIGHT_PX


def test_the_fuzzy_tabs_names_sit_apart(s1_paper):
    """ "input d_t (m)" was written over the L term's name and phi_t's N, Z and P rows
    0.12 apart sat on one another: no name over the plot now (the view's name says
    the variable, the axis' ends its unit), and two term names are a gap apart in x or
    on rows a label's height apart."""
    from fuzzynav.app.recordings.fuzzy import TERM_NAME_GAP

    sim, _, rec, _ = s1_paper
    fis = sim.controller.fis
    for kind, variables in (("inputs", fis.inputs), ("outputs", fis.outputs)):
        for var in variables:
            base = f"/fuzzy/{kind}/{var.name}"
            axis = rec.static[f"{base}/axis"]
            assert all(y < 0 for _, y in axis["Points2D:positions"]), base
            assert all(label.endswith(var.unit) for label in axis["Points2D:labels"]), base
            names = rec.static[f"{base}/term_names"]["Points2D:positions"]
            for i, (xa, ya) in enumerate(names):
                for xb, yb in names[i + 1 :]:
                    assert abs(xa - xb) >= TERM_NAME_GAP - 1e-6 or abs(ya - yb) >= 0.2, base


# ---------------------------------------------------------------------------------------
# The step timeline and the provenance


def test_every_row_has_its_step_the_trace_csvs_row(s2_fuzzynav, tmp_path, capsys):
    """A second timeline, ``step``, numbers every temporal row by its row of the log,
    the ``--trace`` CSV's row (0 the first after the header): a reviewer jumps to CSV
    row N by setting it to N. Every temporal chunk has it, at the time of that row."""
    import csv

    from fuzzynav.app.cli import main

    _, result, _, path = s2_fuzzynav
    log = result.log
    reader = RrdReader(path)
    seen = 0
    for chunk in reader.stream():
        if chunk.is_static:
            continue
        assert set(chunk.timeline_names) == {"sim_time", "step"}, chunk.entity_path
        batch = chunk.to_record_batch()
        steps = batch.column("step").to_numpy()
        times = batch.column("sim_time").cast(pa.int64()).to_numpy()
        assert np.all((steps >= 0) & (steps < len(log)))
        # (an event between two rows, the disturbance's start, has the row before it)
        assert np.all(nanos(log.time_s[steps]) <= times), chunk.entity_path
        assert np.all(times - nanos(log.time_s[steps]) < nanos(result.control_period_s))
        seen += len(steps)
    assert seen > len(log)
    trace = tmp_path / "trace.csv"
    assert main(["run", "s2", "--controller", "fuzzynav", "--trace", str(trace)]) == 0
    capsys.readouterr()
    rows = list(csv.DictReader(trace.open()))
    assert len(rows) == len(log)
    for n in (0, len(log) // 2, len(log) - 1):
        assert float(rows[n]["time_s"]) == log.time_s[n]


@pytest.mark.parametrize(
    "revision, state",
    [("0123456789ab-dirty", "dirty"), ("0123456789ab", "clean"), (None, "not a git checkout")],
)
def test_the_run_document_says_whether_the_git_tree_was_dirty(revision, state, monkeypatch):
    """/meta/run's versions hold the git revision and, as a row of its own, whether the
    tree had uncommitted changes (a revision alone then does not reproduce the run)."""
    versions = {"python": "3", **({"git": revision} if revision else {})}
    shown = documents.versions_with_tree(versions)
    assert shown["git tree"].startswith(state)
    assert ("does not reproduce" in shown["git tree"]) == (state == "dirty")
    assert {k: v for k, v in shown.items() if k != "git tree"} == versions


def test_the_recording_holds_the_git_tree_state(s1_paper):
    from fuzzynav.app.provenance import package_versions

    text = s1_paper[2].text("/meta/run")
    state = documents.git_tree_state(package_versions().get("git"))
    assert f"| git tree | {state} |" in text


def test_a_time_past_a_minute_is_also_written_as_the_time_axis_writes_it(s1_paper):
    """The plots' axis writes "+1m 40s" past a minute (rerun has no tick format to set,
    docs/recordings.md), the texts wrote seconds only: past a minute they give both."""
    from fuzzynav.app.recordings.style import time_text

    assert time_text(28.52) == "28.52 s"
    assert time_text(100.52) == "100.52 s = +1m 40.52s"
    assert time_text(64.44, 1) == "64.4 s = +1m 4.4s"
    _, result, rec, _ = s1_paper
    end = float(result.log.time_s[-1])
    assert end > 60.0
    _, texts = rec.rows("/events/log", "TextLog:text")
    minutes, seconds = divmod(end, 60.0)
    assert texts[-1][0].lstrip().startswith(f"{end:.2f} s = +{int(minutes)}m {seconds:.2f}s")


def test_fuzzynavs_flag_lanes_have_their_own_colours(s2_fuzzynav):
    """rerun colours a lane's states by their text unless told: the flags' lanes store
    theirs, "-" (the flag down) grey in every lane."""
    from fuzzynav.app.recordings.internals import FLAG_COLORS, INTERNAL_FLAGS, INTERNAL_FLAGS_PATH
    from fuzzynav.app.recordings.style import rgba

    rec = s2_fuzzynav[2]
    for lane, states in INTERNAL_FLAGS.items():
        style = rec.static[f"{INTERNAL_FLAGS_PATH}/{lane}"]
        [values] = [v for k, v in style.items() if k.endswith(":values")]
        [colours] = [v for k, v in style.items() if k.endswith(":colors")]
        assert values == list(states.values())
        assert colours == [rgba(FLAG_COLORS[s]) for s in values]
        assert colours[values.index("-")] == rgba(FLAG_COLORS["-"])
