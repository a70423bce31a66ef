"""The optimiser and the command that reconstructed the paper controller's rule base."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.experiments.evolution import cmaes
from fuzzynav.app.experiments.paper_fit import (
    NOT_REACHED_COST,
    paper_results,
    read_fitted,
    run_cost,
    story_cost,
)
from fuzzynav.controller.design_rules import violations
from fuzzynav.controller.paper import PAPER_RULES
from fuzzynav.controller.paper_design import DESIGN_PARAMETERS, PaperDesignTunable
from fuzzynav.controller.rulebase import read_toml


def _serial(f, xs):
    return [f(x) for x in xs]


def _shifted_sphere(x):
    return float(np.sum((np.asarray(x) - np.array([0.3, -1.2, 2.0, 0.7])) ** 2))


def test_cmaes_finds_a_quadratic_minimum_and_repeats_itself():
    bounds = [(-3.0, 3.0)] * 4
    x, f, nit, nfev = cmaes(_shifted_sphere, bounds, np.zeros(4), 0.3, 80, 10, 1, _serial)
    np.testing.assert_allclose(x, [0.3, -1.2, 2.0, 0.7], atol=1e-3)
    assert f < 1e-5 and nit == 80 and nfev == 800
    again = cmaes(_shifted_sphere, bounds, np.zeros(4), 0.3, 80, 10, 1, _serial)
    assert np.array_equal(again[0], x) and again[1] == f  # seeded: the same run


def test_cmaes_stays_in_the_box():
    # The unconstrained minimum (0.3, -1.2, 2.0, 0.7) lies outside on the third axis.
    bounds = [(-3.0, 3.0), (-3.0, 3.0), (-1.0, 1.0), (-3.0, 3.0)]
    seen = []

    def recording(x):
        seen.append(np.asarray(x))
        return _shifted_sphere(x)

    x, *_ = cmaes(recording, bounds, np.zeros(4), 0.3, 60, 10, 2, _serial)
    lo, hi = np.array(bounds).T
    assert all(np.all((lo <= s) & (s <= hi)) for s in seen)
    assert x[2] == pytest.approx(1.0, abs=1e-3)


class _CornerCost:
    """A stand-in for the fit's cost (no runs): a quadratic whose minimum lies past the
    upper bound of every design number, recording each vector it is asked about."""

    seen: list = []

    def __init__(self, *args, **kwargs):
        low, high = np.array(PaperDesignTunable().bounds()).T
        self.target = high + 0.5 * (high - low)
        self.span = high - low

    def __call__(self, vector):
        vector = np.asarray(vector, float)
        _CornerCost.seen.append(vector.copy())
        return float(np.sum(((vector - self.target) / self.span) ** 2))


def test_fit_papers_optimiser_keeps_the_box_and_repeats_itself(monkeypatch):
    """fit-paper's search (pycma's CMA-ES through paper_fit.fit) evaluates only vectors
    inside the design numbers' bounds, ``popsize`` a generation for ``maxiter``
    generations (and the start once more), and repeats itself for a seed."""
    from fuzzynav.app.experiments import paper_fit

    monkeypatch.setattr(paper_fit, "FitCost", _CornerCost)
    low, high = np.array(PaperDesignTunable().bounds()).T

    def fitted(seed):
        _CornerCost.seen = []
        out = paper_fit.fit(6, 5, seed, 1, 0.05, sigma0=0.3, engine="pymunk")
        return out, np.array(_CornerCost.seen)

    (x, cost, nit, nfev), seen = fitted(4)
    assert (nit, nfev) == (6, 6 * 5 + 1) and len(seen) == nfev
    assert np.all((low <= seen) & (seen <= high))
    assert np.all((low <= x) & (x <= high))
    start_cost = _CornerCost()(PaperDesignTunable().initial_vector())
    assert cost < start_cost  # it moved towards the corner, and stayed in the box
    (x_again, cost_again, *_), seen_again = fitted(4)
    assert np.array_equal(x_again, x) and cost_again == cost
    assert np.array_equal(seen_again, seen)  # the same candidates, in the same order
    (x_other, *_), _ = fitted(5)
    assert not np.array_equal(x_other, x)


def test_fit_paper_is_seeded_on_the_real_cost(tmp_path):
    """Two fits with one seed write the same rule base (one generation of four)."""
    texts = []
    for name in ("a.toml", "b.toml"):
        out = tmp_path / name
        argv = ["fit-paper", "--maxiter", "1", "--popsize", "4", "--seed", "3"]
        assert main(argv + ["--workers", "1", "--out", str(out), "--json"]) == 0
        texts.append(read_fitted(out))
    assert np.array_equal(texts[0], texts[1])


def _measured(reached=True, **changes):
    paper = paper_results()
    table = paper["table4"]["s2"]
    m = {
        "scenario": "s2",
        "reached": reached,
        "collided": False,
        "path_length_m": table["path_length_m"],
        "mad_m": table["mad_m"],
        "rmse_m": table["rmse_m"],
        "min_center_distance_m": table["min_center_distance_m"],
        "passes": [(29.0, 0.38), (61.0, 0.72)],
        "chatter_steps": 0,
        "final_phi_t_rad": 0.0,
        "closest_to_target_m": 0.1,
    }
    m.update(changes)
    return m, paper


def test_the_papers_own_numbers_cost_nothing_and_any_arrival_beats_none():
    m, paper = _measured()
    assert run_cost(m, paper) == pytest.approx(0.0, abs=1e-12)
    worst, _ = _measured(
        path_length_m=1e3,
        mad_m=1e3,
        rmse_m=1e3,
        min_center_distance_m=1e3,
        passes=[(1e3, 1e3), (1e3, 1e3)],
        chatter_steps=10_000,
        final_phi_t_rad=3.0,
    )
    lost, _ = _measured(reached=False)
    assert run_cost(worst, paper) < NOT_REACHED_COST <= run_cost(lost, paper)


def test_the_story_costs_nothing_when_told_and_something_when_not():
    def run(name, passes, mad_m=0.6, approach=1.0):
        return {
            "scenario": name,
            "passes": passes,
            "mad_m": mad_m,
            "approach_speed_ratio": approach,
        }

    told = [
        run("s1", [(30.0, 0.46), (45.0, 0.29), (60.0, 0.26)]),
        run("s2", [(29.0, 0.38), (61.0, 0.72)], mad_m=0.57),
        run("s3", [(33.0, 0.63), (57.0, 0.73)], mad_m=0.63),
    ]
    assert story_cost(told) == 0.0
    first_closest = [run("s1", [(30.0, 0.22), (45.0, 0.82), (60.0, 0.96)])] + told[1:]
    s3_early = told[:2] + [run("s3", [(28.0, 0.63), (57.0, 0.73)], mad_m=0.63)]
    s3_too_late = told[:2] + [run("s3", [(37.0, 0.63), (57.0, 0.73)], mad_m=0.63)]
    s3_as_close = told[:2] + [run("s3", [(33.0, 0.40), (57.0, 0.73)], mad_m=0.63)]
    s3_straighter = told[:2] + [run("s3", [(33.0, 0.63), (57.0, 0.73)], mad_m=0.50)]
    crawl = [run("s1", told[0]["passes"], approach=0.2)] + told[1:]
    for untold in (first_closest, s3_early, s3_too_late, s3_as_close, s3_straighter, crawl):
        assert story_cost(untold) > 0.0


def test_the_shipped_rule_base_is_rebuilt_from_its_own_header():
    vector = read_fitted(PAPER_RULES)
    assert len(vector) == len(DESIGN_PARAMETERS)
    np.testing.assert_allclose(
        read_toml(PAPER_RULES).parameter_vector(),
        PaperDesignTunable().system(vector).parameter_vector(),
        rtol=2e-5,  # the header prints 6 significant digits; d_t's centres sum powers of r
    )
    header = PAPER_RULES.read_text(encoding="utf-8").split("[system]")[0]
    assert "Reproduce with" in header and "scripts/paper_readings.py" in header


def test_fit_paper_command_writes_a_design_valid_rule_base_with_its_reproduce_line(
    tmp_path, capsys
):
    out = tmp_path / "trial.toml"
    argv = ["fit-paper", "--maxiter", "1", "--popsize", "2", "--workers", "1", "--out", str(out)]
    assert main(argv + ["--json"]) == 0
    text = out.read_text(encoding="utf-8")
    assert "Reproduce with: fuzzynav fit-paper --maxiter 1 --popsize 2" in text
    faults = violations(read_toml(out))  # what the fit writes keeps the design rules
    assert faults == [], [str(f) for f in faults]
    assert main(["fit-paper", "--dt", "5", "--out", str(tmp_path / "x.toml")]) == 2
    assert main(["fit-paper", "--out", str(tmp_path / "no" / "x.toml")]) == 2


def test_a_husky_only_fit_measures_the_husky_runs_alone(tmp_path):
    """``--husky --husky-only`` (how rules/paper_husky.toml is made): the cost is the
    Husky geometry's hinges alone, so it is the joint cost less the paper geometry's part."""
    from fuzzynav.app.experiments.paper_fit import FitCost

    vector = read_fitted(PAPER_RULES)
    joint = FitCost(0.1, husky=True, husky_perception=("ideal",))
    alone = FitCost(0.1, husky=True, husky_perception=("ideal",), paper_geometry=False)
    paper = FitCost(0.1)
    assert alone.modes() == [("husky", "ideal")]
    assert alone(vector) == pytest.approx(joint(vector) - paper(vector), rel=1e-9, abs=1e-9)
    with pytest.raises(ValueError, match="geometry"):
        FitCost(0.1, paper_geometry=False)
    out = tmp_path / "x.toml"
    assert main(["fit-paper", "--husky-only", "--out", str(out)]) == 2  # needs --husky
    assert not out.exists()
