"""Issue 38, without a browser: the viewer answers while paused (every drag, switch and
edit re-senses and re-infers at once, and so after a run has ended), without touching
the run's noise stream.

The page side of the same is in tests/test_viewer_lesson_browser.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.app.viewer.lesson import read_lesson
from fuzzynav.app.viewer.model import ViewerApp
from fuzzynav.controller.registry import controller_names

pytestmark = pytest.mark.skipif("paper" not in controller_names(), reason="no paper controller")


def ahead(app: ViewerApp, metres: float) -> tuple[float, float]:
    x, y, heading = app.sim.arena.pose
    return (x + metres * math.cos(heading), y + metres * math.sin(heading))


@pytest.mark.parametrize("perception", ["ideal", "ultrasonic"])
def test_paused_an_obstacle_dragged_ahead_is_sensed_and_inferred_at_once(perception):
    """Defect 1: paused at t = 0, an obstacle dragged a metre ahead of the robot left
    "d_o none sensed", the beams and the rules as they were until Step."""
    app = ViewerApp("s1", "paper", perception=perception)
    before = app.snapshot()
    strengths_before = app.teaching()["strengths"].copy()
    assert not math.isfinite(before.inputs[1])  # nothing sensed at the start of s1
    first = next(iter(app.sim.arena.obstacles))
    app.move_obstacle(first, ahead(app, 1.6))
    snap = app.snapshot()
    assert snap.time_s == 0.0 and not snap.playing  # no step was taken
    assert math.isfinite(snap.inputs[1]) and snap.inputs[1] < 1.5
    if perception == "ultrasonic":
        assert np.isfinite(snap.ranges_m).any()  # the beams see it
    assert not np.allclose(app.teaching()["strengths"], strengths_before)
    assert np.all(np.isfinite(snap.voltages_v))  # the controller answered again
    # the drawn inputs are read from where the robot stands
    assert snap.input_pose == tuple(app.sim.arena.pose)


def test_paused_a_dragged_target_moves_d_t_and_after_the_end_too():
    """Defect 1: after a paused drag of the target, status said 11.31 m where the target
    was 9.22 m away; after a run ended, the status stopped following the target."""
    app = ViewerApp("s1", "paper")
    for _ in range(50):
        app.step_once()
    app.move_target((3.0, 6.0))
    x, y, _ = app.sim.arena.pose
    assert app.snapshot().inputs[0] == pytest.approx(math.hypot(3.0 - x, 6.0 - y))
    # a run that has ended: its last pose, and the target still answers
    app.add_obstacle(ahead(app, 0.9))
    while not app.sim.done:
        app.driver._step_locked()
    assert app.sim.done
    app.move_target((1.0, 9.0))
    x, y, _ = app.sim.arena.pose
    snap = app.snapshot()
    assert snap.inputs[0] == pytest.approx(math.hypot(1.0 - x, 9.0 - y))
    assert snap.outcome is not None  # the outcome stays until Play starts a new run


def test_switches_and_edits_while_paused_re_sense():
    """Perception, noise and disturbance switched while paused: the inputs are read
    again at once."""
    app = ViewerApp("s1", "paper")
    app.move_obstacle(next(iter(app.sim.arena.obstacles)), ahead(app, 1.2))
    ideal = app.snapshot().inputs[1]
    app.set_perception("ultrasonic")
    sonar = app.snapshot().inputs[1]
    assert math.isfinite(sonar)
    app.set_noise(0.1)  # the beams read again, with noise
    noisy = app.snapshot().inputs[1]
    assert math.isfinite(noisy) and noisy != sonar
    app.set_perception("ideal")
    assert app.snapshot().inputs[1] == pytest.approx(ideal)


def test_a_paused_read_leaves_the_runs_noise_stream_as_it_was():
    """The extra reads while paused draw no noise of the run's: two runs with sensor
    noise, one of them dragged about while paused (and put back), stay the same."""
    runs = []
    for drag in (False, True):
        app = ViewerApp("s1", "paper", perception="ultrasonic", noise_std_m=0.05, seed=3)
        for _ in range(30):
            app.step_once()
        if drag:
            ob = next(iter(app.sim.arena.obstacles))
            home = tuple(app.sim.arena.obstacles[ob].position_at(app.sim.time_s))
            for metres in (0.8, 1.0, 1.2):
                app.move_obstacle(ob, ahead(app, metres))
            app.move_obstacle(ob, home)
        for _ in range(200):
            app.step_once()
        runs.append(np.array(app.sim.arena.pose))
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-9)


def test_a_refusal_in_what_if_or_looking_back_goes_when_that_mode_ends():
    """Defect 5: the red message of a refused what-if value (or time) outlived what-if
    mode and the time slider."""
    from fuzzynav.app.viewer.model import ViewerError

    app = ViewerApp("s1", "paper")
    for _ in range(10):
        app.step_once()
    app.start_what_if()
    with pytest.raises(ViewerError) as refused:
        app.set_what_if_input(0, 1e6)
    app._notice(str(refused.value), "error")  # as the page's guard tells it
    assert app.snapshot().message
    app.stop_what_if()
    assert app.snapshot().message == ""
    # the time slider: a refusal said while looking back goes with Live, and with Play
    for leave in (app.leave_history, app.step_once):
        app.view_history(0.1)
        app._notice("time 'x': must be a number of seconds", "error")
        leave()
        assert app.snapshot().message == ""
    # a message said outside those modes stays
    app._notice("Obstacle 1 is on the robot", "warning")
    app.start_what_if()
    app.stop_what_if()
    assert app.snapshot().message == "Obstacle 1 is on the robot"


def test_paused_fuzzynav_answers_a_drag_through_a_copy_of_itself():
    """Defect 1 for a controller with a memory (fuzzynav): paused, a drag re-infers
    through a copy (its answer and its blocks shown), and the driving controller is
    not called: a run dragged about while paused and put back stays the same."""
    runs = []
    for drag in (False, True):
        app = ViewerApp("s1", "fuzzynav")
        for _ in range(40):
            app.step_once()
        inner_t = app.controller.inner.t
        if drag:
            before = app.teaching()
            ob = next(iter(app.sim.arena.obstacles))
            home = tuple(app.sim.arena.obstacles[ob].position_at(app.sim.time_s))
            app.move_obstacle(ob, ahead(app, 1.0))
            snap = app.snapshot()
            assert np.all(np.isfinite(snap.voltages_v))  # it answered
            after = app.teaching()
            assert after is not None and not np.allclose(after["inputs"], before["inputs"])
            assert app.controller.inner.t == inner_t  # the driving one was not called
            app.move_obstacle(ob, home)
        for _ in range(150):
            app.step_once()
        runs.append(np.array(app.sim.arena.pose))
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-9)


def test_the_starter_system_is_offered_reads_two_inputs_and_drives():
    """Issue 38: a small two-input system to start a lesson with, beside the paper's:
    six rules over d_t and phi_t only; without obstacles it reaches the target."""
    from fuzzynav.app.viewer import views
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    app = ViewerApp("s1", "paper")
    assert STARTER_LABEL in app.controller_options()
    app.set_controller(STARTER_LABEL)
    fis = app.fuzzy_system()
    assert len(fis.rules) == 6
    used = {i for r in fis.rules for i, a in enumerate(r.antecedent) if a is not None}
    assert {fis.input_names[i] for i in used} == {"d_t", "phi_t"}
    info = app.teaching()  # paused, it answered at once
    assert info is not None and np.all(np.isfinite(app.snapshot().voltages_v))
    page = views.inference_html(views.infer(fis, info["inputs"]))
    assert "of 6 rules fire" in page
    for obstacle_id in list(app.sim.arena.obstacles):
        app.remove_obstacle(obstacle_id)
    while not app.sim.done:
        app.driver._step_locked()
    assert app.sim.outcome == "reached"
    # and a teacher's push names it, and a student's world builds it
    student = ViewerApp("s1", "paper")
    student.apply_settings(app.settings())
    assert student.controller_label == STARTER_LABEL


def test_a_lesson_saved_and_opened_again_is_the_same_world(tmp_path):
    """Issue 38: a lesson file keeps the scenario and its layout (still "edited"), the
    controller and its Editor edits, the settings, the view and the time; opened in
    another world it gives the same state."""
    from fuzzynav.app.viewer.model import ViewerError

    app = ViewerApp("s1", "paper")
    ob = next(iter(app.sim.arena.obstacles))
    app.move_obstacle(ob, (3.0, 1.0))
    app.set_inference_choice("defuzz_method", "bisector")
    app.set_perception("ultrasonic")
    app.set_speed(3.0)
    for _ in range(150):
        app.step_once()
    text = app.lesson_text({"presentation": True, "firing_only": True})
    other = ViewerApp("s2", "p")
    view = other.open_lesson(text, "my-lesson.json")
    assert view == {"presentation": True, "firing_only": True}
    assert other.scenario_label == "s1" and other.layout_edited
    assert other.controller_label == app.controller_label == "paper (edited)"
    assert other.fuzzy_system().inference.defuzz_method == "bisector"
    assert other.sim.perception.mode == "ultrasonic" and other.speed == 3.0
    assert other.sim.time_s == pytest.approx(app.sim.time_s) and not other.playing
    np.testing.assert_allclose(other.sim.arena.pose, app.sim.arena.pose, atol=1e-9)
    other.restore_layout()
    assert not other.layout_edited
    # a file from elsewhere is refused with its reason, the world kept
    before = other.snapshot().scenario_label
    for bad, why in (
        (b"{", "not a lesson file"),
        (b'{"a": 1}', "not a fuzzynav lesson"),
        (text.replace('"time_s": ', '"time_s": 1e9 + ').encode(), "not a lesson file"),
        (text.replace('"perception": "ultrasonic"', '"perception": 7').encode(), "perception"),
    ):
        with pytest.raises(ViewerError, match=why):
            other.open_lesson(bad, "bad.json")
    assert other.snapshot().scenario_label == before


def test_serve_opens_a_lesson_file(tmp_path):
    """``fuzzynav serve --lesson FILE``: the lesson's world, view and time at start."""
    from fuzzynav.app.viewer.serve import serve

    app = ViewerApp("s1", "paper")
    app.add_obstacle((2.0, 2.0))
    for _ in range(50):
        app.step_once()
    path = tmp_path / "lesson.json"
    path.write_text(app.lesson_text({"firing_only": True}), encoding="utf-8")
    server = serve("s2", port=0, block=False, open_message=False, lesson=path)
    try:
        assert server.app.scenario_label == "s1" and server.app.layout_edited
        # the run is replayed on a thread of its own: the server serves meanwhile
        assert server.app.wait_for(lambda a: a.message.startswith("Opened the lesson"))
        assert server.app.sim.time_s == pytest.approx(1.0)
        assert server.inference.firing_only_cb.value is True
    finally:
        server.stop()
    from fuzzynav.app.args import UsageError

    (tmp_path / "bad.json").write_text("{}", encoding="utf-8")
    with pytest.raises(UsageError, match="--lesson"):
        serve("s1", port=0, block=False, open_message=False, lesson=tmp_path / "bad.json")


@pytest.mark.parametrize(
    "choice",
    [None]
    + [("and_method", "prod"), ("imp_method", "prod"), ("agg_method", "sum")]
    + [("agg_method", "probor"), ("defuzz_method", "mom"), ("defuzz_method", "bisector")],
)
def test_one_inference_step_by_step_says_the_engines_numbers(choice):
    """Issue 38: the five stages of one inference, each said with its numbers, for
    every inference choice: the degrees, each rule's AND (its strength), the implied
    sets (clipped or scaled), the aggregate and the crisp outputs are the engine's."""
    from fuzzynav.app.viewer import views
    from fuzzynav.app.viewer.drawing import _fmt_degree
    from fuzzynav.app.viewer.stepwise import N_STAGES, implied_sets, stage_html

    app = ViewerApp("s1", "paper")
    if choice is not None:
        app.set_inference_choice(*choice)
    for _ in range(30):
        app.step_once()
    info = app.teaching()
    inf = views.infer(info["fis"], info["inputs"])
    fis = inf.fis
    pages = [stage_html(inf, k) for k in range(1, N_STAGES + 1)]
    for k, page in enumerate(pages, 1):
        assert f"Step {k} of {N_STAGES}" in page
    # 1: every sensed input's degrees
    for i, var in enumerate(fis.inputs):
        for t, d in zip(var.terms, inf.memberships[i]):
            if d > 0:
                assert f"{t.name} {_fmt_degree(float(d))}" in pages[0]
    # 2: each listed rule's AND equals the engine's strength
    and_prod = fis.inference.and_method == "prod"
    listed = [int(r) for r in np.argsort(-inf.strengths, kind="stable") if inf.strengths[r] > 0]
    for r in listed[:8]:  # the strongest eight are listed
        degrees = [
            inf.memberships[i][k] for i, k in enumerate(fis.rules[r].antecedent) if k is not None
        ]
        combined = (np.prod(degrees) if and_prod else min(degrees)) * fis.rules[r].weight
        assert combined == pytest.approx(inf.strengths[r], rel=1e-9, abs=1e-12)
        assert f"= <b>{_fmt_degree(float(inf.strengths[r]))}</b>" in pages[1]
    # 3: the implied sets, aggregated by the system's method, are the engine's aggregate
    sets = [implied_sets(inf, int(r)) for r in np.flatnonzero(inf.strengths > 0)]
    for o in range(fis.n_outputs):
        parts = [s[o] for s in sets if o in s]
        if not parts:
            continue
        method = fis.inference.agg_method
        if method == "max":
            mine = np.max(parts, axis=0)
        elif method == "sum":
            mine = np.sum(parts, axis=0)
        else:
            mine = 1.0 - np.prod([1.0 - p for p in parts], axis=0)
        np.testing.assert_allclose(mine, inf.aggregate[o], atol=1e-9)
    assert ("scaled by" if fis.inference.imp_method == "prod" else "clipped at") in pages[2]
    assert f"aggregation {fis.inference.agg_method}" in pages[3]
    # 5: the crisp outputs are the controller's voltages
    for c in inf.centroids:
        assert f"{c:.2f}" in pages[4]
    np.testing.assert_allclose(inf.centroids, fis.evaluate_one(inf.inputs), atol=1e-9)


def test_baseline_shows_its_two_blocks_in_the_inference():
    """Defect 5: baseline is a fuzzy controller (its two rule files ship), yet the
    Inference tab said it had no rules. Now its blocks show at the inputs they read,
    with the blend's weight, and the outputs' blend is the controller's answer."""
    from fuzzynav.app.viewer import views

    app = ViewerApp("s1", "baseline")
    info = app.teaching()
    assert info is not None
    fis = info["fis"]
    assert fis is app.fuzzy_system()  # one system, kept (the views key on it)
    html_text = views.inference_html(views.infer(fis, info["inputs"]), crisp=info["state"])
    assert html_text.count("Block ") == 2 and "goal_left" in html_text
    ob = next(iter(app.sim.arena.obstacles))
    app.move_obstacle(ob, ahead(app, 1.0))
    info = app.teaching()
    alpha = float(info["state"]["avoidance weight alpha"])
    assert alpha > 0
    c = views.infer(info["fis"], info["inputs"]).centroids
    names = list(info["output_names"])
    goal = c[[names.index("goal_left"), names.index("goal_right")]]
    avoid = c[[names.index("avoid_left"), names.index("avoid_right")]]
    np.testing.assert_allclose(
        (1 - alpha) * goal + alpha * avoid, app.snapshot().voltages_v, atol=0.01
    )


def test_crowded_obstacles_are_labelled_by_their_number_on_their_top():
    """Defect 5: in trap the posts' labels ("obstacle 7" beside each) overlapped, and a
    tall post away from the middle showed its side beside its top (a double circle)."""
    import time

    from fuzzynav.app.viewer.handles import OBSTACLE_HEIGHT_M
    from fuzzynav.app.viewer.server import ViewerServer

    assert OBSTACLE_HEIGHT_M <= 0.25
    server = ViewerServer(ViewerApp("trap", "paper"), port=0)
    try:

        def labels():
            return {
                n["number"]: (n["label"].text, n["label"].anchor)
                for n in server.handles.obstacle_nodes.values()
            }

        deadline = time.monotonic() + 10
        while len(labels()) < 10 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert labels() == {k: (str(k), "center-center") for k in range(1, 11)}
        # s1's obstacles stand apart: labelled in full, beside them
        server.app.load_scenario("s1")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and set(labels()) != {1, 2, 3}:
            time.sleep(0.1)
        time.sleep(0.3)
        # (obstacle 3, 2.5 m from the arena's right edge, on its left: cut there before)
        assert labels() == {
            1: ("obstacle 1", "center-left"),
            2: ("obstacle 2", "center-left"),
            3: ("obstacle 3", "center-right"),
        }
    finally:
        server.stop()


def test_rules_are_added_changed_removed_and_undone_validated_and_exported():
    """Issue 38: the Editor edits the rules like a designer: a sentence read by the rule
    base's own parser (a wrong term or variable refused with its reason), applied at
    once to the driving controller, undoable, and exported in TOML and .fis."""
    from fuzzynav.app.viewer.model import ViewerError
    from fuzzynav.controller.rulebase import loads_toml

    app = ViewerApp("s1", "paper")
    editor = app.editor()
    n = len(app.fuzzy_system().rules)
    first = editor.rule_text(1)
    # change rule 1's consequent, with a weight
    import re

    changed = (
        re.split(r"\s+then\s+", first, flags=re.I)[0]
        + " then left is VS and right is VS weight 0.5"
    )
    app.edit_rules("set", 1, changed)
    assert app.controller_label == "paper (edited)"
    rule = app.fuzzy_system().rules[0]
    assert rule.weight == 0.5 and "0.5" in app.editor().rule_text(1)
    # add one, remove one
    app.edit_rules("add", text="if d_t is VS then left is VS and right is VS")
    assert len(app.fuzzy_system().rules) == n + 1
    app.edit_rules("remove", 2)
    assert len(app.fuzzy_system().rules) == n
    # refused with the reason, nothing changed
    before = app.fuzzy_system().rules
    for bad, why in (
        ("if d_t is HUGE then left is S", "unknown term"),
        ("if speed is S then left is S", "unknown variable"),
        ("d_t is S then left is S", "must start with IF"),
    ):
        with pytest.raises(ViewerError, match=why):
            app.edit_rules("add", text=bad)
    assert app.fuzzy_system().rules == before
    # a slider move keeps the edited rules
    name = editor.names[0]
    lo, hi = editor.bounds[name]
    app.set_membership_parameter(name, 0.5 * (lo + hi))
    assert app.fuzzy_system().rules == before
    # undo, back to the shipped rules
    app.edit_rules("undo")
    app.edit_rules("undo")
    app.edit_rules("undo")
    assert app.fuzzy_system().rules == app.editor().shipped.fis.rules
    with pytest.raises(ViewerError, match="no rule edit"):
        app.edit_rules("undo")
    # exported in TOML, read back the same
    app.edit_rules("set", 1, changed)
    assert loads_toml(app.editor().toml_text()).rules == app.fuzzy_system().rules


def _run_with_switches_and_edits():
    """A run of s1: paper, then the starter, edited, then fuzzynav, then a rule edit
    (the paper's, edited), a change of noise between; paused at 13 s."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    app = ViewerApp("s1", "paper")
    for _ in range(150):
        app.step_once()
    app.set_controller(STARTER_LABEL)
    for _ in range(100):
        app.step_once()
    app.set_membership_parameter("d_t.near", 1.5)
    app.set_noise(0.02)
    for _ in range(100):
        app.step_once()
    app.set_controller("fuzzynav")
    for _ in range(200):
        app.step_once()
    app.edit_rules("set", 1, app.editor().rule_text(1).replace("right IS VS", "right IS S"))
    for _ in range(100):
        app.step_once()
    return app


def test_a_lesson_saved_after_switches_and_edits_reopens_at_the_same_inputs():
    """A lesson saved mid-run after controller switches and edits reopens at the moment
    saved: the run is replayed with each switch and edit at its step (it was replayed
    with the last controller from t = 0: d_t 6.15 m where 3.87 m was saved)."""
    app = _run_with_switches_and_edits()
    text = app.lesson_text()
    saved = app.controller.last_inputs.copy()
    other = ViewerApp("s2", "p")
    other.open_lesson(text, "lesson.json")
    assert other.sim.time_s == pytest.approx(app.sim.time_s)
    now = other.controller.last_inputs
    assert abs(now[0] - saved[0]) <= 1e-6 and abs(now[2] - saved[2]) <= 1e-6, (now, saved)
    np.testing.assert_allclose(other.sim.arena.pose, app.sim.arena.pose, atol=1e-9)
    assert other.controller_label == app.controller_label == "paper (edited)"
    assert other.fuzzy_system() == app.fuzzy_system()
    assert other.message_level == "info" and other.message.startswith("Opened the lesson")


def test_a_lesson_whose_run_had_a_drag_warns_that_the_replay_differs():
    """A drag during the run cannot be replayed (the layout saved is the one the run
    restarts from): the lesson opens, and says where and why the moment differs."""
    app = ViewerApp("s1", "paper")
    for _ in range(200):
        app.step_once()
    tx, ty = app.sim.arena.target
    app.move_target((tx, ty + 4.0))
    for _ in range(200):
        app.step_once()
    other = ViewerApp("s1", "paper")
    other.open_lesson(app.lesson_text(), "dragged.json")
    assert other.message_level == "warning"
    assert "differs" in other.message and "the target moved at 4.00 s" in other.message


def _world(app) -> tuple:
    with app.lock:
        return (
            app.scenario_label,
            app.controller_label,
            app.sim.perception.mode,
            app.geometry,
            app.speed,
            app.seed,
            app.noise_std_m,
            app.disturbance_on,
            app.parts_off,
            app.sim.time_s,
            tuple(app.sim.arena.pose),
            app.editing._layout_scenario(),
            app.message,
        )


@pytest.mark.parametrize(
    ("key", "old", "new"),
    [
        ("speed", '"speed": 1.0', '"speed": Infinity'),
        ("speed", '"speed": 1.0', '"speed": 50'),
        ("perception", '"geometry": "husky"', '"geometry": "paper"'),  # with ultrasonic
        ("geometry", '"geometry": "husky"', '"geometry": "flat"'),
        ("noise_std_m", '"noise_std_m": 0.0', '"noise_std_m": 5.0'),
        ("parts_off", '"parts_off": []', '"parts_off": ["wings"]'),
        ("controller", '"controller": "paper"', '"controller": "nosuch"'),
        ("seed", '"seed": 0', '"seed": -5'),
        (
            "timeline[0]: perception",
            '"perception": "ultrasonic",\n      "disturbance_on"',
            '"perception": "sonar",\n      "disturbance_on"',
        ),
        # values of the wrong kind or beyond reason
        ("noise_std_m", '"noise_std_m": 0.0', '"noise_std_m": 1' + "0" * 400),  # OverflowError
        ("time_s", '"time_s": ', '"time_s": 1' + "0" * 400 + ', "was": '),
        ("speed", '"speed": 1.0', '"speed": 1' + "0" * 400),
        ("unreplayed", '"unreplayed": []', '"unreplayed": 5'),  # TypeError
        ("unreplayed", '"unreplayed": []', '"unreplayed": "a drag"'),  # read per character
        ("view", '"view": {}', '"view": {"presentation": "no"}'),  # "no" was presentation on
        ("sped", '"speed": 1.0', '"speed": 1.0, "sped": 3.0'),  # a misspelt key was ignored
        ("timeline[0]: unknown key", '"step": 0,', '"step": 0, "perceptoin": "ideal",'),
        ("scenario_label", '"scenario_label": "s1"', '"scenario_label": "' + "s" * 5000 + '"'),
        ("nested too deep", '"view": {}', '"view": ' + "[" * 5000 + "]" * 5000),  # RecursionError
    ],
)
def test_a_refused_lesson_leaves_the_world_exactly_as_it_was(key, old, new):
    """Every setting is checked before any is applied: a refused lesson names its file
    and key, and leaves the world as it was (an infinite speed, an impossible geometry
    and perception pair, ... left it switched to the lesson's scenario; an integer of
    400 digits raised OverflowError, ``unreplayed: 5`` TypeError, JSON nested 5,000 deep
    RecursionError; a misspelt key and a view of texts were taken)."""
    from fuzzynav.app.viewer.model import ViewerError

    app = ViewerApp("s1", "paper", perception="ultrasonic")
    for _ in range(20):
        app.step_once()
    text = app.lesson_text()
    assert old in text, old
    bad = text.replace(old, new, 1)
    world = ViewerApp("s3", "p")
    world.set_speed(3.0)
    for _ in range(5):
        world.step_once()
    before = _world(world)
    with pytest.raises(ViewerError) as refused:
        world.open_lesson(bad, "class-3.json")
    assert "class-3.json" in str(refused.value) and key in str(refused.value)
    assert _world(world) == before


def test_a_lesson_s_label_and_unreplayed_texts_cannot_drive_a_terminal():
    """The scenario's label and what the run did are shown as they are read: control
    characters are written as escapes, as every name from a file is."""
    app = ViewerApp("s1", "paper")
    text = app.lesson_text()
    other = ViewerApp("s1", "paper")
    bad = text.replace('"scenario_label": "s1"', '"scenario_label": "s1\\u001b[2J"', 1)
    bad = bad.replace('"unreplayed": []', '"unreplayed": ["a drag\\u001b[31m"]', 1)
    lesson = read_lesson(bad, "ctl.json")
    assert lesson["scenario_label"] == "s1\\x1b[2J"
    assert lesson["unreplayed"] == ["a drag\\x1b[31m"]
    other.open_lesson(bad, "ctl.json")
    assert "\x1b" not in other.scenario_label


def test_a_long_lesson_is_replayed_on_a_thread_of_its_own():
    """``serve --lesson`` with a long time serves at once: opening returns before the
    replay has made a step (the world's lock is held here, so the replay cannot start),
    and the replay then reaches the time on its own thread."""
    app = ViewerApp("s1", "paper")
    for _ in range(300):
        app.step_once()
    text = app.lesson_text()
    other = ViewerApp("s2", "p")
    with other.lock:
        other.open_lesson(text, "long.json", background=True)
        assert other.sim.time_s == 0.0 and other.message.startswith("Opening the lesson")
    assert other.wait_for(lambda a: a.message.startswith("Opened the lesson"), timeout=60)
    assert other.sim.time_s == pytest.approx(6.0)


def test_the_rule_editor_refuses_the_rule_past_the_files_limit_and_the_lesson_reopens():
    """The rule editor stops at the limit a rule base file holds (one constant,
    controller.rulebase.MAX_RULES): the next Add is refused with a word, and the TOML
    export and a saved lesson of that many rules open again (past it, both were refused
    on reopening and the teacher's work was lost). The page's adds are built off its
    thread, together."""
    from fuzzynav.app.viewer.model import ViewerError
    from fuzzynav.controller.rulebase import MAX_RULES, loads_toml

    app = ViewerApp("s1", "paper")
    rule = "if d_t is VS and phi_t is Z then left is VS and right is VS"
    for _ in range(MAX_RULES - app.editor().rule_count()):
        app.edit_rules("add", None, rule, wait=False)
    assert app.wait_for(lambda a: len(a.fuzzy_system().rules) == MAX_RULES, timeout=120)
    with pytest.raises(ViewerError, match=f"the most a rule base file holds \\({MAX_RULES}\\)"):
        app.edit_rules("add", None, rule, wait=False)
    assert app.editor().rule_count() == MAX_RULES
    assert len(loads_toml(app.editor().toml_text()).rules) == MAX_RULES
    other = ViewerApp("s2", "p")
    other.open_lesson(app.lesson_text(), "many-rules.json")
    assert len(other.fuzzy_system().rules) == MAX_RULES and other.message_level == "info"
    # undo goes back one add at a time
    app.edit_rules("undo")
    assert len(app.fuzzy_system().rules) == MAX_RULES - 1


def test_a_drop_that_causes_a_collision_is_named_as_its_cause():
    """An obstacle dropped in the robot's way during the run, and the robot then hits
    it: the message names the obstacle and the drop, with its time (it said only
    "collided with an obstacle")."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    app = ViewerApp("s1", "paper")
    app.set_controller(STARTER_LABEL)  # it reads no obstacle: it drives into one
    for _ in range(50):
        app.step_once()
    x, y, _ = app.sim.arena.pose
    tx, ty = app.sim.arena.target
    d = np.hypot(tx - x, ty - y)
    ob = next(iter(app.sim.arena.obstacles))  # put on the way to the target, 2 m ahead
    app.move_obstacle(ob, (x + 2.0 * (tx - x) / d, y + 2.0 * (ty - y) / d))
    for _ in range(2000):
        if app.sim.done:
            break
        app.step_once()
    assert app.metrics is not None and app.metrics["collisions"] >= 1
    number = app.obstacle_number(ob)
    assert f"collided with obstacle {number}, which was dropped in its way at t = 1.00 s" in (
        app.message
    ), app.message
    # a collision without a drop names the obstacle only
    app.reset()
    for _ in range(3000):
        if app.sim.done:
            break
        app.step_once()
    assert "collided with obstacle" in app.message and "dropped" not in app.message


def test_the_obstacle_plane_holds_a_target_near_enough_to_show_the_obstacle_rules():
    """The Surface tab's (d_o, phi_o) map holds the target near, straight ahead, where
    the paper's obstacle rules change the turn by more than 1.5 V over the plane (with
    the target 5 m ahead the turn spanned 0.7 V: the map showed nearly nothing). The
    starter, blind to obstacles, gets no such map."""
    import types

    from fuzzynav.app.viewer import surface_view
    from fuzzynav.app.viewer.starter import starter_controller
    from fuzzynav.app.viewer.surface_panel import SurfacePanel
    from fuzzynav.controller.registry import make_controller

    panel = SurfacePanel.__new__(SurfacePanel)
    panel.surface_axes, panel.surface_held = (0, 2), [5.0, 1.0, 0.0, 0.0]
    panel.surface_no_obstacle_cb = types.SimpleNamespace(value=True)
    title, fis, xi, yi, x_range, y_range, held, _ = panel._surface_planes_for(
        make_controller("paper")
    )[1]
    assert (xi, yi) == (1, 3) and "ahead" in title
    _, _, out = surface_view.surface_grid(fis, xi, yi, x_range, y_range, held)
    out = np.asarray(out)
    turn = (out[..., 1] - out[..., 0]) / 2
    assert np.ptp(turn) > 1.5, np.ptp(turn)
    assert len(panel._surface_planes_for(starter_controller())) == 1


def test_a_teachers_note_is_saved_with_the_lesson_and_shown_when_it_opens():
    """Lesson → Teacher's note: kept in the lesson file and said when it is opened (in
    the message and back in the box); one too long is refused, naming file and key."""
    from fuzzynav.app.viewer.lesson import MAX_NOTE_CHARS
    from fuzzynav.app.viewer.model import ViewerError

    app = ViewerApp("s1", "paper")
    app.set_note("Watch rule 9 as the robot nears obstacle 1.")
    for _ in range(10):
        app.step_once()
    text = app.lesson_text()
    other = ViewerApp("s2", "p")
    other.open_lesson(text, "note.json")
    assert other.note == "Watch rule 9 as the robot nears obstacle 1."
    assert other.message.endswith("Teacher's note: Watch rule 9 as the robot nears obstacle 1.")
    with pytest.raises(ViewerError, match="at most"):
        app.set_note("x" * (MAX_NOTE_CHARS + 1))
    long = text.replace('"note": "Watch', '"note": "' + "x" * MAX_NOTE_CHARS + "Watch")
    with pytest.raises(ViewerError, match="long.json: note"):
        other.open_lesson(long, "long.json")


def test_a_rule_edit_made_while_an_earlier_one_builds_is_driven_after_it(monkeypatch):
    """The page's rule edits are built off its thread: an edit made while an earlier
    build is under way (forced here: the first build waits after taking its copy of the
    rules) is not lost; the robot ends driving with both, and the editor counts both."""
    import threading

    from fuzzynav.controller import fis_controller

    app = ViewerApp("s1", "paper")
    first = app.editor().rule_count()
    started, release = threading.Event(), threading.Event()
    original = fis_controller.FisController

    class Held(original):
        def __init__(self, *args, **kwargs):
            if not started.is_set():
                started.set()
                assert release.wait(30)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(fis_controller, "FisController", Held)
    rule = "if d_t is VS and phi_t is Z then left is VS and right is VS"
    app.edit_rules("add", None, rule, wait=False)
    assert started.wait(30)  # the first build holds its copy of one added rule
    app.edit_rules("add", None, rule.replace("is Z", "is P"), wait=False)
    release.set()
    assert app.wait_for(lambda a: len(a.fuzzy_system().rules) == first + 2, timeout=30)
    assert app.editor().rule_count() == first + 2


def _edited_both(sliders_at: float, choice: tuple, rule: int):
    """A world whose Editor edited the starter (a slider), then the paper controller (a
    slider at ``sliders_at`` of its range, an inference choice, rule ``rule``'s
    weight), paused after some steps."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    app = ViewerApp("s1", "paper")
    app.set_controller(STARTER_LABEL)
    lo, hi = app.editor().bounds["d_t.near"]
    app.set_membership_parameter("d_t.near", lo + sliders_at * (hi - lo))
    for _ in range(50):
        app.step_once()
    app.set_controller("paper")
    for name in app.editor().names[:3]:
        lo, hi = app.editor().bounds[name]
        app.set_membership_parameter(name, lo + sliders_at * (hi - lo))
    app.set_inference_choice(*choice)
    app.edit_rules("set", rule, app.editor().rule_text(rule) + " weight 0.5")
    for _ in range(100):
        app.step_once()
    return app


def _editors(app) -> dict:
    """What each Editor holds: its sliders' numbers, its rules, its choices; and the
    controllers offered."""
    from fuzzynav.app.viewer.editor_panel import EDITOR_CHOICES

    out = {"offered": app.controller_options()}
    for kind in ("paper", "starter"):
        editor = app.editor(kind)
        out[kind] = (
            {name: editor.value(name) for name in editor.names},
            [editor.rule_text(k) for k in range(1, editor.rule_count() + 1)],
            {field: editor.choice(field) for field, _, _ in EDITOR_CHOICES},
            editor.edited,
        )
    return out


def test_a_reopened_lesson_brings_its_editor_not_the_worlds_own():
    """A lesson opened in a world whose Editor had edits of its own: the Editor holds
    the lesson's (each system's sliders at the numbers saved, its rules, its choices;
    the sliders kept the world's numbers), and a slider then moved keeps the lesson's
    other shapes (it rebuilt them from the world's numbers). A lesson without edits
    leaves the Editor afresh; an older lesson (no editors) still opens."""
    import json

    from fuzzynav.app.viewer.model import ViewerError

    saved = _edited_both(0.25, ("defuzz_method", "bisector"), 1)
    text = saved.lesson_text()
    world = _edited_both(0.75, ("agg_method", "sum"), 2)
    world.open_lesson(text, "edited.json")
    assert world.controller_label == "paper (edited)"
    assert _editors(world) == _editors(saved)
    name = saved.editor().names[5]  # a slider moved to its own number: nothing changes
    world.set_membership_parameter(name, saved.editor().value(name))
    assert world.fuzzy_system() == saved.fuzzy_system()
    # a lesson of the shipped systems: the Editor afresh
    world.open_lesson(ViewerApp("s1", "paper").lesson_text(), "plain.json")
    assert _editors(world) == _editors(ViewerApp("s1", "paper"))
    assert "paper (edited)" not in world.controller_options()
    # an older lesson (no editors): the last edit of each system, its sliders as shipped
    data = json.loads(text)
    del data["editors"]
    world.open_lesson(json.dumps(data), "old.json")
    assert world.fuzzy_system() == saved.fuzzy_system()
    assert _editors(world)["paper"][1:] == _editors(saved)["paper"][1:]
    assert _editors(world)["paper"][0] == _editors(ViewerApp("s1", "paper"))["paper"][0]
    # refused with file, key and value; the world kept
    first = saved.editor().names[0]
    for change, why in (
        (lambda d: d["editors"]["paper"]["numbers"].update({first: 1e6}), f"{first} = 1000000"),
        (
            lambda d: d["editors"]["paper"]["numbers"].pop(first),
            "not the layout's numbers (missing: d_t",
        ),
        (lambda d: d["editors"].update({"fuzzynav": {}}), "editors = "),
        (lambda d: d["editors"]["starter"].update({"rule_base": 0}), "variables and terms"),
    ):
        data = json.loads(text)
        change(data)
        before = _world(world), _editors(world)
        with pytest.raises(ViewerError, match="bad.json: editors") as refused:
            world.open_lesson(json.dumps(data), "bad.json")
        assert why in str(refused.value)
        assert (_world(world), _editors(world)) == before


def _drawn(server) -> bool:
    """Whether ``server``'s panels are drawn at its world's version (and stay so)."""
    import time

    app = server.app
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        version = app.version
        if server.render._last_panel_version == version:
            time.sleep(0.3)  # and nothing changes meanwhile
            if server.render._last_panel_version == app.version == version:
                return True
        time.sleep(0.05)
    return False


def test_a_reopened_lesson_is_shown_as_saved_in_every_panel():
    """The page of a world that opened a lesson shows what the saved world's page
    showed: the Editor's sliders, choices and rule, the What-if boxes, the surface, the
    inference and its step by step (the world had its own edits, tried inputs and a
    stage open before)."""
    import re

    from fuzzynav.app.viewer.server import ViewerServer

    def shown(server):
        editor, inference = server.editor, server.inference
        return {
            "sliders": {name: slider.value for name, slider in editor.editor_sliders.items()},
            "choices": {field: box.value for field, box in editor.editor_choices.items()},
            "rule": (
                editor.rule_text.value,
                server.app.editor().rule_text(int(editor.rule_number.value)),
            ),
            "what-if": (inference.what_if_cb.value, [b.value for b in inference.what_if_boxes]),
            "surface": server.surface.surface_html.content,
            "inference": re.sub(r"\bfz\d+", "fz", inference.inference_html.content),
            "stage": inference.stage_html.content,
        }

    saved = _edited_both(0.25, ("defuzz_method", "bisector"), 1)
    text = saved.lesson_text()
    world = _edited_both(0.75, ("agg_method", "sum"), 2)
    servers = [ViewerServer(saved, port=0), ViewerServer(world, port=0)]
    try:
        world.start_what_if()
        world.set_what_if_input(0, 3.0)
        for server in servers:
            server.inference.stage = 2  # the rules' AND, step by step
            server.inference.redraw()
        assert _drawn(servers[1])
        world.open_lesson(text, "edited.json")
        assert _drawn(servers[0]) and _drawn(servers[1])
        want, got = shown(servers[0]), shown(servers[1])
        assert got == want
        assert got["rule"][0] == got["rule"][1]
        assert want["what-if"][1][0] == pytest.approx(saved.controller.last_inputs[0], abs=0.01)
    finally:
        for server in servers:
            server.stop()


def test_a_teachers_push_brings_the_teachers_editor_as_a_lesson_does():
    """A classroom push (the teacher's ``settings`` taken by ``apply_settings``) to a
    world whose Editor had edits of its own: its Editor holds the teacher's (each
    system's sliders, rules and choices), as a lesson of the teacher's world brings
    them, and a slider then moved keeps the teacher's other shapes (it rebuilt them from
    the student's numbers). The editors are the student's own (an edit there leaves the
    teacher's); a push without edits leaves the Editor afresh."""
    teacher = _edited_both(0.25, ("defuzz_method", "bisector"), 1)
    student = _edited_both(0.75, ("agg_method", "sum"), 2)
    lessoned = _edited_both(0.75, ("agg_method", "sum"), 2)
    lessoned.open_lesson(teacher.lesson_text(), "teacher.json")
    student.apply_settings(teacher.settings())
    assert student.controller_label == "paper (edited)"
    assert student.fuzzy_system() == teacher.fuzzy_system()
    assert _editors(student) == _editors(teacher) == _editors(lessoned)
    name = teacher.editor().names[5]  # a slider moved to its own number: nothing changes
    student.set_membership_parameter(name, teacher.editor().value(name))
    assert student.fuzzy_system() == teacher.fuzzy_system()
    lo, hi = student.editor().bounds[name]
    student.set_membership_parameter(name, lo + 0.9 * (hi - lo))
    student.edit_rules("remove", 3)
    assert _editors(teacher) == _editors(lessoned)
    # a push of the shipped systems: the Editor afresh
    student.apply_settings(ViewerApp("s1", "paper").settings())
    assert _editors(student) == _editors(ViewerApp("s1", "paper"))
    assert student.controller_label == "paper"


def test_what_if_boxes_say_none_sensed_for_an_input_not_sensed_now():
    """The greyed What-if boxes of a paused moment (a lesson opened) whose d_o and phi_o
    are not sensed (no obstacle in view) hold no number and say *none sensed*, as the
    term plots do, not the numbers of the moment shown before; tried in What-if, the
    same; a number set shows again."""
    from fuzzynav.app.viewer.server import ViewerServer

    NONE_SENSED = "none sensed"  # what the term plots say of such an input
    empty = ViewerApp("s1", "paper")
    for obstacle_id in list(empty.sim.arena.obstacles):
        empty.remove_obstacle(obstacle_id)
    for _ in range(20):
        empty.step_once()
    assert np.isnan(empty.controller.last_inputs[[1, 3]]).all()
    app = ViewerApp("s1", "paper")
    app.add_obstacle(ahead(app, 2.0))
    server = ViewerServer(app, port=0)
    boxes = server.inference.what_if_boxes

    def shown():
        return [(box.label, box.value) for box in boxes]

    try:
        app.step_once()
        assert _drawn(server)
        sensed = app.controller.last_inputs.copy()
        assert np.isfinite(sensed).all()
        labels = [label for label, _ in shown()]
        assert [value for _, value in shown()] == pytest.approx(np.round(sensed, 2))
        assert not any(NONE_SENSED in label for label in labels)
        app.open_lesson(empty.lesson_text(), "empty.json")
        assert _drawn(server)
        now = app.controller.last_inputs
        for k, (label, value) in enumerate(shown()):
            if k in (1, 3):
                assert label == f"{labels[k]}: {NONE_SENSED}" and math.isnan(value), shown()
            else:
                assert label == labels[k] and value == pytest.approx(round(now[k], 2))
        app.start_what_if()
        assert _drawn(server)
        assert [math.isnan(value) for _, value in shown()] == [False, True, False, True]
        app.set_what_if_input(1, 1.5)
        assert _drawn(server)
        assert shown()[1] == (labels[1], 1.5)
        assert shown()[3][0] == f"{labels[3]}: {NONE_SENSED}"
    finally:
        server.stop()


def test_a_misspelt_key_in_a_lessons_editor_is_refused_by_name():
    """A key an ``editors`` entry does not hold is named, not ignored, and the world
    stays as it was."""
    import json

    from fuzzynav.app.viewer.model import ViewerError

    data = json.loads(_edited_both(0.25, ("defuzz_method", "bisector"), 1).lesson_text())
    data["editors"]["paper"]["numbrs"] = {}
    world = ViewerApp("s3", "p")
    before = _world(world)
    with pytest.raises(ViewerError, match=r"misspelt\.json: editors\.paper.*'numbrs'"):
        world.open_lesson(json.dumps(data), "misspelt.json")
    assert _world(world) == before
