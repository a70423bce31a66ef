"""A new time series is one entry of the recordings' table of plots (issue 36, item d).

A toy series, the robot's speed computed from the logged pose, is added at run time to
``app.recordings.series.PLOTS`` alone; it is then in a recording (its entity, names,
colours and values), in the recording's layout (a panel of its tab, titled as the entry
says) and, with a ``live`` part, in the viewer's Signals tab. A live value the viewer
does not gather yet is one more place, ``app.viewer.driver``'s signal row."""

from __future__ import annotations

import time
from collections import defaultdict

import numpy as np
import pytest

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402

from fuzzynav.app.recordings import series  # noqa: E402
from fuzzynav.app.recordings.columns import plot_layout  # noqa: E402
from fuzzynav.app.recordings.record import record_simulation  # noqa: E402
from fuzzynav.app.runs import build_simulation  # noqa: E402
from fuzzynav.world.scenario import load_scenario  # noqa: E402

TOY = "/plots/toy_speed"
TOY_TITLE = "toy: the robot's speed from its pose, m/s"
TOY_COLOR = (14, 165, 233)


def speed_from_pose(rows: series.Rows) -> np.ndarray:
    """(n, 1): the distance from the previous row's position over the time between
    them (0 at the first row)."""
    first = max(rows.start - 1, 0)
    xy = rows.log.pose[first : rows.end, :2]
    t = rows.log.time_s[first : rows.end]
    speed = np.hypot(*np.diff(xy, axis=0).T) / np.diff(t)
    if rows.start == 0:
        speed = np.concatenate([[0.0], speed])
    return speed[:, None]


def toy_plot(live=None) -> series.Plot:
    return series.Plot(
        TOY,
        TOY_TITLE,
        series.PLANT,
        ["speed (m/s)"],
        [TOY_COLOR],
        [1.5],
        speed_from_pose,
        legend=False,
        live=live,
    )


def expected_speed(log) -> np.ndarray:
    xy, t = np.asarray(log.pose)[:, :2], np.asarray(log.time_s)
    return np.concatenate([[0.0], np.hypot(*np.diff(xy, axis=0).T) / np.diff(t)])


def read(path):
    """(static components by entity, scalars (times, rows) by entity, blueprint
    components by entity) of an .rrd file."""
    reader = RrdReader(str(path))
    static: dict[str, dict] = defaultdict(dict)
    scalars: dict[str, list] = defaultdict(list)
    for chunk in reader.stream():
        batch = chunk.to_record_batch()
        if chunk.is_static:
            for name in batch.schema.names:
                static[chunk.entity_path][name] = batch.column(name).to_pylist()[-1]
        elif "Scalars:scalars" in batch.schema.names:
            times = batch.column("sim_time").cast("int64").to_numpy()
            values = batch.column("Scalars:scalars").to_pylist()
            scalars[chunk.entity_path] += list(zip(times, values))
    layout: dict[str, dict] = defaultdict(dict)
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            batch = chunk.to_record_batch()
            for name in batch.schema.names:
                if ":" in name and not name.startswith("rerun."):
                    layout[chunk.entity_path][name] = batch.column(name).to_pylist()[-1]
    return static, scalars, layout


@pytest.fixture
def with_toy(monkeypatch):
    """The table with the toy appended (the test's only change to the code)."""
    monkeypatch.setattr(series, "PLOTS", [*series.PLOTS, toy_plot()])


def test_a_toy_series_added_to_the_table_is_recorded_and_laid_out(with_toy, tmp_path):
    assert TOY in plot_layout((0,), ("left",))
    sim = build_simulation(load_scenario("s1").replace(duration_s=6.0), "p")
    result = sim.run()
    path = record_simulation(sim, result, tmp_path / "toy.rrd")
    static, scalars, layout = read(path)

    # the recording: the entity, its legend's name and colour, a value at every row
    assert static[TOY]["SeriesLines:names"] == ["speed (m/s)"]
    [color] = static[TOY]["SeriesLines:colors"]
    assert color == int.from_bytes(bytes([*TOY_COLOR, 255]), "big")
    rows = sorted(scalars[TOY], key=lambda row: row[0])
    log = result.log
    assert [t for t, _ in rows] == list(np.round(np.asarray(log.time_s) * 1e9).astype(np.int64))
    values = np.array([v for _, [v] in rows])
    assert np.allclose(values, expected_speed(log), atol=1e-9)
    assert 0.1 < values.max() < 2.0  # a speed a Husky drives at, in m/s
    # the events' marks reach it too, as every plot's
    assert any(entity.startswith(f"{TOY}/events/") for entity in static)
    # the other plots are as before
    assert static["/plots/velocity"]["SeriesLines:names"] == ["v_MH (m/s)", "w_JH (rad/s)"]

    # the layout: a panel on the toy, with the entry's title, in the entry's tab, no legend
    [view] = [
        entity
        for entity, parts in layout.items()
        if parts.get("ViewBlueprint:space_origin") == [TOY]
    ]
    assert layout[view]["ViewBlueprint:display_name"] == [TOY_TITLE]
    assert layout[f"{view}/PlotLegend"]["PlotLegend:visible"] == [False]
    [tab] = [
        parts
        for parts in layout.values()
        if parts.get("ContainerBlueprint:display_name") == [series.PLANT]
    ]
    assert view.lstrip("/") in tab["ContainerBlueprint:contents"]


def test_the_blueprint_places_the_toy_where_its_entry_says(monkeypatch):
    """``place`` orders a tab's panels; a new tab comes after the others."""
    first = toy_plot()
    import dataclasses

    elsewhere = dataclasses.replace(first, path="/plots/toy_elsewhere", tab="toys", place=-1)
    monkeypatch.setattr(
        series, "PLOTS", [*series.PLOTS, dataclasses.replace(first, place=-1), elsewhere]
    )
    tabs = series.tab_panels()
    assert list(tabs)[-1] == "toys" and list(tabs)[: len(series.TABS)] == list(series.TABS)
    assert tabs[series.PLANT][0].path == TOY
    assert [p.path for p in tabs["toys"]] == ["/plots/toy_elsewhere"]


def _wait(predicate, timeout=10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return False


def test_a_toy_with_a_live_part_is_plotted_in_the_signals_tab(monkeypatch):
    """A live plot of columns the viewer gathers already: the table alone."""
    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.server import ViewerServer

    live = series.Live(
        "Toy: target distance and bearing",
        (
            series.LiveLine("d_t", "#0ea5e9", column="d_t"),
            series.LiveLine("phi_t", "#a855f7", column="phi_t"),
            series.LiveLine("zero", "#999999", value=0.0, width=1, dash=(2, 2)),
        ),
        (-4.0, 20.0),
        order=5.0,
    )
    monkeypatch.setattr(series, "PLOTS", [*series.PLOTS, toy_plot(live)])
    server = ViewerServer(ViewerApp("s1", "p"), port=0)
    try:
        plots = server.plots.plots
        assert list(plots) == [
            "/plots/inputs/distances",
            "/plots/inputs/angles",
            "/plots/voltage",
            TOY,
        ]
        toy = plots[TOY]
        assert toy.title == "Toy: target distance and bearing"
        assert [s["label"] for s in toy.series] == ["t (s)", "d_t", "phi_t", "zero"]
        assert toy.scales["y"]["range"] == [-4.0, 20.0]
        for _ in range(12):
            server.app.step_once()
        assert _wait(lambda: np.isfinite(np.asarray(plots[TOY].data[1])).sum() >= 10)
        t, d_t, phi_t, zero = (np.asarray(a) for a in plots[TOY].data)
        rows = server.app.signals()
        assert np.allclose(d_t[-1], rows[-1, 1]) and np.allclose(phi_t[-1], rows[-1, 3])
        assert np.all(zero == 0.0) and t[-1] == pytest.approx(rows[-1, 0])
    finally:
        server.stop()


def test_a_new_live_value_is_the_table_and_the_signal_row(monkeypatch):
    """A live value the viewer does not gather yet (the speed): the table's entry and
    ``app.viewer.driver``'s signal row, nothing else."""
    from fuzzynav.app.viewer import driver
    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.server import ViewerServer

    base = driver.signal_row

    def with_speed(sim, controller):
        # from where the step began (the log's last row) to where it ended
        x0, y0, _ = sim.log_view().pose[-1]
        x1, y1, _ = sim.arena.pose
        speed = np.hypot(x1 - x0, y1 - y0) / sim.control_period_s
        return (*base(sim, controller), speed)

    monkeypatch.setattr(driver, "SIGNAL_COLUMNS", (*driver.SIGNAL_COLUMNS, "speed"))
    monkeypatch.setattr(driver, "signal_row", with_speed)
    live = series.Live(
        "Speed (m/s)", (series.LiveLine("speed", "#0ea5e9", column="speed"),), (0, 2)
    )
    monkeypatch.setattr(series, "PLOTS", [*series.PLOTS, toy_plot(live)])
    server = ViewerServer(ViewerApp("s1", "p"), port=0)
    try:
        for _ in range(30):
            server.app.step_once()
        plots = server.plots.plots
        assert _wait(lambda: np.isfinite(np.asarray(plots[TOY].data[1])).sum() >= 25)
        speed = np.asarray(plots[TOY].data[1])
        assert np.allclose(speed, server.app.signals()[:, -1][: len(speed)], equal_nan=True)
        assert 0.0 < speed[-1] < 2.0
    finally:
        server.stop()
