"""Issue 37 items 4 and 5: what one tab can make the viewer's server keep is bounded and
counted in one budget per server (`app/viewer/budget.py`): uploads under way, uploaded
scenarios kept, obstacles added, the run's history; and ``serve --rrd``'s recordings a
minute and bytes a session. The model and the message guards are driven directly, as
the server's websocket would. Each test failed on the code before."""

from __future__ import annotations

import asyncio
import gc
import random
import tracemalloc

import pytest

from fuzzynav.app.viewer import budget as budgets
from fuzzynav.app.viewer import compat_viser
from fuzzynav.app.viewer.model import ViewerApp, ViewerError
from fuzzynav.world.scenario import ObstacleSpec, load_scenario

pytest.importorskip("viser")
FileTransferStartUpload = compat_viser.message_class("FileTransferStartUpload")
FileTransferPart = compat_viser.message_class("FileTransferPart")


def _moving(n: int, duration_s: float = 3600.0):
    """s1 with ``n`` moving obstacles far from the robot, the target 7 km away."""
    rng = random.Random(1)
    obstacles = tuple(
        ObstacleSpec(
            (rng.uniform(-300, 300), rng.uniform(30, 300)),
            0.3,
            (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5)),
        )
        for _ in range(n)
    )
    return load_scenario("s1").replace(
        obstacles=obstacles, duration_s=duration_s, target=(7000.0, 0.0)
    )


# -- the run's history ----------------------------------------------------------------


def test_the_history_stays_within_its_budget_and_spans_the_run(monkeypatch):
    """The history kept a dict of every obstacle per control step: about 1 MB a
    simulated second with 110 obstacles (3.6 GB for a legal hour, per classroom tab).
    Now it is thinned within HISTORY_BYTES, and its charge is what it holds."""
    limit = 1024**2
    monkeypatch.setattr(budgets, "HISTORY_BYTES", limit)
    app = ViewerApp(_moving(110), "p")
    from fuzzynav.app.viewer.history import StepHistory

    app._history = StepHistory(app.account, limit=limit)
    with app.lock:
        app.driver._step_locked()  # (the log's first block, the arena's caches)
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        with app.lock:
            for _ in range(3000):
                app.driver._step_locked()
        gc.collect()
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    history = app._history
    assert history.bytes <= limit
    assert app.account.held("history") == history.bytes
    assert history.stride > 1  # thinned ...
    times = [h.time_s for h in history]
    assert times[0] == pytest.approx(0.02) and times[-1] == pytest.approx(app.sim.time_s)
    assert max(b - a for a, b in zip(times, times[1:])) <= 0.02 * history.stride + 1e-9
    # ... and what it is charged is no less than what it holds (the simulation's own
    # growth over 3,000 steps, its log block and trail, is in `grown` too)
    assert grown < 2 * limit + 4 * 1024**2, grown
    # the time slider still shows a past step with its obstacles where they were
    shown = app.view_history(30.0)
    snap = app.snapshot()
    assert snap.history and snap.time_s == pytest.approx(shown)
    assert len(snap.obstacles) == 110


def test_a_recorded_step_costs_what_the_history_charges():
    """STEP_BYTES (and the positions' bytes) are no less than what a recorded step
    holds, measured with tracemalloc, for moving obstacles and for fuzzynav's blocks."""
    from fuzzynav.app.viewer.history import StepHistory

    for controller, scenario in (("p", _moving(110)), ("fuzzynav", load_scenario("s1"))):
        app = ViewerApp(scenario, controller)
        app._history = StepHistory(None, limit=1024**3)
        with app.lock:
            for _ in range(5):
                app.driver._step_locked()
        centres, radii, ids = app.sim.arena.obstacle_arrays()
        moved = [centres + 0.01 * k for k in range(400)]  # (made before the count)
        positions = iter(moved)
        app.sim.arena.obstacle_arrays = lambda p=positions, r=radii, i=ids: (next(p), r, i)
        gc.collect()
        tracemalloc.start()
        try:
            before = tracemalloc.get_traced_memory()[0]
            charged = app._history.bytes
            with app.lock:
                for _ in range(400):
                    app.results._record_history_locked()  # (the obstacles moved on)
            gc.collect()
            held = tracemalloc.get_traced_memory()[0] - before
        finally:
            tracemalloc.stop()
        assert app._history.bytes - charged >= held, (controller, held)


# -- obstacles --------------------------------------------------------------------------


def test_add_stops_at_the_documented_cap_with_a_message():
    """1,500 Adds took 464 MB, and after 3,000 a Pause took 43 s: no cap."""
    app = ViewerApp("s1", "p")
    rng = random.Random(0)
    n0 = len(app._layout)
    for _ in range(budgets.MAX_LAYOUT_OBSTACLES - n0):
        app.add_obstacle((rng.uniform(-200, 200), rng.uniform(20, 200)))
    assert len(app._layout) == budgets.MAX_LAYOUT_OBSTACLES
    assert app.account.held("obstacles") == (
        budgets.MAX_LAYOUT_OBSTACLES * budgets.ADDED_OBSTACLE_BYTES
    )
    with pytest.raises(ViewerError, match=f"up to {budgets.MAX_LAYOUT_OBSTACLES}; remove one"):
        app.add_obstacle((0.0, 50.0))
    assert len(app._layout) == budgets.MAX_LAYOUT_OBSTACLES
    app.remove_obstacle()
    app.add_obstacle((0.0, 50.0))  # room again


def test_add_keeps_an_hour_long_run_s_log_in_its_budget():
    """An hour at 20 ms holds at most 118 obstacles in the 2 GiB log budget (as an
    upload is checked); Add went past it."""
    app = ViewerApp(_moving(110), "p")
    with pytest.raises(ViewerError, match="too many here"):
        for k in range(20):
            app.add_obstacle((-100.0 + 5 * k, -50.0))
    assert len(app._layout) == 118


def test_one_budget_for_every_world_of_a_server():
    """A classroom's tabs share their server's budget: what one world holds counts
    against every other's, and a world that ends gives it back."""
    shared = budgets.MemoryBudget(total=10 * budgets.ADDED_OBSTACLE_BYTES)
    first, second = ViewerApp("s1", "p"), ViewerApp("s1", "p")
    first.attach_budget(shared)
    second.attach_budget(shared)
    rng = random.Random(2)
    with pytest.raises(ViewerError, match="memory budget is spent"):
        for _ in range(12):
            first.add_obstacle((rng.uniform(-50, 50), rng.uniform(20, 60)))
    with pytest.raises(ViewerError, match="memory budget is spent"):
        second.add_obstacle((0.0, 40.0))
    assert shared.used <= shared.total
    first.stop()
    assert shared.used == second.account.held()
    second.add_obstacle((0.0, 40.0))


# -- uploaded scenarios kept -------------------------------------------------------------


def _toml(k: int) -> bytes:
    return (
        f'name = "u{k}"\nduration_s = 60.0\n[robot]\nstart = [0.0, 0.0]\n'
        f"[target]\nposition = [{5 + k}.0, 0.0]\n"
    ).encode()


def test_uploaded_scenarios_kept_are_the_last_few():
    """400 uploads kept 182 MB and 400 dropdown entries."""
    app = ViewerApp("s1", "p")
    shipped = len(app.scenario_options())
    for k in range(30):
        label = app.upload_scenario(_toml(k), f"u{k}.toml")
    assert len(app.uploaded_scenarios) == budgets.MAX_KEPT_SCENARIOS
    assert len(app.scenario_options()) == shipped + budgets.MAX_KEPT_SCENARIOS
    assert label in app.uploaded_scenarios and "uploaded: u0.toml" not in app.uploaded_scenarios
    assert app.account.held("scenarios") == sum(
        budgets.scenario_charge(s) for s in app.uploaded_scenarios.values()
    )
    # the one loaded is never the one dropped (kept while another tab's push comes)
    app.load_scenario("uploaded: u22.toml")
    for k in range(30, 40):
        app.editing.keep_uploaded(f"pushed {k}", load_scenario("s2"))
    assert "uploaded: u22.toml" in app.uploaded_scenarios
    assert len(app.uploaded_scenarios) == budgets.MAX_KEPT_SCENARIOS


def test_a_kept_scenario_is_charged_no_less_than_it_holds():
    """KEPT_SCENARIO_BYTES and KEPT_OBSTACLE_BYTES bound what a kept scenario of 1,000
    obstacles holds (measured with tracemalloc: about 0.35 kB an obstacle)."""
    from fuzzynav.world.scenario import loads_scenario

    def toml(k):
        rows = [f'name = "big {k}"', "duration_s = 60.0", "[robot]", "start = [0.0, 0.0]"]
        rows += ["[target]", "position = [8.0, 8.0]"]
        for j in range(1000):
            rows += ["[[obstacles]]", f"position = [{j % 40 * 25 - 500}.0, {30 + j // 40 * 5}.0]"]
            rows += ["radius_m = 0.2"]
        return "\n".join(rows).encode()

    texts = [toml(k) for k in range(4)]
    loads_scenario(texts[0], source="warm-up")
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        kept = [loads_scenario(t, source=f"u{k}") for k, t in enumerate(texts)]
        gc.collect()
        held = (tracemalloc.get_traced_memory()[0] - before) / len(kept)
    finally:
        tracemalloc.stop()
    assert budgets.scenario_charge(kept[0]) >= held


# -- uploads under way -------------------------------------------------------------------


@pytest.fixture
def served():
    from fuzzynav.app.viewer.server import ViewerServer

    server = ViewerServer(ViewerApp("s1", "p"), port=0)
    yield server
    server.stop()


def _deliver(server, message) -> None:
    asyncio.run(compat_viser.handle_incoming(server.server.gui, 1, message))


def _start(uuid, transfer, size=1000, parts=1):
    return FileTransferStartUpload(
        uuid, transfer, f"{transfer}.toml", "text/plain", part_count=parts, size_bytes=size
    )


def test_an_upload_left_short_is_dropped_after_its_timeout(served, monkeypatch):
    """1,000 uploads one byte short of their declared size were kept for ever (98 to
    603 MB in 22 s)."""
    clock = [0.0]
    served.uploads.clock = lambda: clock[0]
    gui = served.server.gui
    uuid = compat_viser.handle_uuid(served.controls.scenario_upload)
    _deliver(served, _start(uuid, "short", size=1000, parts=2))
    _deliver(served, FileTransferPart(uuid, "short", 0, b"x" * 999))
    assert "short" in compat_viser.upload_states(gui)
    assert served.app.account.held("uploads") == 1000
    clock[0] = budgets.UPLOAD_TIMEOUT_S + 1
    served.uploads.sweep()  # (on the event loop, it is swept when due)
    assert "short" not in compat_viser.upload_states(gui)
    assert served.app.account.held("uploads") == 0
    assert "upload dropped" in served.app.message


def test_uploads_under_way_are_capped_and_their_charge_given_back(served):
    gui = served.server.gui
    uuid = compat_viser.handle_uuid(served.controls.scenario_upload)
    for k in range(budgets.MAX_UPLOADS_IN_FLIGHT + 3):
        _deliver(served, _start(uuid, f"t{k}", size=500, parts=2))
    under_way = [t for t in compat_viser.upload_states(gui) if t.startswith("t")]
    assert len(under_way) == budgets.MAX_UPLOADS_IN_FLIGHT
    assert "under way already" in served.app.message
    assert served.app.account.held("uploads") == 500 * budgets.MAX_UPLOADS_IN_FLIGHT
    # one finishes: its charge is given back, and another may start
    for part in range(2):
        _deliver(served, FileTransferPart(uuid, "t0", part, b"x" * 250))
    assert "t0" not in compat_viser.upload_states(gui)
    assert served.app.account.held("uploads") == 500 * (budgets.MAX_UPLOADS_IN_FLIGHT - 1)
    _deliver(served, _start(uuid, "again", size=500, parts=2))
    assert "again" in compat_viser.upload_states(gui)


# -- serve --rrd: the disk ----------------------------------------------------------------


def test_serve_rrd_records_a_few_runs_a_minute(tmp_path):
    """Each Step then Reset wrote a 747 kB file: 150 presses, 112 MB in 14 s."""
    pytest.importorskip("fuzzynav.app.recordings.record")
    clock = [0.0]
    app = ViewerApp("s1", "p", rrd_path=tmp_path / "session.rrd")
    app.driver.recording_budget.clock = lambda: clock[0]
    said = []
    app.on_message(lambda text, level: said.append(text))
    try:
        for _ in range(3 * budgets.RRD_RUNS_PER_MINUTE):
            app.step_once()
            app.reset()
        assert len(app.recorded_files) == budgets.RRD_RUNS_PER_MINUTE
        assert any("runs a minute are recorded" in t for t in said)
        clock[0] = 61.0  # a minute later, runs are recorded again
        app.step_once()
        app.reset()
        assert len(app.recorded_files) == budgets.RRD_RUNS_PER_MINUTE + 1
    finally:
        app.stop()
    assert sorted(tmp_path.glob("*.rrd")) == sorted(app.recorded_files)


def test_serve_rrd_stops_at_its_session_bytes(tmp_path):
    pytest.importorskip("fuzzynav.app.recordings.record")
    app = ViewerApp("s1", "p", rrd_path=tmp_path / "session.rrd")
    app.driver.recording_budget.session_bytes = 1
    said = []
    app.on_message(lambda text, level: said.append(text))
    try:
        for _ in range(3):
            app.step_once()
            app.reset()
    finally:
        app.stop()
    assert len(app.recorded_files) == 1
    assert any("the most serve --rrd writes" in t for t in said)


def test_the_docs_state_the_budget_s_numbers():
    """docs/viewer.md and docs/robustness.md say the numbers budget.py holds."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    viewer = " ".join((root / "docs/viewer.md").read_text(encoding="utf-8").split())
    robustness = (root / "docs/robustness.md").read_text(encoding="utf-8")
    b = budgets
    for phrase in (
        f"at most {b.MAX_UPLOADS_IN_FLIGHT} at once",
        f"not whole {b.UPLOAD_TIMEOUT_S:g} s after it began",
        f"the last {b.MAX_KEPT_SCENARIOS} of a world",
        f"{b.KEPT_SCENARIO_BYTES // 1024} kB + {b.KEPT_OBSTACLE_BYTES // 1024} kB an obstacle",
        f"up to {b.MAX_LAYOUT_OBSTACLES} obstacles",
        f"{b.ADDED_OBSTACLE_BYTES // 1024} kB an obstacle of the layout",
        f"{b.HISTORY_BYTES // 1024**2} MiB a world",
        f"at most {b.RRD_RUNS_PER_MINUTE} runs a minute are recorded",
        f"at most {b.RRD_SESSION_BYTES // 1024**3} GiB (`RRD_SESSION_BYTES`)",
        f"the {b.SERVER_BUDGET_BYTES // 1024**3} GiB of `MEMORY_BUDGET_BYTES`",
    ):
        assert phrase in viewer, phrase
    for name in (
        "test_an_upload_left_short_is_dropped_after_its_timeout",
        "test_uploads_under_way_are_capped_and_their_charge_given_back",
        "test_uploaded_scenarios_kept_are_the_last_few",
        "test_a_kept_scenario_is_charged_no_less_than_it_holds",
        "test_add_stops_at_the_documented_cap_with_a_message",
        "test_add_keeps_an_hour_long_run_s_log_in_its_budget",
        "test_the_history_stays_within_its_budget_and_spans_the_run",
        "test_a_recorded_step_costs_what_the_history_charges",
        "test_one_budget_for_every_world_of_a_server",
        "test_a_classroom_s_tabs_share_their_server_s_budget",
        "test_a_long_trail_is_drawn_in_few_nodes",
        "test_resets_leave_nothing_in_the_scene_s_message_buffer",
        "test_resets_without_a_step_keep_no_removed_obstacles",
        "test_serve_rrd_records_a_few_runs_a_minute",
        "test_serve_rrd_stops_at_its_session_bytes",
        "test_serve_rrd_completes_the_run_that_reaches_the_session_bytes",
    ):
        assert name in robustness and name in globals(), name


def test_a_long_trail_is_drawn_in_few_nodes(served):
    """An hour's trail was 22,500 scene nodes of 8 points (97 MB on the server, as many
    objects in every tab); the frozen chunks are now merged TRAIL_MERGE at a time, and
    the segments drawn are the trail's, each once."""
    import numpy as np

    from fuzzynav.app.viewer.scene import TRAIL_CHUNK, TRAIL_MERGE, polyline_segments

    app, scene = served.app, served.scene
    assert served.app.wait_for(lambda a: scene._drawn_run == a.run_id, timeout=10)
    served.render.stop()
    x0, y0 = app._trail[0]
    n = 20 * TRAIL_CHUNK * TRAIL_MERGE
    for k in range(1, n):
        app._trail.append((x0 + 0.03 * k, y0 + 0.01 * np.sin(0.01 * k)))
    for _ in range(3):  # (as the render thread draws, a piece at a time)
        scene._draw_trail()
    assert len(scene._trail_nodes) <= n // (TRAIL_CHUNK * TRAIL_MERGE) + TRAIL_MERGE
    nodes = scene._trail_nodes + [scene._current_trail]
    drawn = np.concatenate([np.asarray(node.points, dtype=float) for node in nodes])
    whole = polyline_segments(np.asarray(app._trail), 0.015)
    assert drawn.shape == whole.shape
    assert np.allclose(drawn, whole, atol=1e-3)


def test_resets_leave_nothing_in_the_scene_s_message_buffer(served):
    """viser kept a removal message per scene node name until a tab connected, and a
    node's name holds its run: each Reset or scenario load left three messages an
    obstacle (400 uploads of 1,000 obstacles: 518 MB). The render thread now sweeps
    them every SWEEP_PERIOD_S."""
    app = served.app
    for k in range(40):
        app.add_obstacle((-20.0 + k, 30.0))
    buffer = served.server._websock_server._broadcast_buffer

    def drawn():
        return served.app.wait_for(
            lambda a: (
                served.scene._drawn_run == a.run_id
                and all(key[0] == a.run_id for key in served.handles.obstacle_nodes)
            ),
            timeout=10,
        )

    for _ in range(10):
        app.reset()
        assert drawn()
    served.render.sweep()
    messages = list(buffer.message_from_id.values())
    assert not [m for m in messages if type(m).__name__ == "RemoveSceneNodeMessage"]
    # nothing of an earlier run's obstacles is kept (10 resets left 1,200 messages)
    now = f"/obstacles/r{app.run_id}_"
    names = [str(getattr(m, "name", "")) for m in messages]
    assert not [n for n in names if n.startswith("/obstacles/") and not n.startswith(now)]


def test_resets_without_a_step_keep_no_removed_obstacles():
    """pymunk's space kept every shape a reset removed until its next step: 300 Resets
    among 200 obstacles (or 300 scenario loads) without a step kept 60,000 shapes."""
    pymunk = pytest.importorskip("pymunk")
    app = ViewerApp("s1", "p")
    for k in range(100):
        app.add_obstacle((-60.0 + 1.2 * k, 40.0))
    for _ in range(30):
        app.reset()
    for _ in range(20):
        app.remove_obstacle()
        app.add_obstacle((0.0, 45.0))
    gc.collect()
    alive = sum(1 for o in gc.get_objects() if isinstance(o, pymunk.Circle))
    assert alive <= 2 * len(app._layout) + 10, alive


def test_a_classroom_s_tabs_share_their_server_s_budget():
    """With --classroom each tab's world was counted alone (3.6 GB of history a tab):
    every tab's world now charges the classroom server's one budget, and a closed tab
    gives its charges back."""
    from test_viewer_clients import ScriptedClients, wait_until

    from fuzzynav.app.viewer.classroom import ClassroomServer

    server = ClassroomServer(lambda: ViewerApp("s1", "p"), port=0, token="teach-me")
    clients = ScriptedClients(server.url)
    try:
        sockets = clients.connect(2)
        assert wait_until(lambda: len(server.sessions) == 2, timeout=120)
        views = list(server.sessions.values())
        assert all(view.app.budget is server.budget for view in views)
        views[0].app.add_obstacle((0.0, 30.0))
        views[1].app.add_obstacle((0.0, 30.0))
        held = sum(view.app.account.held() for view in views)
        assert server.budget.used == held > 0
        clients._run(sockets[0].close())
        assert wait_until(lambda: len(server.sessions) == 1, timeout=60)
        (left,) = server.sessions.values()
        assert wait_until(lambda: server.budget.used == left.app.account.held(), timeout=30)
    finally:
        clients.close()
        server.stop()


def test_serve_rrd_completes_the_run_that_reaches_the_session_bytes(tmp_path):
    """The run being recorded when the session's bytes are reached is completed there
    (a whole file, said on the page) and nothing more is written."""
    pytest.importorskip("fuzzynav.app.recordings.record")
    import math

    app = ViewerApp("s1", "p", rrd_path=tmp_path / "session.rrd")
    app.driver.recording_budget.session_bytes = 50_000
    said = []
    app.on_message(lambda text, level: said.append(text))
    try:
        for _ in range(400):
            app.driver._size_checked = -math.inf  # (read the size at every step)
            app.step_once()
            if app._recorder is None and app.recorded_files:
                break
        stopped_at = app.sim.time_s
        assert any(t.startswith("Recording stopped at t = ") for t in said), said
        for _ in range(20):
            app.step_once()
        app.reset()
        app.step_once()
    finally:
        app.stop()
    assert app.recorded_files == [tmp_path / "session.rrd"]
    assert stopped_at < 8.0 and (tmp_path / "session.rrd").stat().st_size > 50_000
