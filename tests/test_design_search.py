"""Tuning from Python (issue 40 item 4): an ask/tell search over the design layouts,
your own cost, infeasible candidates projected, options checked."""

from __future__ import annotations

import numpy as np
import pytest

import fuzzynav
from fuzzynav.app.experiments.search import DEFAULTS, DesignSearch
from fuzzynav.controller.design_rules import violations

INPUTS = np.array([4.0, np.nan, 0.5, np.nan])  # the target 4 m away, 0.5 rad to the left


def _turn_cost(controller) -> float:
    """Wanted: a right wheel 3 V faster than the left here."""
    left, right = controller(INPUTS)
    return abs((right - left) - 3.0)


def test_tune_lowers_your_cost_and_keeps_the_design_rules():
    start = _turn_cost(fuzzynav.make_controller("paper"))
    seen = []
    result = fuzzynav.tune(
        _turn_cost, "paper", generations=6, popsize=6, seed=1, progress=lambda g, c: seen.append(c)
    )
    assert seen == result.history and len(seen) == 6
    assert all(b <= a for a, b in zip(seen, seen[1:]))  # the best only improves
    assert result.cost < 0.5 * start, (result.cost, start)
    assert result.cost == pytest.approx(_turn_cost(result.controller))
    assert violations(result.controller.fis) == []
    again = fuzzynav.tune(_turn_cost, "paper", generations=6, popsize=6, seed=1)
    np.testing.assert_array_equal(again.vector, result.vector)  # seeded


def test_ask_gives_vectors_inside_the_bounds_and_projects_a_start_outside():
    search = DesignSearch("paper", popsize=5, sigma0=1.0, x0=np.full(12, 1e3))
    assert np.array_equal(search.best_vector, search.high)  # projected, not refused
    for _ in range(3):
        vectors = search.ask()
        assert len(vectors) == 5
        for v in vectors:
            assert np.all(v >= search.low) and np.all(v <= search.high)
        search.tell(vectors, [float("nan")] + [float(v.sum()) for v in vectors[1:]])
    assert search.generation == 3 and search.evaluations == 15
    assert np.isfinite(search.best_cost)


@pytest.mark.parametrize(
    ("options", "says"),
    [
        ({"sigma0": 0.0}, "sigma0"),
        ({"popsize": 2}, "popsize"),
        ({"seed": -1}, "seed"),
        ({"popsize": True}, "popsize"),
        ({"speed": 3}, "unknown"),
    ],
)
def test_options_are_checked_against_their_documented_ranges(options, says):
    with pytest.raises(ValueError, match=says):
        DesignSearch("paper", **options)


def test_the_defaults_are_documented_and_used():
    search = DesignSearch("paper")
    assert (search.sigma0, search.popsize, search.seed) == (
        DEFAULTS["sigma0"],
        DEFAULTS["popsize"],
        DEFAULTS["seed"],
    )
    with pytest.raises(ValueError, match="not tunable"):
        DesignSearch("p")
    with pytest.raises(ValueError, match="12 numbers"):
        search.project([1.0, 2.0])


def test_tune_draws_a_progress_bar_and_is_never_worse_than_its_start(capsys):
    start = _turn_cost(DesignSearch("paper").build())
    result = fuzzynav.tune(_turn_cost, "paper", generations=2, popsize=4, seed=2, progress=True)
    assert "generation 2/2" in capsys.readouterr().err
    assert result.cost <= start and result.generations == 2
    assert result.evaluations == 2 * 4 + 1  # and the start itself
    with pytest.raises(ValueError, match="progress"):
        fuzzynav.tune(_turn_cost, generations=1, popsize=4, progress="yes")


def test_the_one_tune_takes_the_commands_searches_with_your_cost():
    names = DesignSearch("paper").parameter_names
    free = [i for i, name in enumerate(names) if name.startswith("phi_t")]
    x0 = DesignSearch("paper").tunable.initial_vector()
    start = _turn_cost(DesignSearch("paper").build(x0))
    for method in ("de", "powell"):
        result = fuzzynav.tune(
            _turn_cost, "paper", method=method, generations=2, popsize=2, seed=1, free=free
        )
        fixed = [i for i in range(len(names)) if i not in free]
        np.testing.assert_array_equal(result.vector[fixed], x0[fixed])  # only phi_t moved
        assert result.cost <= start
        assert result.cost == pytest.approx(_turn_cost(result.controller))
    with pytest.raises(ValueError, match="one of them"):
        fuzzynav.tune(controller="paper")
    with pytest.raises(ValueError, match="method"):
        fuzzynav.tune(_turn_cost, method="annealing", generations=1, popsize=4)


@pytest.mark.parametrize("method", ["cmaes", "de"])
def test_a_population_cost_searches_as_a_cost_of_each_controller(method):
    calls = []

    def population_cost(controllers):
        calls.append(len(controllers))
        return [_turn_cost(c) for c in controllers]

    kwargs = dict(method=method, generations=2, popsize=4, seed=5)
    one_by_one = fuzzynav.tune(_turn_cost, "paper", **kwargs)
    together = fuzzynav.tune(population_cost=population_cost, controller="paper", **kwargs)
    np.testing.assert_array_equal(together.vector, one_by_one.vector)
    assert together.cost == one_by_one.cost and together.history == one_by_one.history
    assert max(calls) > 1  # whole generations, not one controller a call
    with pytest.raises(ValueError, match="one of them"):
        fuzzynav.tune(_turn_cost, population_cost=population_cost)
    with pytest.raises(ValueError, match="2 costs for"):
        fuzzynav.tune(population_cost=lambda cs: [0.0, 1.0], generations=1, popsize=4)
