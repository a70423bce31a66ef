"""The shipped paper rule bases behave like the paper's controller: no holes (some rule
always fires clearly, so MATLAB's no-rule fallback never acts), no chattering voltages,
and, in the paper's geometry, the paper's Table 4 and events within the issue's bounds,
recomputed from ``run --trace`` rather than taken from our own metrics."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.paper_fit import paper_results
from fuzzynav.app.runs import run_scenario
from fuzzynav.controller.coverage import MIN_STRONGEST, weakest_cover
from fuzzynav.controller.paper import RULES_BY_GEOMETRY
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.geometry import point_segment_distance
from fuzzynav.world.scenario import load_scenario

# The Husky geometry's rule base covers the obstacle inputs only ahead of its axle line
# and a little more (|phi_o| <= 1.75 rad): an obstacle behind fires no obstacle rule.
# Covering the rear too (Table 1's "VP -> go straight" firing at >= 0.1 behind) makes
# s1-s3 orbit the target in ideal perception (docs/paper-controller.md gives the
# numbers), so that one bound is not met in the Husky geometry, and says so.
HUSKY_REAR = pytest.mark.xfail(
    strict=True,
    reason="not met in the Husky geometry: behind the axle line (|phi_o| > 1.75 rad) no "
    "obstacle rule fires; with the rear covered s1-s3 orbit in ideal perception",
)
RULE_BASES = sorted(RULES_BY_GEOMETRY.items())
FRONT_HALF_PLANE_RAD = math.pi / 2
TARGET_RULES = slice(0, 25)  # Table 1: rules 1-25 take d_t and phi_t
OBSTACLE_RULES = slice(25, 40)  # rules 26-40 take d_o and phi_o
MAX_JUMPS = 20


def _variable(system, name):
    return next(v for v in system.inputs if v.name == name)


@pytest.mark.parametrize(("geometry", "path"), RULE_BASES)
def test_some_target_rule_fires_clearly_everywhere(geometry, path):
    """So the no-rule fallback never acts: a target rule fires clearly at every input."""
    system = read_toml(path)
    d_t = np.linspace(*_variable(system, "d_t").range, 301)
    phi_t = np.linspace(*_variable(system, "phi_t").range, 601)
    grid = np.array([(a, math.nan, b, math.nan) for a in d_t for b in phi_t])
    strongest = system.firing_strengths(grid)[:, TARGET_RULES].max(axis=1)
    worst = int(np.argmin(strongest))
    assert strongest[worst] >= MIN_STRONGEST, (
        f"{path.name}: at d_t = {grid[worst, 0]:.3f} m, phi_t = {grid[worst, 2]:.3f} rad "
        f"the strongest rule fires at {strongest[worst]:.4f}"
    )


def _assert_obstacle_rules_cover(path, max_angle_rad=math.inf):
    """Some obstacle rule fires at >= 0.1 on a 301 x 601 (d_o, phi_o) grid, the target
    5 m ahead, within |phi_o| <= max_angle_rad (a grid of its own, not coverage.py's)."""
    system = read_toml(path)
    d_o = np.linspace(*_variable(system, "d_o").range, 301)
    phi_o = np.linspace(*_variable(system, "phi_o").range, 601)
    grid = np.array([(5.0, a, 0.0, b) for a in d_o for b in phi_o if abs(b) <= max_angle_rad])
    strongest = system.firing_strengths(grid)[:, OBSTACLE_RULES].max(axis=1)
    worst = int(np.argmin(strongest))
    assert strongest[worst] >= MIN_STRONGEST, (
        f"{path.name}: at d_o = {grid[worst, 1]:.3f} m, phi_o = {grid[worst, 3]:.3f} rad "
        f"the strongest obstacle rule fires at {strongest[worst]:.4f}"
    )


@pytest.mark.parametrize(
    ("geometry", "path"),
    [pytest.param(g, p, marks=HUSKY_REAR if g == "husky" else ()) for g, p in RULE_BASES],
)
def test_some_obstacle_rule_fires_clearly_whenever_an_obstacle_is_sensed(geometry, path):
    _assert_obstacle_rules_cover(path)


@pytest.mark.parametrize(("geometry", "path"), RULE_BASES)
def test_some_obstacle_rule_fires_clearly_for_every_obstacle_ahead_of_the_axle(geometry, path):
    """What the Husky rule base does meet: every obstacle in the front half-plane
    (|phi_o| <= pi/2, which holds the sonars' beams) fires an obstacle rule clearly."""
    _assert_obstacle_rules_cover(path, FRONT_HALF_PLANE_RAD)


@pytest.mark.parametrize(("geometry", "path"), RULE_BASES)
def test_no_hole_hides_between_the_grid_points(geometry, path):
    """The grids above step 0.02 rad; two steep terms can cross below 0.1 between two
    points. Table 1 has a rule for every pair of terms, so the strongest rule is the
    smaller of the two inputs' largest memberships, which controller/coverage.py
    samples finely round every dip."""
    system = read_toml(path)
    assert weakest_cover(system, "target") >= MIN_STRONGEST
    assert weakest_cover(system, "obstacle", max_angle_rad=FRONT_HALF_PLANE_RAD) >= MIN_STRONGEST


@pytest.mark.parametrize("geometry", ["paper", "husky"])
@pytest.mark.parametrize("scenario", ["s1", "s2", "s3"])
def test_voltages_do_not_chatter_and_some_rule_always_fires(scenario, geometry):
    """At most 20 control steps per run where a wheel jumps by more than 2 V (outside
    s3's 25-35 s disturbance, where the paper's own voltages are noisy), and at every
    logged step the strongest rule fires at >= 0.1: the fallback never drove."""
    result = run_scenario(scenario, "paper", perception="ideal", geometry=geometry)
    assert result.reached
    assert result.metrics["voltage_jumps"] <= MAX_JUMPS
    system = read_toml(RULES_BY_GEOMETRY[geometry])
    strongest = system.firing_strengths(result.log.inputs[:-1]).max(axis=1)
    assert strongest.min() >= MIN_STRONGEST


@pytest.mark.parametrize("scenario", ["s1", "s2", "s3"])
@pytest.mark.parametrize("perception", ["ideal", "ultrasonic"])
def test_husky_geometry_reaches_safely_and_short(scenario, perception):
    m = run_scenario(scenario, "paper", perception=perception).metrics
    assert m["reached"] and not m["collided"]
    assert m["min_clearance_m"] >= 0.25
    assert m["path_length_m"] <= 13.0


def _trace(tmp_path, scenario):
    path = tmp_path / f"{scenario}.csv"
    assert main(["run", scenario, "--geometry", "paper", "--trace", str(path)]) == 0
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) if r[k] else math.nan for r in rows]) for k in rows[0]}


# The "done" bounds (its aim is tighter: path 2 %, the rest 10 %).
DONE_PATH = 0.03
DONE_OTHER = 0.25


@pytest.mark.parametrize("scenario", ["s1", "s2", "s3"])
def test_paper_geometry_reproduces_table4_from_the_trace(tmp_path, scenario):
    paper = paper_results()
    t = _trace(tmp_path, scenario)
    sc = load_scenario(scenario)
    xy = np.column_stack([t["x_m"], t["y_m"]])
    assert math.hypot(*(xy[-1] - np.array(sc.target))) <= sc.tolerance_m  # reached
    path_m = float(np.hypot(*np.diff(xy, axis=0).T).sum())  # Eq. 15
    d = point_segment_distance(xy, sc.start, sc.target)
    mad, rmse = float(np.mean(np.abs(d))), float(np.sqrt(np.mean(d**2)))  # Eqs. 16-17
    centres = []  # every obstacle's centre over time, by its law (Eqs. 13-14)
    for o in sc.obstacles:
        a = np.asarray(o.acceleration)[None, :]
        v = np.asarray(o.velocity)[None, :]
        centres.append(
            np.asarray(o.position)[None, :]
            + v * t["time_s"][:, None]
            + 0.5 * a * t["time_s"][:, None] ** 2
        )
    distances = np.stack([np.hypot(*(xy - c).T) for c in centres], axis=1)
    table = paper["table4"][scenario]
    measured = {
        "path_length_m": path_m,
        "mad_m": mad,
        "rmse_m": rmse,
        "min_center_distance_m": float(distances.min()),
    }
    for key, want in table.items():
        bound = DONE_PATH if key == "path_length_m" else DONE_OTHER
        assert abs(measured[key] / want - 1) <= bound, (key, measured[key], want)
    for event in paper["events"].get(scenario, []):
        if "time_s" in event:
            k = int(np.argmin(distances[:, event["obstacle"]]))
            assert abs(t["time_s"][k] / event["time_s"] - 1) <= DONE_OTHER, (event, t["time_s"][k])
    # "After several oscillations, it finally reaches zero": the target ends up ahead.
    assert abs(t["phi_t_rad"][-1]) < 0.35
