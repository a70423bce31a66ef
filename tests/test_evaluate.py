"""fuzzynav.evaluate: a population on the batch engine gives simulate's runs and costs."""

from __future__ import annotations

import math
import warnings

import pytest

import fuzzynav
from fuzzynav.app.experiments.search import DesignSearch

NUMBERS = (
    "path_length_m",
    "min_clearance_m",
    "min_center_distance_m",
    "mad_m",
    "rmse_m",
    "time_to_target_s",
    "max_abs_voltage_v",
    "sim_time_s",
)


def cost(metrics) -> float:
    success = metrics["reached"] and not metrics["collided"]
    return (0.0 if success else 100.0) + metrics["path_length_m"]


def _candidates(k: int) -> list:
    search = DesignSearch("paper", popsize=max(4, k), sigma0=0.05, seed=2)
    return [search.build(v) for v in search.ask()[:k]]


def test_a_population_on_the_batch_engine_equals_simulate_run_by_run():
    controllers = _candidates(3)
    seen = []
    evaluation = fuzzynav.evaluate(
        controllers, 2, cost, seed=1, start=4, progress=lambda d, t: seen.append((d, t))
    )
    assert evaluation.engines == ["batch"] * 3
    assert seen[0] == (0, 6) and seen[-1] == (6, 6)
    assert len(evaluation.scenarios) == 2
    assert evaluation.costs is not None and evaluation.costs.shape == (3, 2)
    for i, controller in enumerate(controllers):
        for j, scenario in enumerate(evaluation.scenarios):
            reference = fuzzynav.simulate(scenario, controller, seed=1).result.metrics
            mine = evaluation.metrics[i][j]
            for key in ("outcome", "reached", "collided", "steps", "voltage_jumps"):
                assert mine[key] == reference[key], (i, j, key)
            for key in NUMBERS:  # the engines agree to rounding (summation order)
                a, b = mine[key], reference[key]
                assert (a is None) == (b is None), (i, j, key)
                if a is not None:
                    assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9), (i, j, key, a, b)
            assert math.isclose(
                evaluation.costs[i, j], cost(reference), rel_tol=1e-12, abs_tol=1e-9
            )
    assert evaluation.mean_costs.shape == (3,)
    assert evaluation.success.shape == (3, 2)


def test_the_layouts_are_sweeps_layouts_from_start():
    from fuzzynav.world.layouts import generate_layout

    evaluation = fuzzynav.evaluate(["p"], 2, family="clutter", seed=7, start=5)
    assert [s.to_toml() for s in evaluation.scenarios] == [
        generate_layout("clutter", 7, i).to_toml() for i in (5, 6)
    ]
    assert evaluation.costs is None
    with pytest.raises(ValueError, match="mean_costs"):
        _ = evaluation.mean_costs


def test_a_controller_the_batch_engine_cannot_drive_runs_on_pymunk_with_a_warning():
    from toy_controller import ToyController

    with pytest.warns(RuntimeWarning, match="pymunk"):
        evaluation = fuzzynav.evaluate([ToyController(), "p"], ["s1"], cost)
    assert evaluation.engines == ["pymunk", "batch"]
    reference = fuzzynav.simulate("s1", ToyController()).result.metrics
    assert evaluation.metrics[0][0]["outcome"] == reference["outcome"]
    assert evaluation.costs[0, 0] == pytest.approx(cost(reference), rel=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"controllers": "paper"}, "a list of controllers"),
        ({"controllers": []}, "none given"),
        ({"controllers": ["p"], "layouts": ["s1"], "seed": 3}, "not with scenarios"),
        ({"controllers": ["p"], "layouts": 2, "start": -1}, "start"),
        ({"controllers": ["p"], "layouts": 2, "progress": "yes"}, "progress"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    with warnings.catch_warnings(), pytest.raises(ValueError, match=message):
        fuzzynav.evaluate(**kwargs)
