"""Metrics against hand-computed answers (paper Eq. 15-17)."""

import math

import numpy as np
import pytest

from fuzzynav.world.metrics import deviation_from_line, path_length


def test_path_length_of_a_square_walk():
    xy = np.array([[0, 0], [3, 0], [3, 4], [0, 4]], dtype=float)
    assert path_length(xy) == pytest.approx(10.0)


def test_mad_and_rmse_against_the_start_target_segment():
    # Points at known perpendicular distances 0, 1, 2 and 1 from the diagonal y = x.
    start, target = (0.0, 0.0), (8.0, 8.0)
    s2 = math.sqrt(2.0)
    xy = np.array([[0, 0], [1 + 1 / s2, 1 - 1 / s2], [4 - s2, 4 + s2], [6 + 1 / s2, 6 - 1 / s2]])
    mad, rmse = deviation_from_line(xy, start, target)
    assert mad == pytest.approx(1.0)
    assert rmse == pytest.approx(math.sqrt((0 + 1 + 4 + 1) / 4))


def test_points_beyond_the_ends_measure_to_the_endpoint():
    mad, _ = deviation_from_line(np.array([[-3.0, -4.0]]), (0.0, 0.0), (8.0, 8.0))
    assert mad == pytest.approx(5.0)


def test_metrics_of_a_run_interrupted_before_its_first_step():
    from fuzzynav.controller.proportional import ProportionalController
    from fuzzynav.world.scenario import load_scenario
    from fuzzynav.world.simulation import Simulation

    result = Simulation(load_scenario("s1"), ProportionalController()).result()
    assert result.metrics["steps"] == 0 and result.metrics["reached"] is False
    assert result.metrics["mad_m"] is None
