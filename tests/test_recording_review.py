"""Issue 39: recordings a reviewer reads without squinting. Each defect's test reads the
recording back (rerun's SDK) and fails on the recordings made before its fix.

No number a run of the paper controller produces is written here (its rule base may be
refitted): every expectation is computed from the run itself."""

from __future__ import annotations

import json
import re
import shlex

import numpy as np
import pytest

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402
from test_recording import Recording, _views, nanos, title_of  # noqa: E402

from fuzzynav.app import palette  # noqa: E402
from fuzzynav.app.cli import main  # noqa: E402
from fuzzynav.app.figures.style import obstacle_label  # noqa: E402
from fuzzynav.app.recordings.blueprint import CLEARANCE_SHOWN_M  # noqa: E402
from fuzzynav.app.recordings.record import record_simulation  # noqa: E402
from fuzzynav.app.recordings.style import SAFE_DISTANCE_M, rgba  # noqa: E402
from fuzzynav.app.runs import build_simulation  # noqa: E402

# ---------------------------------------------------------------------------------------
# Fixtures: s1 with the paper controller (inside the safe distance for a while), s2
# with the p controller (collides), both recorded once for the module.


def _record(tmp_path_factory, scenario, controller, **kw):
    sim = build_simulation(scenario, controller, **kw)
    result = sim.run()
    path = tmp_path_factory.mktemp("rrd") / f"{scenario}_{controller}.rrd"
    record_simulation(sim, result, path)
    return sim, result, Recording(path), path


@pytest.fixture(scope="module")
def s1_paper(tmp_path_factory):
    return _record(tmp_path_factory, "s1", "paper")


@pytest.fixture(scope="module")
def s2_collided(tmp_path_factory):
    return _record(tmp_path_factory, "s2", "p")


def _view_classes(path) -> dict:
    """{view name: its class (TimeSeries, StateTimeline...)} of the final layout."""
    return {n: v["ViewBlueprint:class_identifier"][0] for n, v in _views(path).items()}


# ---------------------------------------------------------------------------------------
# Defect 1: the lanes show the whole run


def test_the_lanes_show_the_whole_run_as_the_plots_beside_them(s1_paper):
    """Every state-timeline view (the events' lanes, the strongest rule) stores a time
    range, the same as the plots of its tab: the whole run, unbounded both ways
    (without one rerun shows a window around the cursor: the last ~27 s at opening)."""
    path = s1_paper[3]
    views = _views(path)
    classes = _view_classes(path)
    lanes = [n for n, c in classes.items() if c == "StateTimeline"]
    assert len(lanes) >= 2, classes  # the events, the strongest rule
    plots = [n for n, c in classes.items() if c == "TimeSeries"]
    plot_range = views[plots[0]]["TimeAxis/TimeAxis:view_range"]
    for name in lanes:
        stored = views[name].get("TimeAxis/TimeAxis:view_range")
        assert stored is not None, name
        assert stored == plot_range, name
    # (an infinite boundary is the union's null variant: None both ways)
    assert plot_range == [{"start": None, "end": None}]


# ---------------------------------------------------------------------------------------
# Defect 2: a layout per run; every plot's range holds its own data


@pytest.fixture(scope="module")
def s2_two_perceptions(tmp_path_factory):
    return [
        _record(tmp_path_factory, "s2", "paper", perception=mode)
        for mode in ("ideal", "ultrasonic")
    ]


def _series_of_view(rec, origin: str) -> np.ndarray:
    entities = [e for e in rec.entities if e == origin or e.startswith(origin + "/")]
    values = [rec.scalars(e)[1].reshape(-1) for e in entities if e in rec._temporal]
    values = np.concatenate(values) if values else np.zeros(0)
    return values[np.isfinite(values)]


def test_two_perceptions_of_one_scenario_keep_their_own_layouts_and_ranges(s2_two_perceptions):
    """s2 with ideal and with ultrasonic perception, opened in one viewer: each has its
    own application id (the key of its layout), its blueprint stored under it, its own
    name in the viewer's list, and every plot's stored value range holds every finite
    value that plot shows in *that* recording (no series clipped)."""
    ids, names = set(), set()
    for _sim, _result, rec, path in s2_two_perceptions:
        reader = RrdReader(path)
        [app_id] = {r.application_id for r in reader.recordings()}
        assert {b.application_id for b in reader.blueprints()} == {app_id}
        ids.add(app_id)
        [name] = {
            v[0]
            for v in (
                rec.static.get("/__properties", {}).get("RecordingInfo:name"),
                rec.static.get("/__properties/recording", {}).get("RecordingProperties:name"),
            )
            if v
        } or {None}
        names.add(name)
        views = _views(path)
        for view_name, view in views.items():
            if "ScalarAxis/ScalarAxis:range" not in view:
                continue
            origin = view.get("ViewBlueprint:space_origin", [None])[0]
            values = _series_of_view(rec, origin) if origin else np.zeros(0)
            if not values.size:
                continue
            lo, hi = view["ScalarAxis/ScalarAxis:range"][0]
            if title_of(view_name).startswith("footprint clearance"):  # (shown up to 2 m: its name)
                assert f"up to {CLEARANCE_SHOWN_M:g} m shown" in view_name
                values = values[values <= CLEARANCE_SHOWN_M]
            assert lo <= values.min() and values.max() <= hi, (view_name, lo, hi)
    assert len(ids) == 2
    assert len(names) == 2 and None not in names, names


def test_the_layout_key_holds_every_run_option():
    from fuzzynav.app.recordings.blueprint import application_id
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.scenario import load_scenario

    s2 = load_scenario("s2")
    c = make_controller("paper")
    base = dict(perception="ideal", seed=0, noise_std_m=0.0, control_period_s=0.02)
    ids = {application_id(s2, c, "husky", **base)}
    for key, value in (
        ("perception", "ultrasonic"),
        ("seed", 1),
        ("noise_std_m", 0.05),
        ("control_period_s", 0.05),
        ("voltage_limit_v", 10.0),
    ):
        ids.add(application_id(s2, c, "husky", **{**base, key: value}))
    assert len(ids) == 6


# ---------------------------------------------------------------------------------------
# Defect 3: one palette


def _lane_colours(rec, lane: str) -> dict:
    """{state: packed colour} of a lane's StateConfiguration."""
    config = rec.static.get(f"/events/lanes/{lane}", {})
    values = config.get("StateConfiguration:values") or []
    colours = config.get("StateConfiguration:colors") or []
    return dict(zip(values, colours))


@pytest.mark.parametrize("which", ["s1_paper", "s2_collided"])
def test_an_obstacle_has_one_colour_in_lanes_plots_and_world(which, request):
    """The closest-approach lane colours each obstacle's state with the obstacle's colour
    (rerun chose a colour by the state's text: obstacle 1 purple in s1, green in s3, red
    in s2), the same as its distance series and its body in the world; a moving
    obstacle's path is its own colour (it was purple over an orange obstacle)."""
    sim, result, rec, path = request.getfixturevalue(which)
    log = result.log
    plot = rec.static["/plots/distance"]["SeriesLines:colors"]
    lane = _lane_colours(rec, "closest_approach")
    _, states = rec.rows("/events/lanes/closest_approach", "StateChange:state")
    shown = {s[0] for s in states} - {"-"}
    assert shown, "no closest approach in the lane"
    for col, oid in enumerate(log.obstacle_ids):
        want = rgba(palette.rgb(palette.obstacle(col)))
        assert plot[col + 1] == want
        assert rec.static[f"/world/obstacles/{oid}/body"]["Points2D:colors"][0] == want
        for state in shown:
            if state.startswith(f"{obstacle_label(oid)}:"):
                assert lane[state] == want, state
        path_style = rec.static.get(f"/world/obstacles/{oid}/path", {})
        if "LineStrips2D:colors" in path_style:  # a moving obstacle
            assert path_style["LineStrips2D:colors"][0] >> 8 == want >> 8  # (paler: alpha)


def test_the_inputs_have_one_colour_in_every_panel_and_figure(s1_paper):
    """d_t is the target's green and phi_t blue in "paper figures", in "plant and
    inputs" and in the PNG figures (they were swapped between them)."""
    from matplotlib.colors import to_hex

    from fuzzynav.app.figures.run_figures import run_figure

    _, result, rec, _ = s1_paper
    d_t = rec.static["/plots/distance"]["SeriesLines:colors"][0]
    phi_t = rec.static["/plots/angles/phi_t"]["SeriesLines:colors"][0]
    inputs_d = rec.static["/plots/inputs/distances"]["SeriesLines:colors"]
    inputs_phi = rec.static["/plots/inputs/angles"]["SeriesLines:colors"]
    assert inputs_d[0] == d_t == rgba(palette.rgb(palette.D_T))
    assert inputs_phi[0] == phi_t == rgba(palette.rgb(palette.PHI_T))
    obstacles = {rgba(palette.rgb(c)) for c in palette.OBSTACLES}
    assert inputs_d[1] not in obstacles and inputs_phi[1] not in obstacles  # d_o, phi_o
    fig = run_figure("distances", result)
    [target] = [ln for ln in fig.axes[0].lines if ln.get_label() == "to the target"]
    assert to_hex(target.get_color()) == palette.D_T
    fig = run_figure("angles", result)
    [line] = [ln for ln in fig.axes[0].lines if ln.get_label() == "phi_t"]
    assert to_hex(line.get_color()) == palette.PHI_T


def test_the_terms_have_the_same_colours_in_the_fuzzy_tab_and_the_figures(
    s1_paper, tmp_path, monkeypatch
):
    """S, M, L... of every variable: the fuzzy-logic tab's colours are the membership
    figures' (Figs. 6-11; S and L were swapped), and the aggregated output has a
    colour no term has (it shared L's orange)."""
    from matplotlib.colors import to_hex

    from fuzzynav.app.figures import membership

    sim, _, rec, _ = s1_paper
    fis = sim.controller.fis
    figures = {}

    def keep(fig, out_dir, name, formats=()):
        figures[name] = fig
        return []

    monkeypatch.setattr(membership, "_save", keep)
    membership.write_membership_figures(fis, tmp_path)
    for kind, variables in (("inputs", fis.inputs), ("outputs", fis.outputs)):
        for var in variables:
            tab = rec.static[f"/fuzzy/{kind}/{var.name}/terms"]["LineStrips2D:colors"]
            fig = figures[f"membership_{var.name}"]
            lines = [ln for ln in fig.axes[0].lines if not ln.get_label().startswith("_")]
            assert len(lines) == len(var.terms) == len(tab)
            for packed, line in zip(tab, lines):
                assert f"#{packed >> 8:06x}" == to_hex(line.get_color()), var.name
            if kind == "outputs":
                aggregated = rec.static[f"/fuzzy/outputs/{var.name}/aggregated"]
                assert aggregated["LineStrips2D:colors"][0] not in tab


def test_the_viewer_draws_from_the_same_palette():
    from fuzzynav.app.viewer import drawing, scene

    assert drawing.TARGET_INPUT == palette.TARGET_INPUT
    assert drawing.OBSTACLE_INPUT == palette.OBSTACLE_INPUT
    assert tuple(drawing.PALETTE) == palette.VIEWER_SERIES
    assert scene.TARGET_INPUT == palette.rgb(palette.TARGET_INPUT)
    assert scene.OBSTACLE_INPUT == palette.rgb(palette.OBSTACLE_INPUT)


# ---------------------------------------------------------------------------------------
# Defect 7: the safe distance, seen and said


def _breaches(log):
    """(obstacle column, first row, last row) of every stretch below the safe distance,
    from the log itself."""
    out = []
    for col in range(len(log.obstacle_ids)):
        c = log.clearance_m[:, col]
        inside = np.isfinite(c) & (c < SAFE_DISTANCE_M)
        k = 0
        while k < len(inside):
            if inside[k]:
                j = k
                while j + 1 < len(inside) and inside[j + 1]:
                    j += 1
                out.append((col, k, j))
                k = j + 1
            else:
                k += 1
    return out


@pytest.mark.parametrize("which", ["s1_paper", "s2_collided"])
def test_the_safe_distance_is_an_event_a_lane_and_a_summary_line(which, request):
    """Every stretch inside the 0.25 m safe distance is an event ("inside the 0.25 m
    safe distance of obstacle k from t1 to t2, closest X m"), a state in the "safe
    distance" lane from t1 on, and a line of the summary; a run never inside says so."""
    _, result, rec, _ = request.getfixturevalue(which)
    log = result.log
    times, texts = rec.rows("/events/log", "TextLog:text")
    texts = [x[0] for x in texts]
    summary = rec.text("/meta/summary")
    lane_t, lane = rec.rows("/events/lanes/safe_distance", "StateChange:state")
    lane = [x[0] for x in lane]
    breaches = _breaches(log)
    for col, a, b in breaches:
        oid = log.obstacle_ids[col]
        closest = float(np.min(log.clearance_m[a : b + 1, col]))
        want = (
            f"inside the {SAFE_DISTANCE_M:g} m safe distance of {obstacle_label(oid)} from "
            f"{log.time_s[a]:.2f} s to {log.time_s[b]:.2f} s, closest {closest:.2f} m"
        )
        [hit] = [j for j, x in enumerate(texts) if want in x]
        assert times[hit] == nanos(log.time_s[a])
        assert want in summary
        [k] = [j for j, t in enumerate(lane_t) if t == nanos(log.time_s[a])]
        assert lane[k] == f"inside: {obstacle_label(oid)}, closest {closest:.2f} m"
        assert _lane_colours(rec, "safe_distance")[lane[k]] == rgba(palette.rgb(palette.BREACH))
    if not breaches:
        assert f"never inside the {SAFE_DISTANCE_M:g} m safe distance" in summary
    assert lane[0] == "clear" or lane_t[0] == nanos(log.time_s[0])


def test_the_safe_distance_line_can_be_seen_on_the_clearance_panel(s1_paper):
    """The clearance panel's value range leaves the 0.25 m line clear of zero: at least
    a tenth of the panel's height above its bottom and below its top (it spanned ~22 m
    for the legend's room, the line sat on zero), and it holds the closest approach."""
    _, result, rec, path = s1_paper
    [view] = [v for n, v in _views(path).items() if title_of(n).startswith("footprint clearance")]
    lo, hi = view["ScalarAxis/ScalarAxis:range"][0]
    assert (SAFE_DISTANCE_M - lo) / (hi - lo) >= 0.1
    assert (hi - SAFE_DISTANCE_M) / (hi - lo) >= 0.1
    assert lo <= float(np.nanmin(result.log.clearance_m))
    assert hi - lo <= 3.0  # m: a breach of a tenth of a metre is visible


# ---------------------------------------------------------------------------------------
# Defect 9: the reproduce command pinned


def test_the_reproduce_command_is_pinned_and_refuses_what_changed(tmp_path, capsys, monkeypatch):
    """A shipped scenario's reproduce command carries the scenario's digest, the
    controller's rules' digest and fuzzynav's version; it repeats the run; and it
    refuses to run when the scenario, the rule base or the version changed (each
    tampered with in turn)."""
    from fuzzynav.app import provenance, runs

    rrd = tmp_path / "a.rrd"
    argv = ["run", "s1", "--controller", "p", "--json", "--rrd", str(rrd)]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    text = Recording(rrd).text("/meta/run")
    command = shlex.split(re.search(r"\| reproduce \| `([^`]*)` \|", text).group(1))
    for option in ("--scenario-sha256", "--rules-sha256", "--fuzzynav-version"):
        assert option in command, option
    assert command[command.index("--fuzzynav-version") + 1] == provenance.fuzzynav_version()
    assert main([*command[1:], "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    first.pop("wall_time_s", None), again.pop("wall_time_s", None)
    assert again == first

    def refused(option):
        assert main([*command[1:], "--json"]) == 2
        err = capsys.readouterr().err
        assert option in err, err

    with monkeypatch.context() as m:  # s1.toml changed since
        load = runs.load_scenario
        m.setattr(runs, "load_scenario", lambda *a, **k: load(*a, **k).replace(duration_s=7.0))
        refused("--scenario-sha256")
    with monkeypatch.context() as m:  # the controller's parameters changed since
        make = runs.make_controller

        def changed(*a, **k):
            controller = make(*a, **k)
            controller.gain = getattr(controller, "gain", 1.0) * 1.5 + 0.1
            return controller

        m.setattr(runs, "make_controller", changed)
        refused("--rules-sha256")
    with monkeypatch.context() as m:  # another fuzzynav
        m.setattr(provenance, "fuzzynav_version", lambda: "0.0.0+other")
        refused("--fuzzynav-version")


def test_a_paper_rule_base_that_changed_is_refused(tmp_path, capsys, monkeypatch):
    """The paper controller's rule base changed since the recording (one rule's weight):
    its reproduce command refuses to run."""
    from fuzzynav.app import runs
    from fuzzynav.world.scenario import load_scenario

    scenario = tmp_path / "short.toml"
    scenario.write_text(load_scenario("s1").replace(duration_s=1.0).to_toml(), encoding="utf-8")
    rrd = tmp_path / "a.rrd"
    assert main(["run", str(scenario), "--controller", "paper", "--rrd", str(rrd)]) == 0
    capsys.readouterr()
    text = Recording(rrd).text("/meta/run")
    command = shlex.split(re.search(r"\| reproduce \| `([^`]*)` \|", text).group(1))
    make = runs.make_controller

    def refitted(*a, **k):
        controller = make(*a, **k)
        rules = list(controller.fis.rules)
        rules[0] = rules[0].__class__(rules[0].antecedent, rules[0].consequent, 0.5)
        controller.fis = controller.fis.with_rules(rules)
        return controller

    monkeypatch.setattr(runs, "make_controller", refitted)
    assert main([*command[1:]]) == 2
    assert "--rules-sha256" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------
# Defect 4: the world view


def _closest_marks(rec, obstacle_ids, component: str, child: str = "") -> list:
    """(time, value) of each obstacle's closest-approach mark in the world, if any."""
    out = []
    for oid in obstacle_ids:
        t, values = rec.rows(f"/world/events/closest/{oid}{child}", component)
        out += list(zip(t, values))
    return out


def test_a_collided_run_marks_its_collision_not_a_stack_of_closest_approaches(s2_collided):
    """In a collided run an obstacle the robot was still approaching at the end has no
    "closest approach" (it was "closest to obstacle 1" at the last step), the collision
    has its own marker, and no two closest-approach markers share a place."""
    _, result, rec, _ = s2_collided
    log = result.log
    assert result.outcome == "collided"
    last = len(log) - 1
    times, texts = rec.rows("/events/log", "TextLog:text")
    texts = [x[0] for x in texts]
    at_end = [x for t, x in zip(times, texts) if t == nanos(log.time_s[last])]
    clear = np.where(np.isfinite(log.clearance_m[last]), log.clearance_m[last], np.inf)
    hit = log.obstacle_ids[int(np.argmin(clear))]
    for col, oid in enumerate(log.obstacle_ids):
        d = log.center_distance_m[:, col]
        if oid != hit and int(np.nanargmin(d)) == last:
            assert not any(f"closest to {obstacle_label(oid)}:" in x for x in at_end)
            assert any(f"{obstacle_label(oid)}:" in x and "still approaching" in x for x in at_end)
    t, where = rec.rows("/world/events/collision", "Points2D:positions")
    _, labels = rec.rows("/world/events/collision", "Points2D:labels")
    assert list(t) == [nanos(log.time_s[last])]  # from the collision on
    assert np.allclose(where[0], log.pose[last, :2], atol=1e-5)
    assert f"collided with {obstacle_label(hit)}" in labels[0][0]
    marks = np.array(
        [p[0] for _, p in _closest_marks(rec, log.obstacle_ids, "Points2D:positions")]
    ).reshape(-1, 2)
    for k in range(len(marks)):
        assert np.hypot(*(marks[k] - log.pose[last, :2])) > 0.05  # not on the collision
        for j in range(k):
            assert np.hypot(*(marks[k] - marks[j])) > 0.3


def test_closest_approach_labels_stay_off_the_safety_rings(s1_paper):
    """Each closest approach's label sits beyond its obstacle's safe ring (the ring is
    the obstacle's radius plus 0.25 m), not over it; the marker stays where the robot
    was."""
    _, result, rec, _ = s1_paper
    log = result.log
    ids = list(log.obstacle_ids)
    marks = _closest_marks(rec, ids, "Points2D:positions")
    labelled = _closest_marks(rec, ids, "Points2D:positions", "/label")
    texts = _closest_marks(rec, ids, "Points2D:labels", "/label")
    for (_, [xy]), (_, [text]) in zip(labelled, texts):
        t = float(re.search(r"at ([0-9.]+) s", text).group(1))
        k = int(np.argmin(np.abs(log.time_s - t)))
        for col in range(len(ids)):
            centre = log.obstacle_xy[k, col]
            ring = log.obstacle_radii_m[col] + SAFE_DISTANCE_M
            assert np.hypot(*(np.asarray(xy) - centre)) > ring + 0.05, text
    assert not any(_closest_marks(rec, ids, "Points2D:labels"))
    assert len(marks) == len(labelled) == len(texts) > 0


def test_the_start_and_the_scale_can_be_read(s1_paper):
    """The start's label is dark (it was near-white on light grey) and the world view
    reaches far enough below the start for the scale bar's "1 m" label (it was cut)."""
    from fuzzynav.app.recordings.blueprint import SCALE_BELOW_START_M, world_bounds

    _, result, rec, _ = s1_paper
    start = rec.static["/world/start"]["Points2D:colors"]
    for packed in start:
        r, g, b = (packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255
        assert 0.299 * r + 0.587 * g + 0.114 * b < 110
    _, y_range = world_bounds(result.scenario, result.log)
    bar_y = result.scenario.start[1] - 0.75
    assert y_range[0] <= bar_y - 0.45 - 1.0 + 1e-9  # the label's room, then the margin
    assert SCALE_BELOW_START_M >= 1.2


# ---------------------------------------------------------------------------------------
# Defect 9: compare-runs


def test_compare_runs_finds_a_reproduction_the_same_and_another_run_different(tmp_path, capsys):
    """The recording and the recording of its reproduce command: the same run (their
    NaNs, command lines, wall times and recording ids differ or are NaN; ``rerun rrd
    compare`` called them a mismatch). Another seed and noise: said to differ, entity
    by entity, exit 1."""
    a, b, c = (tmp_path / f"{k}.rrd" for k in "abc")
    assert main(["run", "s1", "--controller", "p", "--rrd", str(a)]) == 0
    text = Recording(a).text("/meta/run")
    command = shlex.split(re.search(r"\| reproduce \| `([^`]*)` \|", text).group(1))
    assert main([*command[1:], "--rrd", str(b)]) == 0
    options = ["--perception", "ultrasonic", "--noise", "0.02", "--seed", "3"]
    assert main(["run", "s1", "--controller", "p", *options, "--rrd", str(c)]) == 0
    capsys.readouterr()
    _, voltages = Recording(a).scalars("/plots/voltage")
    assert np.isnan(voltages).any()  # (NaN against NaN below)
    assert main(["compare-runs", str(a), str(b)]) == 0
    assert "the same run" in capsys.readouterr().out
    assert main(["compare-runs", str(a), str(c)]) == 1
    out = capsys.readouterr().out
    assert "/plots/inputs/distances" in out and "difference(s)" in out
    assert main(["compare-runs", str(a), str(tmp_path / "missing.rrd")]) == 2


def test_compare_runs_counts_nan_as_equal_and_names_what_differs():
    import pyarrow as pa

    from fuzzynav.app.recordings.compare import _column_difference

    times = np.arange(3, dtype=np.int64)
    x = pa.array([[1.0, float("nan")], [2.0, 3.0], [float("nan"), 4.0]])
    y = pa.array([[1.0, float("nan")], [2.0, 3.5], [float("nan"), 4.0]])
    assert _column_difference("s", (times, x), (times, x)) is None
    said = _column_difference("s", (times, x), (times, y))
    assert "1 values differ" in said and "0.5" in said
    assert "rows against" in _column_difference("s", (times, x), (times[:2], x[:2]))


# ---------------------------------------------------------------------------------------
# Defect 10: the trace's optional columns


def _csv(path) -> dict:
    import csv

    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}


def test_the_trace_can_hold_obstacle_positions_and_rule_strengths(tmp_path, capsys):
    """``--trace-columns obstacles,rules``: each obstacle's centre at every row (equal to
    the run's log), and each rule's firing strength at the inputs the controller
    received (equal to the rule base's at the trace's own inputs; empty on the last
    row). Without the option the trace keeps its columns."""
    from fuzzynav.app.recordings.trace import TRACE_COLUMNS
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.scenario import load_scenario

    scenario = tmp_path / "short.toml"
    scenario.write_text(load_scenario("s2").replace(duration_s=3.0).to_toml(), encoding="utf-8")
    plain, full = tmp_path / "plain.csv", tmp_path / "full.csv"
    argv = ["run", str(scenario), "--controller", "paper"]
    assert main([*argv, "--trace", str(plain)]) == 0
    assert main([*argv, "--trace", str(full), "--trace-columns", "obstacles,rules"]) == 0
    capsys.readouterr()
    assert plain.read_text().splitlines()[0] == ",".join(TRACE_COLUMNS)
    col = _csv(full)
    sim = build_simulation(str(scenario), "paper")
    log = sim.run().log
    for k, oid in enumerate(log.obstacle_ids):
        assert np.array_equal(col[f"obstacle_{oid}_x_m"], log.obstacle_xy[:, k, 0], equal_nan=True)
        assert np.array_equal(col[f"obstacle_{oid}_y_m"], log.obstacle_xy[:, k, 1], equal_nan=True)
    assert np.ptp(col[f"obstacle_{log.obstacle_ids[-1]}_x_m"]) >= 0  # (s2's moving one)
    fis = make_controller("paper").fis
    names = [f"rule_R{k + 1}_strength" for k in range(len(fis.rules))]
    got = np.column_stack([col[n] for n in names])
    inputs = np.column_stack([col[n] for n in ("d_t_m", "d_o_m", "phi_t_rad", "phi_o_rad")])
    want = np.asarray(fis.firing_strengths(inputs[:-1]), dtype=float)
    assert np.allclose(got[:-1], want, rtol=0, atol=1e-12)
    assert np.isnan(got[-1]).all()
    assert main([*argv, "--trace", str(full), "--trace-columns", "speed"]) == 2


# ---------------------------------------------------------------------------------------
# Defect 5: the rules' numbering said one way


def test_the_rules_page_numbers_the_bars_as_the_chart_does(s1_paper):
    """The bars stand at abscissae 1 to n and the panel says "bar k = rule Rk": the
    rules' page says the same (it said "bar k is rule R(k+1)")."""
    _, _, rec, path = s1_paper
    text = rec.text("/rules/texts")
    assert "R(k+1)" not in text and "R(k + 1)" not in text
    assert "is rule Rk" in text
    abscissa = rec.static["/rules/firing"]["BarChart:abscissa"][0]
    n = len(abscissa["buffer"])
    assert list(abscissa["buffer"]) == list(range(1, n + 1))
    assert any("bar k = rule Rk" in name for name in _views(path))


def test_an_ideal_run_says_its_sensor_ranges_were_not_used(s1_paper, s2_two_perceptions):
    """Ideal perception drives on the true obstacles: its "sensor ranges" panel says the
    readings were not used; an ultrasonic run's does not."""
    ideal = [n for n in _views(s1_paper[3]) if title_of(n).startswith("sensor ranges")]
    assert len(ideal) == 1 and "not used" in ideal[0] and "ideal perception" in ideal[0]
    sonar = s2_two_perceptions[1]
    assert sonar[1].perception == "ultrasonic"
    [name] = [n for n in _views(sonar[3]) if title_of(n).startswith("sensor ranges")]
    assert "not used" not in name


def test_the_summary_holds_max_voltage_against_the_limit_and_the_paper(s1_paper):
    """The summary gives the largest |V| the controller asked for against the limit
    (and, for s3, the paper's claim that its voltages saturate)."""
    _, result, rec, _ = s1_paper
    v = result.log.controller_output_v
    peak = float(np.nanmax(np.abs(v)))
    assert f"max |V| before the limit {peak:.2f} V" in rec.text("/meta/summary")


# ---------------------------------------------------------------------------------------
# Defect 6: the fuzzy-logic tab's labels: not cut at the view's edge, not crossed by the
# line they name, the term names apart


def test_the_fuzzy_tabs_labels_are_not_clipped_crossed_or_merged(s1_paper):
    """The value's text sat on its line ("right = 0.69 V (centroid)" cut to "ight = ..."
    at the view's right edge, the line through it); phi_t's N, Z and P sat 0.09 apart
    and read "NZP"."""
    from fuzzynav.app.recordings.fuzzy import FUZZY_W, TERM_NAME_GAP

    sim, result, rec, path = s1_paper
    fis = sim.controller.fis
    bounds = [
        v["VisualBounds2D/VisualBounds2D:range"][0]
        for n, v in _views(path).items()
        if n.endswith("at the cursor")
    ]
    assert bounds
    decided = int(np.all(np.isfinite(result.log.controller_output_v), axis=1).sum())
    for kind, variables in (("inputs", fis.inputs), ("outputs", fis.outputs)):
        for var in variables:
            base = f"/fuzzy/{kind}/{var.name}"
            # the line carries no text: nothing to cross
            assert not rec.rows(f"{base}/value", "LineStrips2D:labels")[0].size, base
            _, labels = rec.rows(f"{base}/value_label", "Points2D:labels")
            assert len(labels) == decided and any(labels), base
            # written at a fixed place, the middle of the axis: half the view each side
            [(x, y)] = rec.static[f"{base}/value_label"]["Points2D:positions"]
            assert x == pytest.approx(0.5 * FUZZY_W) and y < 0.0
            for box in bounds:  # inside the view (y flipped: up), as far from either edge
                lo, hi = box["x_range"]
                assert x - lo == pytest.approx(hi - x)
                assert -box["y_range"][1] < y < -box["y_range"][0]
            # the term names at least TERM_NAME_GAP apart unless on different rows
            names = rec.static[f"{base}/term_names"]["Points2D:positions"]
            for i, (xa, ya) in enumerate(names):
                for xb, yb in names[i + 1 :]:
                    assert abs(xa - xb) >= TERM_NAME_GAP - 1e-6 or ya != yb, (base, names)
                assert 0.0 <= xa <= FUZZY_W
    # phi_t's N, Z, P: each pair apart, whatever the rows
    [phi_t] = [v for v in fis.inputs if v.name == "phi_t"]
    names = rec.static["/fuzzy/inputs/phi_t/term_names"]["Points2D:positions"]
    xs = sorted(x for x, _ in names)
    assert min(np.diff(xs)) >= TERM_NAME_GAP - 1e-6, (phi_t.term_names, names)


# ---------------------------------------------------------------------------------------
# Defect 7, the rest: the distance panel is as tall as its data, not its legend


def test_the_distance_panel_spans_its_data_not_a_legend(s1_paper):
    """The distance panel stretched its axis to about twice the data's span to give its
    legend room (rerun draws the legend over the plot): to about 22 m in s1. It now has
    no legend, its name says which colour is which, and its range is its data's with
    rerun's 5 % margin."""
    _, result, rec, path = s1_paper
    [(name, view)] = [
        (n, v) for n, v in _views(path).items() if title_of(n).startswith("distance to")
    ]
    lo, hi = view["ScalarAxis/ScalarAxis:range"][0]
    values = _series_of_view(rec, "/plots/distance")
    span = values.max() - values.min()
    assert lo <= values.min() and values.max() <= hi
    assert hi - lo <= 1.15 * span, (name, lo, hi, values.min(), values.max())
    assert view.get("PlotLegend/PlotLegend:visible") == [False], name
    for oid in result.log.obstacle_ids:
        assert f"{obstacle_label(oid)} (" in name, name
    assert "target (green)" in name
