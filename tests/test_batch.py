"""The lockstep batch engine (world/batch.py) against the pymunk engine, its fuzzy
evaluation with per-row parameter sets, and its place in the commands (issue 29).

The cross-check here runs a slice of the issue's 500 layouts that fits the suite's time
budget (every family, both perception modes, the paper, baseline and p controllers, and
the paper's point robot); ``bench/bench_batch.py --crosscheck 500`` runs the full set
with the same checks (docs/speed.md has its numbers).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.experiments.batch_runs import run_layout_batch, run_layouts, tasks
from fuzzynav.app.experiments.executor import LocalExecutor, SerialExecutor
from fuzzynav.app.experiments.resultlog import ResultLog
from fuzzynav.app.experiments.studies import run_jobs, run_layout, sweep_jobs
from fuzzynav.app.runs import build_simulation
from fuzzynav.controller.batch import NotBatchable, batch_controller
from fuzzynav.controller.fuzzy_batch import BatchFuzzy, evaluate_rows
from fuzzynav.controller.paper import PaperTunable
from fuzzynav.controller.registry import make_controller
from fuzzynav.world.batch import OUTCOMES, run_batch
from fuzzynav.world.layouts import FAMILIES, generate_layout

# ---------------------------------------------------------------- fuzzy, per-row sets


def _candidates(k: int, seed: int = 0) -> tuple[PaperTunable, np.ndarray]:
    tunable = PaperTunable()
    low, high = np.array(tunable.bounds()).T
    rng = np.random.default_rng(seed)
    return tunable, low + (high - low) * rng.random((k, len(low)))


def _rows(n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = np.column_stack(
        [
            rng.uniform(-1.0, 14.0, n),
            np.where(rng.random(n) < 0.3, np.nan, rng.uniform(0.0, 3.5, n)),
            rng.uniform(-7.0, 7.0, n),
            np.where(rng.random(n) < 0.3, np.nan, rng.uniform(-4.0, 4.0, n)),
        ]
    )
    X[:5, 1] = X[:5, 3] = np.nan  # only the target rules
    return X


def test_batch_fuzzy_equals_evaluate_row_by_row_with_a_parameter_set_per_row():
    tunable, vectors = _candidates(24)
    systems = [tunable.system(v) for v in vectors]
    X = _rows(600)
    groups = np.arange(600) % 24
    got = BatchFuzzy(systems).evaluate(X, groups)
    want = np.array([systems[g].evaluate_one(x) for x, g in zip(X, groups)])
    assert np.abs(got - want).max() <= 1e-12
    assert np.array_equal(got, want)  # in fact bit for bit (the same sums in grid order)
    alone = BatchFuzzy(systems).evaluate(X[5:6], groups[5:6])  # one row: the cumsum path
    assert np.array_equal(alone[0], want[5])
    # the outputs really differ between the sets (a shared set would pass the above too)
    same_inputs = np.repeat(X[7:8], 24, axis=0)
    spread = BatchFuzzy(systems).evaluate(same_inputs, np.arange(24))
    assert np.ptp(spread[:, 0]) > 0.5


def test_evaluate_rows_takes_one_parameter_vector_per_row():
    tunable, vectors = _candidates(3, seed=4)
    systems = [tunable.system(v) for v in vectors]
    base = systems[0]
    X = _rows(50, seed=2)
    params = np.array([systems[i % 3].parameter_vector() for i in range(50)])
    got = evaluate_rows(base, X, params)
    want = np.array([systems[i % 3].evaluate_one(x) for i, x in enumerate(X)])
    assert np.abs(got - want).max() <= 1e-12
    with pytest.raises(ValueError, match=r"parameters has shape \(2, "):
        evaluate_rows(base, X, params[:2])


def test_one_parameter_set_is_evaluate_bit_for_bit_and_bad_batches_are_refused():
    system = make_controller("paper").fis
    X = _rows(300, seed=3)
    assert np.array_equal(BatchFuzzy([system]).evaluate(X), system.evaluate(X))
    other = make_controller("baseline").goal
    with pytest.raises(ValueError, match=r"systems\[1\] .* another structure"):
        BatchFuzzy([system, other])
    with pytest.raises(ValueError, match="every entry must be from 0 to 0"):
        BatchFuzzy([system]).evaluate(X[:3], [0, 1, 0])


# ---------------------------------------------------------------- the cross-check

#: Layouts per (family, perception, controller) in the suite's slice: 5 families x
#: (2 perceptions x 3 controllers + the paper's point robot) x 2 = 70 runs, their
#: durations capped at CAP_S and a control period of PERIOD_S (the same scenarios and
#: period on both engines; bench/bench_batch.py --crosscheck runs the default 20 ms
#: and the full durations), about 10 s of pymunk on one idle core.
PER_CELL = 2
CAP_S = 60.0
PERIOD_S = 0.05
COMBOS = [
    (perception, controller, "husky")
    for perception in ("ideal", "ultrasonic")
    for controller in ("paper", "baseline", "p")
] + [("ideal", "paper", "paper")]


def _layouts(family: str, first: int, n: int, geometry: str):
    """Every other layout with s1-s3's front half-plane as its field of view."""
    out = []
    for i in range(first, first + n):
        sc = generate_layout(family, 7, i)
        field = 180.0 if i % 2 else sc.field_of_view_deg
        out.append(sc.replace(duration_s=min(sc.duration_s, CAP_S), field_of_view_deg=field))
    return out


def _explained(reference, batch_metrics, scenario) -> bool:
    """A differing outcome is explained when a threshold (target tolerance, contact at
    clearance 0) was met within 1e-9 by one engine and not the other."""
    final = reference.log.pose[-1, :2]
    to_target = math.dist(final, scenario.target) - scenario.tolerance_m
    clearance = reference.metrics["min_clearance_m"]
    return abs(to_target) <= 1e-9 or (clearance is not None and abs(clearance) <= 1e-9)


@pytest.fixture(scope="module")
def crosscheck():
    """(perception, controller, geometry, scenarios, pymunk results, batch result)."""
    cells = []
    for perception, controller, geometry in COMBOS:
        scenarios = []
        for k, family in enumerate(FAMILIES):
            scenarios += _layouts(family, 3 * k, PER_CELL, geometry)
        reference = [
            build_simulation(
                sc,
                controller,
                perception=perception,
                seed=7,
                geometry=geometry,
                control_period_s=PERIOD_S,
            ).run()
            for sc in scenarios
        ]
        batch = run_batch(
            scenarios,
            batch_controller(make_controller(controller, geometry=geometry)),
            perception=perception,
            geometry=geometry,
            seeds=7,
            control_period_s=PERIOD_S,
            record_poses=perception == "ideal",
        )
        cells.append((perception, controller, geometry, scenarios, reference, batch))
    return cells


def test_batch_and_pymunk_agree_on_outcomes_metrics_and_trajectories(crosscheck):
    runs = agree = 0
    outcomes = set()
    for perception, controller, geometry, scenarios, reference, batch in crosscheck:
        for i, (sc, ref) in enumerate(zip(scenarios, reference)):
            runs += 1
            mine = batch.metrics(i)
            outcomes.add(ref.outcome)
            same = (mine["outcome"], mine["collided"]) == (ref.outcome, ref.metrics["collided"])
            agree += same
            label = f"{perception} {controller} {geometry} {sc.name}"
            if not same:
                assert _explained(ref, mine, sc), f"{label}: {ref.outcome} vs {mine['outcome']}"
                continue
            for key in (
                "path_length_m",
                "mad_m",
                "rmse_m",
                "min_center_distance_m",
                "min_clearance_m",
                "min_safety_distance_m",
                "max_abs_voltage_v",
                "time_to_target_s",
                "sim_time_s",
            ):
                want, got = ref.metrics[key], mine[key]
                assert (want is None) == (got is None), f"{label}: {key} {want} vs {got}"
                if want is not None:
                    assert abs(want - got) <= 1e-6, f"{label}: {key} {want} vs {got}"
            assert mine["steps"] == ref.metrics["steps"], label
            assert mine["voltage_jumps"] == ref.metrics["voltage_jumps"], label
            if perception == "ideal":
                poses = batch.poses[i]
                assert poses.shape == ref.log.pose.shape, label
                assert np.abs(poses[:, :2] - ref.log.pose[:, :2]).max() <= 1e-9, label
    assert runs == len(COMBOS) * len(FAMILIES) * PER_CELL
    assert agree / runs >= 0.995
    # the slice exercises every ending
    assert outcomes == set(OUTCOMES)


# ---------------------------------------------------------------- rows, resume, executors

FAST = {"control_period_s": 0.1}


def test_a_run_gives_the_same_row_bits_in_any_batch():
    # 20 runs: more than FuzzySystem.evaluate's row-by-row limit (16), so the batch
    # takes the block path and the small batches the row-by-row one
    jobs = sweep_jobs("paper", 20, 3, "standard", "ultrasonic", options=FAST)
    together = run_layout_batch(jobs)
    assert run_layout_batch(jobs[2:5]) == together[2:5]
    assert run_layout_batch(jobs[6:7]) == together[6:7]
    # and the pymunk engine's row of the same job to the tolerance
    reference = run_layout(jobs[4])
    for key, value in reference.items():
        if isinstance(value, float):
            assert abs(value - together[4][key]) <= 1e-6, key
        else:
            assert value == together[4][key], key


def test_resume_on_a_pool_gives_the_rows_of_one_serial_run(tmp_path):
    jobs = sweep_jobs("p", 12, 2, "two_moving", options=FAST)
    whole = run_jobs(jobs, SerialExecutor(), engine="batch")
    path = tmp_path / "runs.jsonl"
    with ResultLog(path, resume=False, key=_key) as log:
        run_jobs(jobs[:5], SerialExecutor(), log=log, engine="batch")
    with ResultLog(path, resume=True, key=_key) as log, LocalExecutor(2) as pool:
        resumed = run_jobs(jobs, pool, log=log, engine="batch")
    assert resumed == whole
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert sorted(r["index"] for r in lines) == list(range(12))  # none twice


def _key(row):
    from fuzzynav.app.experiments.rows import row_key

    return row_key(row)


def test_dask_runs_batches_as_tasks():
    pytest.importorskip("distributed")
    from fuzzynav.app.experiments.executor import DaskExecutor

    jobs = sweep_jobs("baseline", 6, 4, "clutter", options=FAST)
    serial = run_jobs(jobs, SerialExecutor(), engine="batch")
    with DaskExecutor(2) as executor:
        assert run_jobs(jobs, executor, engine="batch") == serial


def test_tasks_cut_studies_into_batches_and_send_the_rest_to_pymunk():
    jobs = sweep_jobs("paper", 250, 1) + sweep_jobs("fuzzynav", 3, 1)
    items, fallbacks = tasks(jobs, workers=2)
    batches = [payload for kind, payload in items if kind == "batch"]
    sizes = [len(b) for b in batches]
    assert sum(sizes) == 250 and len(sizes) == 3 and max(sizes) - min(sizes) <= 2
    assert [kind for kind, _ in items].count("pymunk") == 3
    assert len(fallbacks) == 1 and "'fuzzynav' cannot be batched" in fallbacks[0]


# ---------------------------------------------------------------- refusals and the CLI


def test_controllers_that_cannot_be_batched_are_refused_with_the_reason():
    with pytest.raises(NotBatchable, match="'fuzzynav' .* cannot run on the batch engine"):
        batch_controller(make_controller("fuzzynav"))

    class Mine:
        def reset(self):
            pass

        def __call__(self, inputs):
            return np.zeros(2)

    with pytest.raises(NotBatchable, match="declares no batched"):
        batch_controller(Mine())
    with pytest.raises(NotBatchable, match="several kinds"):
        batch_controller([make_controller("paper"), make_controller("p")])


def test_run_batch_refuses_bad_input_by_name():
    sc = [generate_layout("standard", 1, 0)]
    ctrl = batch_controller(make_controller("p"))
    with pytest.raises(ValueError, match="control_period_s = 0.0"):
        run_batch(sc, ctrl, control_period_s=0.0)
    with pytest.raises(ValueError, match="geometry = 'paper'"):
        run_batch(sc, ctrl, perception="ultrasonic", geometry="paper")
    with pytest.raises(ValueError, match="seeds has 2 entries for 1 scenarios"):
        run_batch(sc, ctrl, seeds=[1, 2])
    with pytest.raises(TypeError):
        run_batch(sc, ctrl, bogus=1)

    class Broken:
        def decide(self, inputs, runs, ranges_m):
            return np.full((len(inputs), 2), np.nan)

    with pytest.raises(ValueError, match=r"non-finite voltages .* \(run 0\)"):
        run_batch(sc, Broken())


def test_python_entry_point_returns_arrays():
    result = run_layouts("standard", 4, 1, controller="p", control_period_s=0.1)
    assert result.outcome.shape == (4,) and result.path_length_m.dtype == float
    assert set(result.outcomes) <= set(OUTCOMES)
    assert np.all(result.path_length_m > 0)


def test_sweep_engine_option_and_the_fallback_message(capsys):
    assert main(["sweep", "--n", "2", "--beside", "none", "--controller", "p",
                 "--executor", "serial", "--json"]) == 0  # fmt: skip
    batch = json.loads(capsys.readouterr().out)
    assert main(["sweep", "--n", "2", "--beside", "none", "--controller", "p",
                 "--executor", "serial", "--json", "--engine", "pymunk"]) == 0  # fmt: skip
    pymunk = json.loads(capsys.readouterr().out)
    for a, b in zip(batch["runs"], pymunk["runs"]):
        assert a["outcome"] == b["outcome"]
        assert abs(a["path_length_m"] - b["path_length_m"]) <= 1e-6
    assert main(["sweep", "--n", "1", "--beside", "none", "--controller", "fuzzynav",
                 "--executor", "serial", "--json"]) == 0  # fmt: skip
    assert "'fuzzynav' cannot be batched" in capsys.readouterr().err
    assert main(["sweep", "--n", "1", "--engine", "warp"]) == 2
    assert "--engine" in capsys.readouterr().err


# ---------------------------------------------------------------- tune and fit-paper


def test_tuning_and_fit_costs_on_the_batch_engine_equal_the_pymunk_ones():
    from fuzzynav.app.experiments.batch_runs import fit_costs, objective_costs
    from fuzzynav.app.experiments.objective import STALL_S, Case, Objective, outcome_cost
    from fuzzynav.app.experiments.paper_fit import FitCost
    from fuzzynav.controller.tuning import tunable
    from fuzzynav.world.scenario import ObstacleSpec, load_scenario

    sc = load_scenario("s1").replace(
        target=(2.5, 0.5), duration_s=6.0, obstacles=(ObstacleSpec((1.5, -1.2), 0.2),)
    )
    t = tunable("paper")
    cases = [Case(sc, "ideal", "tiny"), Case(sc, "ultrasonic", "tiny/u")]
    objective = Objective(t, cases, control_period_s=0.1)
    low, high = np.array(t.bounds()).T  # the paper tunable's own layout
    vectors = low + (high - low) * np.random.default_rng(5).random((3, len(low)))
    batch = objective_costs(objective, outcome_cost, STALL_S, vectors)
    assert len(set(batch)) == 3  # the candidates' costs differ
    assert np.allclose(batch, [objective(v) for v in vectors], rtol=0, atol=1e-9)
    # the fit: the paper's point robot on s1-s3 with the stall rule, at a coarse period
    fit = FitCost(control_period_s=0.1)
    vector = fit.tunable.initial_vector()
    batch = fit_costs(fit, [vector])
    assert batch == pytest.approx([fit(vector)], rel=1e-9)
    # with the Husky geometry's runs too (both perception modes)
    husky = FitCost(control_period_s=0.1, husky=True)
    assert fit_costs(husky, [vector]) == pytest.approx([husky(vector)], rel=1e-9)
