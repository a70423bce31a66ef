"""The paper's geometry (a point robot, Eqs. 7-12 centre to centre) and ``run --trace``."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzynav.app.cli import main
from fuzzynav.app.recordings.trace import TRACE_COLUMNS
from fuzzynav.app.runs import build_simulation
from fuzzynav.controller.fis import read_fis, write_fis
from fuzzynav.controller.proportional import ProportionalController
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.scenario import ObstacleSpec, Scenario
from fuzzynav.world.simulation import Simulation

HEADER = (
    "time_s,x_m,y_m,heading_rad,d_t_m,d_o_m,phi_t_rad,phi_o_rad,true_d_t_m,true_phi_t_rad,v_left_v"
)


def _scenario(start, heading, target, obstacles, duration_s=40.0):
    return Scenario(
        name="t",
        duration_s=duration_s,
        start=start,
        heading_rad=heading,
        target=target,
        tolerance_m=0.15,
        obstacles=tuple(obstacles),
    )


def _wrap(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


coordinate = st.floats(-5, 5)


@settings(max_examples=60)
@given(
    st.tuples(coordinate, coordinate),
    st.floats(-math.pi, math.pi),
    st.tuples(coordinate, coordinate),
    st.lists(st.tuples(coordinate, coordinate, st.floats(0.05, 0.6)), min_size=1, max_size=4),
)
def test_inputs_are_equations_7_to_12_centre_to_centre(start, heading, target, obstacles):
    specs = [
        ObstacleSpec((x, y), r)
        for x, y, r in obstacles
        if math.dist((x, y), start) > r + 0.01  # the point robot starts outside every disc
    ]
    sim = Simulation(
        _scenario(start, heading, target, specs), ProportionalController(), geometry="paper"
    )
    d_t, d_o, phi_t, phi_o = sim.sense()[0].tolist()
    xr, yr = start
    assert d_t == pytest.approx(math.hypot(target[0] - xr, target[1] - yr), abs=1e-12)  # Eq. 7
    theta_t = math.atan2(target[1] - yr, target[0] - xr)  # Eq. 11 (the quadrant-aware arctan)
    if d_t > 1e-9:
        assert _wrap(phi_t - (theta_t - heading)) == pytest.approx(0.0, abs=1e-12)  # Eq. 10
    centre = [math.hypot(s.position[0] - xr, s.position[1] - yr) for s in specs]  # Eq. 8
    if not specs or min(centre) > 3.0:
        assert math.isnan(d_o) and math.isnan(phi_o)  # beyond the 3 m cutoff: "none"
        return
    k = int(np.argmin(centre))
    assert d_o == pytest.approx(centre[k], abs=1e-12)
    ox, oy = specs[k].position
    theta_o = math.atan2(oy - yr, ox - xr)  # Eq. 12
    assert _wrap(phi_o - (theta_o - heading)) == pytest.approx(0.0, abs=1e-12)  # Eq. 9


def test_the_point_robot_collides_when_its_centre_enters_a_disc():
    # Drive straight at a 0.3 m obstacle 3 m ahead: the contact comes when the centre
    # reaches the disc (not 0.495 m earlier, where the Husky's bumper would touch).
    scenario = _scenario((0.0, 0.0), 0.0, (10.0, 0.0), [ObstacleSpec((3.0, 0.0), 0.3)])
    for geometry, contact_m in (("paper", 0.3), ("husky", 0.3 + 0.495)):
        sim = Simulation(scenario, ProportionalController(), geometry=geometry)
        result = sim.run()
        assert result.outcome == "collided"
        distance = 3.0 - result.log.pose[-1, 0]
        step_m = 0.65 * sim.control_period_s  # one step at top speed
        assert contact_m - step_m <= distance <= contact_m + 1e-3, geometry


def test_paper_geometry_measures_safety_centre_to_centre():
    scenario = _scenario((0.0, 0.0), 0.0, (10.0, 0.0), [ObstacleSpec((3.0, 1.0), 0.2)])
    result = Simulation(scenario, ProportionalController(), geometry="paper").run()
    m = result.metrics
    assert m["geometry"] == "paper" and result.reached
    assert m["min_center_distance_m"] == pytest.approx(1.0, abs=0.02)
    assert m["min_safety_distance_m"] == m["min_center_distance_m"]
    assert m["min_clearance_m"] == pytest.approx(m["min_center_distance_m"] - 0.2, abs=1e-9)
    husky = Simulation(scenario, ProportionalController()).run().metrics
    assert (
        husky["geometry"] == "husky" and husky["min_safety_distance_m"] == husky["min_clearance_m"]
    )


def test_paper_geometry_refuses_range_sensors(capsys):
    with pytest.raises(ValueError, match="ideal"):
        build_simulation("s1", "p", perception="ultrasonic", geometry="paper")
    assert main(["run", "s1", "--geometry", "paper", "--perception", "ultrasonic"]) == 2
    assert "geometry = 'paper'" in capsys.readouterr().err
    assert main(["run", "s1", "--geometry", "round"]) == 2


def test_both_geometries_start_s1_at_the_scenarios_heading():
    """One start for both robots (a reading of the text, not a fitted number)."""
    paper = build_simulation("s1", "p", geometry="paper")
    husky = build_simulation("s1", "p")
    assert paper.arena.pose[2] == husky.arena.pose[2] == paper.scenario.heading_rad


def _read_trace(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


def test_trace_columns_rows_and_empty_cells(tmp_path, capsys):
    path = tmp_path / "s2.csv"
    assert main(["run", "s2", "--controller", "p", "--trace", str(path), "--json"]) == 0
    text = path.read_text(encoding="utf-8")
    assert text.startswith(HEADER)
    rows = _read_trace(path)
    assert tuple(rows[0]) == TRACE_COLUMNS
    body = rows[1:]
    steps = __import__("json").loads(capsys.readouterr().out)["steps"]
    assert len(body) == steps + 1  # one row per control step, and the final state
    col = {name: i for i, name in enumerate(rows[0])}
    assert body[-1][col["v_left_v"]] == "" and body[-1][col["v_right_v"]] == ""
    assert all(r[col["v_left_v"]] != "" for r in body[:-1])
    # At the start the moving obstacle (at the target) is 11.3 m away: nothing detected.
    assert body[0][col["d_o_m"]] == "" and body[0][col["phi_o_rad"]] == ""
    assert float(body[1][col["time_s"]]) == pytest.approx(0.02)
    applied = np.array([[float(r[col["v_left_v"]]), float(r[col["v_right_v"]])] for r in body[:-1]])
    assert np.abs(applied).max() <= 12.0


def test_trace_holds_the_disturbed_inputs_the_controller_received(tmp_path):
    path = tmp_path / "s3.csv"
    assert main(["run", "s3", "--controller", "p", "--trace", str(path)]) == 0
    rows = _read_trace(path)
    col = {name: i for i, name in enumerate(rows[0])}
    for r in rows[1:]:
        t, disturbance = float(r[col["time_s"]]), float(r[col["disturbance_m_or_rad"]])
        x, y, heading = (float(r[col[k]]) for k in ("x_m", "y_m", "heading_rad"))
        d_t = math.hypot(8.0 - x, 8.0 - y) + disturbance
        assert float(r[col["d_t_m"]]) == pytest.approx(d_t, abs=1e-9)
        expected = 1.0 * math.sin(2.0 * t) if 25.0 <= t < 35.0 else 0.0
        assert disturbance == pytest.approx(expected, abs=1e-12)


def test_trace_to_a_missing_folder_is_refused_before_the_run(tmp_path, capsys):
    assert main(["run", "s1", "--trace", str(tmp_path / "no" / "t.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.parametrize("geometry", ["paper", "husky"])
def test_logged_voltages_are_the_rule_base_at_the_logged_inputs(tmp_path, geometry, capsys):
    """The trace's voltages are what the shipped rule base gives at the trace's inputs,
    checked through an independent evaluator (simpful) on a sample of the steps. The
    rule base reads NONE for d_o as the text has it, which a .fis cannot say, so ``fis
    export`` refuses it with a sentence; the two systems that reading splits into (rules
    26-40 while an obstacle is sensed, all 40 while none is) are MATLAB systems, and
    each goes through a .fis to simpful."""
    pytest.importorskip("simpful")
    from fuzzynav.controller.paper import RULES_BY_GEOMETRY

    shipped = read_toml(RULES_BY_GEOMETRY[geometry])
    exported = main(["fis", "export", str(tmp_path / "paper.fis"), "--geometry", geometry])
    if shipped.unsensed_none:  # the text's NONE: refused, nothing written
        assert exported == 2 and "a .fis cannot say" in capsys.readouterr().err
        assert not (tmp_path / "paper.fis").exists()
    else:  # MATLAB's NONE (the twin): exported, and the same system
        assert exported == 0 and read_fis(tmp_path / "paper.fis") == shipped
    trace = tmp_path / "s2.csv"
    assert main(["run", "s2", "--geometry", geometry, "--trace", str(trace)]) == 0
    rows = _read_trace(trace)
    col = {name: i for i, name in enumerate(rows[0])}
    body = rows[1:-1]
    inputs = np.array(
        [
            [
                float(r[col[k]]) if r[col[k]] else math.nan
                for k in ("d_t_m", "d_o_m", "phi_t_rad", "phi_o_rad")
            ]
            for r in body
        ]
    )
    ours = np.array(
        [[float(r[col[k]]) for k in ("controller_left_v", "controller_right_v")] for r in body]
    )
    np.testing.assert_allclose(shipped.evaluate(inputs), ours, atol=1e-9)
    applied = np.array([[float(r[col["v_left_v"]]), float(r[col["v_right_v"]])] for r in body])
    np.testing.assert_allclose(np.clip(ours, -12, 12), applied, atol=1e-9)
    # The same rows through simpful, an evaluator that shares no code with ours, each
    # row through the MATLAB system its reading of NONE picks (written as .fis and read).
    from test_fuzzy_engine import build_simpful, simpful_eval

    split = {}
    for sensed in (False, True):
        matlab = shipped.gated_system([sensed])[0]
        path = tmp_path / f"sensed_{sensed}.fis"
        write_fis(matlab, path)
        system = read_fis(path)
        split[sensed] = (system, build_simpful(system))
    sensed_rows = ~np.isnan(inputs[:, 1])
    assert sensed_rows.any() and (~sensed_rows).any()
    for k in np.linspace(0, len(body) - 1, 25).astype(int):
        system, oracle = split[bool(sensed_rows[k])]
        want = simpful_eval(system, *oracle, inputs[k])
        np.testing.assert_allclose(want, ours[k], atol=1e-9)
