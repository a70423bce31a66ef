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
from fuzzynav.controller.paper import RULES_BY_GEOMETRY
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.geometry import point_segment_distance
from fuzzynav.world.scenario import load_scenario

# The Husky geometry's rule base is still the earlier tuning (27-number layout) with
# holes and chatter: a retune under the partition layout did not keep s1-s3 reached and
# safe in ultrasonic perception in the time this session had (docs/paper-controller.md).
# These marks say so and fail (strict) once a retuned rules/paper.toml passes.
HUSKY_NOT_YET = pytest.mark.xfail(
    strict=True,
    reason="not yet met: the Husky-geometry rules/paper.toml is the earlier tuning, with "
    "holes (phi_t 0.345-0.44 rad, phi_o beyond +-1.27 rad) and chatter (188-266 jumps)",
)
RULE_BASES = [
    pytest.param(geometry, path, marks=HUSKY_NOT_YET if geometry == "husky" else ())
    for geometry, path in sorted(RULES_BY_GEOMETRY.items())
]
TARGET_RULES = slice(0, 25)  # Table 1: rules 1-25 take d_t and phi_t
OBSTACLE_RULES = slice(25, 40)  # rules 26-40 take d_o and phi_o
MIN_STRONGEST = 0.1
MAX_JUMPS = 20


def _variable(system, name):
    return next(v for v in system.inputs if v.name == name)


@pytest.mark.parametrize(("geometry", "path"), RULE_BASES)
def test_some_target_rule_fires_clearly_everywhere(geometry, path):
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


@pytest.mark.parametrize(("geometry", "path"), RULE_BASES)
def test_some_obstacle_rule_fires_clearly_whenever_an_obstacle_is_sensed(geometry, path):
    system = read_toml(path)
    d_o = np.linspace(*_variable(system, "d_o").range, 301)
    phi_o = np.linspace(*_variable(system, "phi_o").range, 601)
    grid = np.array([(5.0, a, 0.0, b) for a in d_o for b in phi_o])
    strongest = system.firing_strengths(grid)[:, OBSTACLE_RULES].max(axis=1)
    worst = int(np.argmin(strongest))
    assert strongest[worst] >= MIN_STRONGEST, (
        f"{path.name}: at d_o = {grid[worst, 1]:.3f} m, phi_o = {grid[worst, 3]:.3f} rad "
        f"the strongest obstacle rule fires at {strongest[worst]:.4f}"
    )


@pytest.mark.parametrize("geometry", ["paper", pytest.param("husky", marks=HUSKY_NOT_YET)])
@pytest.mark.parametrize("scenario", ["s1", "s2", "s3"])
def test_voltages_do_not_chatter(scenario, geometry):
    """At most 20 control steps per run where a wheel jumps by more than 2 V (outside
    s3's 25-35 s disturbance, where the paper's own voltages are noisy)."""
    result = run_scenario(scenario, "paper", perception="ideal", geometry=geometry)
    assert result.reached
    assert result.metrics["voltage_jumps"] <= MAX_JUMPS


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
    assert abs(t["phi_t"][-1]) < 0.35
