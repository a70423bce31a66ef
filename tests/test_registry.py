"""One controller registry, one declared interface, one checker (issue 36 item 2).

A controller added through the registry alone is offered by the command line, the
API's ``simulate`` and ``sweep``, the batch engine (when its class declares a batch
form) and the viewer; the checker holds every registered controller to the interface.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from toy_controller import BatchableToy, ToyController

import fuzzynav
from fuzzynav.controller.checker import (
    ControllerCheckError,
    check_controller,
    check_registered,
)
from fuzzynav.controller.registry import (
    controller_entry,
    controller_names,
    make_controller,
    register_controller,
    unregister_controller,
)


@pytest.fixture
def toy():
    register_controller("toy", ToyController, description="a user's go-to-goal law")
    register_controller(
        "toy-batch", BatchableToy, description="the same, batchable", batchable=True
    )
    yield "toy"
    unregister_controller("toy")
    unregister_controller("toy-batch")


@pytest.mark.parametrize(
    ("name", "geometry"),
    [
        (name, geometry)
        for name in controller_names()
        for geometry in (
            ("husky", "paper") if controller_entry(name).geometry_aware else ("husky",)
        )
    ],
)
def test_every_registered_controller_meets_the_interface_and_its_entry(name, geometry):
    caps = check_registered(name, geometry)
    assert ("batch" in caps) == controller_entry(name).batchable


def test_the_lists_of_names_all_read_the_registry(toy):
    from fuzzynav.app.cli import build_parser

    assert "toy" in controller_names()
    assert "toy-batch" in controller_names(batchable=True)
    assert "toy" not in controller_names(batchable=True)
    assert controller_names(fis_export=True) == ["paper", "baseline", "fuzzynav"]
    assert controller_names(tunable=True) == ["paper", "fuzzynav"]
    parser = build_parser()
    args = parser.parse_args(["run", "s1", "--controller", "toy"])
    assert args.controller == "toy"


def test_a_toy_added_through_the_registry_alone_drives_simulate_sweep_and_the_viewer(toy):
    from fuzzynav.app.viewer.model import ViewerApp

    run = fuzzynav.simulate("s1", "toy")
    assert run.outcome in ("reached", "collided", "timeout")
    assert run.trace["time_s"].size > 10
    direct = fuzzynav.simulate("s1", ToyController())
    np.testing.assert_array_equal(run.trace["x_m"], direct.trace["x_m"])

    rows = fuzzynav.sweep("toy", n=3, seed=2, engine="pymunk")
    assert [r["controller"] for r in rows] == ["toy"] * 3
    # the batch engine drives the batchable toy, and decides as the pymunk engine does
    batch_rows = fuzzynav.sweep("toy-batch", n=3, seed=2, engine="batch")
    pymunk_rows = fuzzynav.sweep("toy-batch", n=3, seed=2, engine="pymunk")
    assert [r["outcome"] for r in batch_rows] == [r["outcome"] for r in pymunk_rows]

    app = ViewerApp("s1", "toy")
    assert "toy" in app.controller_options()
    for _ in range(50):
        app.step_once()
    assert app.sim.time_s > 0.5


def test_a_module_factory_name_needs_no_registration():
    controller = make_controller("toy_controller:ToyController")
    assert isinstance(controller, ToyController)
    with pytest.raises(ValueError, match="unknown"):
        make_controller("no such controller")


def test_registration_refuses_bad_names_taken_names_and_non_factories(toy):
    with pytest.raises(ValueError, match="already registered"):
        register_controller("toy", ToyController, description="again")
    with pytest.raises(ValueError, match="a letter"):
        register_controller("9lives", ToyController, description="x")
    with pytest.raises(ValueError, match="not callable"):
        register_controller("broken", 3, description="x")
    with pytest.raises(ValueError, match="description"):
        register_controller("quiet", ToyController, description=" ")
    # a flag that is no bool ("no" is true: batchable="no" was taken as batchable)
    for flag in ("batchable", "geometry_aware", "fis_export", "replace"):
        with pytest.raises(TypeError, match=f"{flag} = 'no': must be True or False"):
            register_controller("flagged", ToyController, description="x", **{flag: "no"})
    with pytest.raises(ValueError, match="tunable = 5"):
        register_controller("flagged", ToyController, description="x", tunable=5)
    assert "flagged" not in controller_names()


class _NoReset:
    def __call__(self, inputs):
        return [0.0, 0.0]


class _NaNOut(ToyController):
    def __call__(self, inputs):
        return [math.nan, 1.0]


class _Remembers(ToyController):
    def __init__(self):
        super().__init__()
        self.calls = 0

    def reset(self):
        pass  # forgets nothing

    def __call__(self, inputs):
        self.calls += 1
        return np.array([float(self.calls), 0.0])


class _WrongBatch(ToyController):
    @classmethod
    def batched(cls, controllers, run_sets=None):
        class Zero:
            def decide(self, inputs, runs, ranges_m=None):
                return np.zeros((len(inputs), 2))

        return Zero()


class _DocumentedBatch(ToyController):
    """``batched(controllers, run_sets)`` exactly as controller/interface.py writes it
    (no default): the checker called it with one argument (TypeError)."""

    @classmethod
    def batched(cls, controllers, run_sets):
        return BatchableToy.batched(controllers, run_sets)


class _TextBatch(ToyController):
    @classmethod
    def batched(cls, controllers, run_sets=None):
        class Text:
            def decide(self, inputs, runs, ranges_m=None):
                return np.full((len(inputs), 2), "a")

        return Text()


def test_the_checker_calls_batched_as_documented():
    assert "batch" in check_controller(_DocumentedBatch())


@pytest.mark.parametrize(
    ("controller", "says"),
    [
        (_TextBatch(), "batch form returned <U1 values"),  # was float()'s ValueError
        (_NoReset(), "no reset"),
        (lambda inputs: [0.0, 0.0], "no reset"),
        (_NaNOut(), "non-finite"),
        (_Remembers(), "after reset"),
        (_WrongBatch(), "batch form decides otherwise"),
    ],
)
def test_the_checker_names_what_a_controller_gets_wrong(controller, says):
    with pytest.raises(ControllerCheckError, match=says):
        check_controller(controller)


def test_the_checker_passes_a_sound_user_controller_and_reports_its_capabilities():
    assert check_controller(ToyController()) == frozenset()
    assert check_controller(BatchableToy()) == frozenset({"batch"})
    assert "parts" in check_controller(make_controller("fuzzynav"))


class _Planner(ToyController):
    """Asks for the world's context: steers by the true target position."""

    needs_context = True

    def __init__(self):
        super().__init__()
        self.seen = []

    def reset(self):
        self.seen = []

    def __call__(self, inputs, context=None):
        self.seen.append(context)
        x, y, heading = context.pose
        tx, ty = context.target
        bearing = math.atan2(ty - y, tx - x) - heading
        turn = 4.0 * math.atan2(math.sin(bearing), math.cos(bearing))
        return np.array([6.0 - turn, 6.0 + turn])


def test_a_controller_that_declares_needs_context_gets_the_world_as_the_simulation_knows_it():
    planner = _Planner()
    assert "context" in check_controller(planner)
    run = fuzzynav.simulate("s2", planner)
    first, last = planner.seen[0], planner.seen[-1]
    s2 = fuzzynav.load_scenario("s2")
    assert first.time_s == 0.0 and first.period_s == 0.02
    assert first.pose[:2] == pytest.approx(s2.start) and first.target == pytest.approx(s2.target)
    assert len(first.obstacles) == len(s2.obstacles) and len(first.ranges_m) == 3
    moving = [k for k, o in enumerate(s2.obstacles) if any(o.velocity) or any(o.acceleration)]
    k = moving[0]
    assert last.obstacles[k][:2] != first.obstacles[k][:2]  # the moving obstacle moved
    assert last.pose[:2] == pytest.approx(
        (run.trace["x_m"][len(planner.seen) - 1], run.trace["y_m"][len(planner.seen) - 1])
    )


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("no_such_module_xyz:Factory", "importing no_such_module_xyz failed"),
        ("toy_controller:NoSuchFactory", "has no 'NoSuchFactory'"),
        ("toy_controller:math", "is not callable"),
        ("math:pow", "calling it with no arguments failed"),
        ("math:sqrt", "it raised TypeError"),  # one argument: a controller function
        ("os:getcwd", "not a controller"),
        ("toy_controller:failing_factory", "it raised RuntimeError"),  # was RuntimeError
    ],
)
def test_a_module_factory_that_makes_no_controller_is_a_value_error_naming_it(spec, says):
    with pytest.raises(ValueError, match=says) as error:
        make_controller(spec)
    assert spec in str(error.value)
    with pytest.raises(ValueError, match=says):
        fuzzynav.simulate("s1", spec)


def test_a_registered_module_that_fails_on_import_breaks_no_list(tmp_path, monkeypatch):
    import sys

    (tmp_path / "broken_controller_mod.py").write_text("raise RuntimeError('a bug of mine')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    register_controller("broken", "broken_controller_mod:Mine", description="mine, broken")
    try:
        names = controller_names()
        assert "broken" in names and "paper" in names
        assert "broken_controller_mod" not in sys.modules  # listed without importing
        with pytest.raises(ValueError, match="unknown .*choose from paper"):
            make_controller("no such controller")
        from fuzzynav.app.viewer.model import ViewerApp

        assert "broken" in ViewerApp("s1", "p").controller_options()  # the viewer's list
        with pytest.raises(ValueError, match="a bug of mine") as error:
            make_controller("broken")
        assert "broken_controller_mod:Mine" in str(error.value)
    finally:
        unregister_controller("broken")


class _Says:
    name = "says-six"

    def __init__(self, returned):
        self.returned = returned

    def reset(self):
        pass

    def __call__(self, inputs):
        return self.returned


@pytest.mark.parametrize(
    "returned", [("6", "6"), (1.0, 2.0, 3.0), [[1.0, 2.0]], "66", None, (True, False)]
)
def test_returned_voltages_that_are_not_two_real_numbers_are_refused_naming_the_controller(
    returned,
):
    with pytest.raises(ValueError, match="controller 'says-six' returned .*two real numbers"):
        fuzzynav.simulate("s1", _Says(returned))
    with pytest.raises(ControllerCheckError, match="two real numbers"):
        check_controller(_Says(returned))


def test_a_class_that_declares_batched_is_batchable_without_saying_so():
    import warnings

    entry = register_controller("toy-detected", BatchableToy, description="batch form declared")
    try:
        assert entry.batchable and "toy-detected" in controller_names(batchable=True)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # on the batch engine: no fallback to warn of
            rows = fuzzynav.sweep("toy-detected", n=3, seed=1)
        assert len(rows) == 3
    finally:
        unregister_controller("toy-detected")
    assert controller_entry("toy_controller:BatchableToy").batchable  # detected on import
    assert not controller_entry("toy_controller:ToyController").batchable


def test_a_fallback_to_the_pymunk_engine_is_warned_from_python():
    with pytest.warns(UserWarning, match="cannot be batched.*pymunk engine"):
        rows = fuzzynav.sweep("toy_controller:ToyController", n=2, seed=1, engine="batch")
    assert len(rows) == 2


def test_sweep_takes_a_module_factory_name_as_simulate_does():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rows = fuzzynav.sweep("toy_controller:BatchableToy", n=2, seed=1)
    again = fuzzynav.sweep(BatchableToy(), n=2, seed=1)
    assert [r["outcome"] for r in rows] == [r["outcome"] for r in again]
    assert rows[0]["path_length_m"] == again[0]["path_length_m"]
    with pytest.raises(ValueError, match="no_such_module_xyz"):
        fuzzynav.sweep("no_such_module_xyz:Factory", n=2)


def test_a_controller_as_one_plain_function_runs_everywhere_without_a_class():
    """A scalar function and a vectorised one: simulate, sweep on both engines (the
    vectorised one on the batch engine itself, no fallback), the registry and the
    viewer; the same runs as the class they are the law of."""
    import warnings

    from toy_controller import toy_decide, toy_law

    from fuzzynav.app.viewer.model import ViewerApp

    reference = fuzzynav.simulate("s1", ToyController())
    for function in (toy_law, toy_decide):
        run = fuzzynav.simulate("s1", function)
        np.testing.assert_allclose(run.trace["x_m"], reference.trace["x_m"], rtol=0, atol=1e-9)
        assert run.metrics["controller"] == function.__name__
    expected = fuzzynav.sweep(BatchableToy(), n=3, seed=2, engine="pymunk")
    with pytest.warns(UserWarning, match="pymunk engine"):  # a scalar function: no batch form
        scalar = fuzzynav.sweep(toy_law, n=3, seed=2, engine="batch")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the vectorised one is batched: nothing to warn of
        batched = fuzzynav.sweep(toy_decide, n=3, seed=2, engine="batch")
    pymunk = fuzzynav.sweep(toy_decide, n=3, seed=2, engine="pymunk")
    for rows in (scalar, batched, pymunk):
        assert [r["outcome"] for r in rows] == [r["outcome"] for r in expected]
        assert [r["path_length_m"] for r in rows] == pytest.approx(
            [r["path_length_m"] for r in expected], rel=1e-9
        )
    for name, function, batchable in (
        ("fn-scalar", toy_law, False),
        ("fn-vector", toy_decide, True),
    ):
        entry = register_controller(name, function, description="one plain function")
        try:
            assert entry.batchable is batchable
            check_registered(name)
            app = ViewerApp("s1", name)
            assert name in app.controller_options()
            for _ in range(30):
                app.step_once()
            assert app.sim.time_s > 0.5
        finally:
            unregister_controller(name)
    assert controller_entry("toy_controller:toy_decide").batchable
    assert isinstance(make_controller("toy_controller:toy_law").function, type(toy_law))
