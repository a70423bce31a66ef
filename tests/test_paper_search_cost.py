"""The Husky twin's bounds-first cost (scripts/paper_search.py --bounds-first), how
rules/paper_husky.toml was fitted: the twin's bounds counted first, each residual
uncapped beyond, chatter counted, a forced bound ten times."""

from __future__ import annotations

from pathlib import Path

import pytest
from load_file import load_file

from fuzzynav.app.published import paper_results

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def search():
    return load_file(ROOT / "scripts" / "paper_search.py")


def _run(**changes) -> dict:
    run = {
        "scenario": "s1",
        "reached": True,
        "collided": False,
        "closest_to_target_m": 0.0,
        "min_clearance_m": 0.6,
        "path_length_m": 11.0,
        "mad_m": 0.4,  # the bound: 0.731 m, twice the paper's s1 MAD
        "final_phi_t_rad": 0.01,
        "chatter_steps": 0,
        "pass_clearances_m": [0.5, 0.6, 0.4],  # the bound: their median at most 0.7 m
        "largest_line_offset_m": 0.8,  # at most 1.2 m
        "max_voltage_v": (10.0, 9.5),  # at least 9 V
        "approach_speed_ratio": 0.9,  # at least 0.5
    }
    return run | changes


def test_a_run_within_every_bound_costs_nothing(search):
    assert search.twin_bounds_cost(_run(), paper_results()) == 0.0


def test_each_bound_missed_costs_more_than_any_residual_within_them(search):
    paper = paper_results()
    near = search.twin_bounds_cost(_run(mad_m=0.72), paper)  # within, past the margin
    missed = search.twin_bounds_cost(_run(mad_m=0.74), paper)
    assert 0.0 < near < 10.0 and missed > 1000.0
    two = search.twin_bounds_cost(_run(mad_m=0.74, min_clearance_m=0.2), paper)
    assert two > missed + 1000.0


def test_residuals_past_a_bound_keep_pulling_and_chatter_counts(search):
    """paper_fit.husky_cost caps each hinge: past the cap a worse residual cost the same."""
    paper = paper_results()
    costs = [search.twin_bounds_cost(_run(mad_m=m), paper) for m in (1.0, 1.4, 2.0)]
    assert costs[0] < costs[1] < costs[2]
    calm = search.twin_bounds_cost(_run(mad_m=1.4, chatter_steps=2), paper)
    jumpy = search.twin_bounds_cost(_run(mad_m=1.4, chatter_steps=30), paper)
    assert jumpy > calm + 1000.0  # the chatter bound missed, and 10 per jump past two


def test_a_forced_bound_weighs_ten_times(search):
    paper = paper_results()
    base = search.twin_bounds_cost(_run(mad_m=1.4), paper) - 1000.0
    forced = search.twin_bounds_cost(_run(mad_m=1.4), paper, forced=("mad",)) - 1000.0
    assert forced == pytest.approx(10.0 * base)


def test_a_run_not_reached_misses_all_ten(search):
    lost = search.twin_bounds_cost(_run(reached=False, closest_to_target_m=2.0), paper_results())
    assert lost == pytest.approx(10000.0 + 20.0)


def test_each_driving_bound_missed_counts(search):
    paper = paper_results()
    for changes in (
        {"pass_clearances_m": [1.2, 0.9, 0.8]},
        {"largest_line_offset_m": 1.5},
        {"max_voltage_v": (6.0, 5.0)},
        {"approach_speed_ratio": 0.3},
    ):
        assert search.twin_bounds_cost(_run(**changes), paper) > 1000.0, changes


def test_force_twin_names_are_checked(search, capsys):
    for bad in ("ideal.s9.mad", "ideal.s1.speed", "sideways.s1.mad"):
        with pytest.raises(SystemExit) as caught:
            search.main(["--heading", "0", "--bounds-first", "--force-twin", bad])
        assert caught.value.code == 2
        assert "--force-twin" in capsys.readouterr().err
    with pytest.raises(SystemExit) as caught:  # forcing needs the bounds-first cost
        search.main(["--heading", "0", "--force-twin", "ideal.s1.mad"])
    assert caught.value.code == 2
