"""controller/coverage.py: where no rule of a family fires clearly (a hole)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.controller.coverage import (
    FAMILIES,
    coverage_shortfall,
    family_rules,
    grid,
    strongest_rules,
    weakest_cover,
)
from fuzzynav.controller.paper import PaperTunable
from fuzzynav.controller.paper_partition import PaperPartitionTunable


def _holed():
    """The 27-number layout with phi_t's Z ending at 0.1 rad and P starting at 0.4 rad."""
    t = PaperTunable()
    names, v = t.parameter_names(), t.initial_vector()
    for name, value in (("phi_t.zero", 0.1), ("phi_t.peak", 0.5), ("phi_t.foot", 0.8)):
        v[names.index(name)] = value
    return t.system(v)


def test_the_families_are_table_ones_target_and_obstacle_rules():
    system = PaperPartitionTunable().system(PaperPartitionTunable().initial_vector())
    assert family_rules(system, "target").tolist() == list(range(25))
    assert family_rules(system, "obstacle").tolist() == list(range(25, 40))


def test_a_partition_layout_has_no_hole():
    t = PaperPartitionTunable()
    rng = np.random.default_rng(0)
    lo, hi = np.array(t.bounds()).T
    for _ in range(5):
        system = t.system(lo + rng.random(len(lo)) * (hi - lo))
        assert coverage_shortfall(system) == 0.0
        for family in FAMILIES:
            assert strongest_rules(system, family, 51, 101)[1].min() >= 0.5 - 1e-12


def test_a_hole_is_found_where_it_is_and_costs():
    system = _holed()
    points, strongest = strongest_rules(system, "target", 31, 1201)
    in_gap = (np.abs(points[:, 2]) > 0.1) & (np.abs(points[:, 2]) < 0.4)
    assert strongest[in_gap].max() == 0.0  # no target rule at all between Z and P
    assert strongest[~in_gap].min() > 0.0
    assert coverage_shortfall(system) > 0.1


def test_the_obstacle_sector_leaves_the_rear_out():
    system = _holed()
    points = grid(system, "obstacle", 11, 101, max_angle_rad=math.pi / 2)
    assert np.abs(points[:, 3]).max() <= math.pi / 2
    assert np.all(points[:, 0] == 5.0) and np.all(points[:, 2] == 0.0)
    assert len(points) < len(grid(system, "obstacle", 11, 101))


def test_a_rule_base_without_the_family_is_refused():
    system = _holed()
    with pytest.raises(ValueError, match="no rule reads"):
        strongest_rules(system.with_rules(system.rules[:25]), "obstacle", 5, 5)


def test_the_envelope_finds_a_crossing_a_grid_steps_over():
    """Z = trimf(-z, 0, z) and P = trimf(f p, p, p + w) cross at a height a 601-point
    grid over +-2 pi misses; the envelopes find it to 1e-4."""
    t = PaperTunable()
    names, v = t.parameter_names(), t.initial_vector()
    z, p, f = 0.48, 0.53, 0.80
    for name, value in (("phi_t.zero", z), ("phi_t.peak", p), ("phi_t.foot", f)):
        v[names.index(name)] = value
    system = t.system(v)
    # 1 - x / z = (x - f p) / (p - f p)  at the crossing
    slope = 1.0 / (p - f * p)
    x = (1.0 + slope * f * p) / (1.0 / z + slope)
    crossing = 1.0 - x / z
    assert weakest_cover(system, "target") == pytest.approx(min(crossing, 1.0), abs=1e-4)
    grid_min = strongest_rules(system, "target")[1].min()
    assert grid_min > crossing + 0.01  # the grid alone would have passed it
