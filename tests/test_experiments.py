"""tune, sweep, compare and fis export through the command line (tiny budgets)."""

import json
from pathlib import Path

import numpy as np
import pytest

from fuzzynav import simulate
from fuzzynav.app.cli import main
from fuzzynav.app.experiments.objective import Case, Objective, run_cost
from fuzzynav.app.experiments.tuning import tune
from fuzzynav.controller.fis import read_fis, write_fis
from fuzzynav.controller.paper import FIRST_DESIGN
from fuzzynav.controller.registry import make_controller
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.controller.tuning import tunable
from fuzzynav.world.scenario import ObstacleSpec, load_scenario

SWEEP_KEYS = {
    "controller",
    "family",
    "perception",
    "n",
    "seed",
    "success_rate",
    "safe_success_rate",
    "reached",
    "collisions",
    "timeouts",
    "median_path_length_m",
    "median_path_ratio",
    "median_time_ratio",
    "mean_score",
    "median_straight_ratio",
    "median_min_clearance_m",
    "wall_time_s",
    "runs",
}


def tiny_case():
    sc = load_scenario("s1").replace(
        target=(2.5, 0.5), duration_s=4.0, obstacles=(ObstacleSpec((1.5, -1.2), 0.2),)
    )
    return [Case(sc, "ideal", "tiny")]


def test_tune_is_reproducible_with_the_same_seed():
    t = tunable("paper")
    runs = [
        tune(
            controller=t,
            cases=tiny_case(),
            method="de",
            generations=1,
            popsize=1,
            seed=7,
            control_period_s=0.1,
        )
        for _ in range(2)
    ]
    assert np.array_equal(runs[0].vector, runs[1].vector) and runs[0].cost == runs[1].cost
    other = tune(
        controller=t,
        cases=tiny_case(),
        method="de",
        generations=1,
        popsize=1,
        seed=8,
        control_period_s=0.1,
    )
    assert not np.array_equal(other.vector, runs[0].vector)


def test_cost_prefers_reaching_over_timeout_over_collision():
    t = tunable("paper")
    objective = Objective(t, [Case(load_scenario("s1"), "ideal", "s1")], control_period_s=0.1)
    [result] = objective.runs(t.initial_vector())
    # without the clearance hinge, the three outcomes fall in disjoint bands
    cost = run_cost(result, clearance_weight=0.0)
    if result.outcome == "reached":
        assert cost < 5
    elif result.collided:
        assert cost >= 14
    else:
        assert 5 <= cost < 14


TINY = (
    'name = "tiny"\nduration_s = 5.0\n[robot]\nstart = [0.0, 0.0]\n'
    "[target]\nposition = [2.5, 0.5]\n[[obstacles]]\nposition = [1.5, -1.2]\nradius_m = 0.2\n"
)


def test_tune_cli_writes_a_valid_rule_base(tmp_path, write_toml, capsys):
    out = tmp_path / "tuned.toml"
    tiny = write_toml(TINY)
    assert (
        main(
            [
                "tune",
                "--scenarios",
                str(tiny),
                "--perception",
                "ideal",
                "--maxiter",
                "1",
                "--popsize",
                "1",
                "--workers",
                "1",
                "--dt",
                "0.1",
                "--seed",
                "3",
                "--out",
                str(out),
                "--checkpoint",
                str(tmp_path / "ck.txt"),
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["written"] == [str(out)] and data["generations"] == 1
    assert "fuzzynav tune" in data["command"] and "--seed 3" in data["command"]
    fis = read_toml(out)
    assert fis.rules == read_toml(FIRST_DESIGN).rules
    assert data["command"] in out.read_text()
    assert len((tmp_path / "ck.txt").read_text().split()) == len(tunable("paper").parameter_names())


def test_tune_cli_bad_input(capsys):
    assert main(["tune", "--controller", "nope", "--maxiter", "1"]) == 2
    assert main(["tune", "--perception", "sonar", "--maxiter", "1"]) == 2
    assert "error" in capsys.readouterr().err


def test_sweep_json(capsys):
    assert main(["sweep", "--n", "2", "--seed", "5", "--controller", "paper", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert SWEEP_KEYS <= set(data)
    assert data["n"] == 2 and len(data["runs"]) == 2 and 0 <= data["success_rate"] <= 1
    assert data["reached"] + data["collisions"] + data["timeouts"] >= 2 - data["reached"]


def test_sweep_bad_input(capsys):
    assert main(["sweep", "--n", "0"]) == 2
    assert main(["sweep", "--n", "1", "--executor", "threads"]) == 2


def test_compare_json(capsys):
    assert (
        main(
            [
                "compare",
                "--controllers",
                "paper,baseline",
                "--sweep-n",
                "1",
                "--workers",
                "1",
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["controllers"] == ["paper", "baseline"]
    assert len(data["rows"]) == 6
    row = data["rows"][0]
    for key in (
        "path_length_m",
        "mad_m",
        "rmse_m",
        "min_center_distance_m",
        "min_clearance_m",
        "time_to_target_s",
        "reached",
        "collided",
        "paper",
    ):
        assert key in row
    assert row["paper"]["path_length_m"] == pytest.approx(11.8332)
    assert data["rows"][3]["paper"]["path_length_m"] == pytest.approx(12.4996)
    assert len(data["sweeps"]) == 2 and "runs" not in data["sweeps"][0]
    assert main(["compare", "--controllers", "nope"]) == 2


def test_compare_table(capsys):
    assert main(["compare", "--controllers", "baseline", "--sweep-n", "2", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "stand-in" in out and "12.5" in out
    # the sweep summary is part of the table by default (held-out seed 5)
    assert "sweep: 2 standard layouts, seed 5" in out
    assert main(["compare", "--controllers", "baseline", "--sweep-n", "-1"]) == 2


def test_fis_export_round_trip(tmp_path, capsys, matlab_twin):
    """``fis export`` refuses the default controller, whose rules read NONE as the text
    does (a .fis cannot say it), in one line naming the file and why; the twin with
    MATLAB's NONE goes through a .fis and ``run --fis`` drives as it does in memory."""
    path = tmp_path / "paper.fis"
    assert main(["fis", "export", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"fuzzynav: error: {path}: not written")
    assert "a .fis cannot say" in err and "rules/paper_husky.toml" in err
    assert not path.exists()
    write_fis(matlab_twin, path)
    text = path.read_text()
    for label in (
        "'d_t'",
        "'d_o'",
        "'phi_t'",
        "'phi_o'",
        "'left'",
        "'right'",
        "'VS'",
        "'near'",
        "'medium'",
        "'far'",
        "'VN'",
        "'VP'",
    ):
        assert label in text
    assert read_fis(path) == matlab_twin
    capsys.readouterr()
    assert main(["run", "s1", "--fis", str(path), "--json"]) == 0
    via_fis = json.loads(capsys.readouterr().out)
    in_memory = simulate("s1", fis=matlab_twin).metrics
    for key in ("outcome", "path_length_m", "min_clearance_m", "steps"):
        assert via_fis[key] == in_memory[key]


def test_fis_export_bad_path(tmp_path, capsys):
    assert main(["fis", "export", str(tmp_path / "x.txt")]) == 2
    assert main(["fis", "export", str(tmp_path / "missing" / "x.fis")]) == 2


@pytest.mark.parametrize("controller", ["fuzzynav", "baseline"])
def test_fis_export_of_a_two_block_controller(tmp_path, capsys, controller):
    """fuzzynav and the baseline are two fuzzy blocks: one .fis per block in a directory,
    each read back equal to the block the controller drives with."""
    out = tmp_path / "blocks"
    assert main(["fis", "export", str(out), "--controller", controller]) == 0
    printed = capsys.readouterr().out
    blocks = make_controller(controller).rule_blocks()
    for name, system in blocks.items():
        path = out / f"{controller}_{name}.fis"
        assert str(path) in printed
        assert read_fis(path) == system
    assert sorted(p.name for p in out.iterdir()) == sorted(f"{controller}_{n}.fis" for n in blocks)


def test_fis_export_of_blocks_refuses_a_file_name(tmp_path, capsys):
    assert main(["fis", "export", str(tmp_path / "x.fis"), "--controller", "fuzzynav"]) == 2
    assert (
        "fuzzynav is 2 fuzzy blocks (goal, avoid), one .fis each: give a directory"
        in capsys.readouterr().err
    )
    (tmp_path / "plain").write_text("not a directory")
    assert main(["fis", "export", str(tmp_path / "plain"), "--controller", "baseline"]) == 2
    assert "not a directory" in capsys.readouterr().err
    assert (tmp_path / "plain").read_text() == "not a directory"  # nothing lost
    assert main(["fis", "export", str(tmp_path / "a" / "b"), "--controller", "fuzzynav"]) == 2
    assert not (tmp_path / "a").exists()


def test_sweep_writes_each_failed_run_to_run_again_and_to_open(tmp_path, capsys):
    """--failures DIR: every failed run's layout as a scenario file that runs again to
    the same end, and a recording of it that names the sweep and that file."""
    from tests.test_recording import Recording

    out_dir = tmp_path / "failed"
    assert (
        main(
            [
                "sweep",
                "--n",
                "4",
                "--seed",
                "1",
                "--controller",
                "p",
                "--beside",
                "none",
                "--failures",
                str(out_dir),
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    failed = [r for r in data["runs"] if not (r["reached"] and not r["collided"])]
    assert failed, "the obstacle-blind P controller should fail somewhere"
    assert [f["index"] for f in data["failures"]] == [r["index"] for r in failed]
    for f, run in zip(data["failures"], failed):
        scenario_file = out_dir / f"standard_seed1_{run['index']:03d}.toml"
        assert f["scenario_file"] == str(scenario_file) and f["outcome"] == run["outcome"]
        assert main(["run", str(scenario_file), "--controller", "p", "--seed", "1", "--json"]) == 0
        again = json.loads(capsys.readouterr().out)
        assert again["outcome"] == run["outcome"]
        assert again["path_length_m"] == pytest.approx(run["path_length_m"], abs=1e-12)
        meta = Recording(f["recording"]).text("/meta/run")
        assert f"standard layout #{run['index']} of seed 1" in meta
        assert f"fuzzynav run {scenario_file} --controller p" in meta
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        name
        for f in data["failures"]
        for name in (Path(f["scenario_file"]).name, Path(f["recording"]).name)
    )


def test_sweep_failures_dir_is_checked_before_the_sweep(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("keep me")
    assert (
        main(
            [
                "sweep",
                "--n",
                "2",
                "--controller",
                "p",
                "--beside",
                "none",
                "--failures",
                str(blocker),
            ]
        )
        == 2
    )
    captured = capsys.readouterr()
    assert f"--failures {blocker}: exists and is not a directory" in captured.err
    assert "sweep" not in captured.out and blocker.read_text() == "keep me"


def test_sweep_prints_the_paper_controller_beside(capsys):
    """Issue 6: a sweep of another controller prints the paper controller's rate beside
    it, on the same layouts; --beside none skips it; a bad name is refused."""
    assert main(["sweep", "--n", "2", "--seed", "5", "--controller", "p", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["controller"] == "p" and data["beside"]["controller"] == "paper"
    assert data["beside"]["n"] == 2 and data["beside"]["seed"] == 5 and "runs" not in data["beside"]
    assert main(["sweep", "--n", "2", "--seed", "5", "--controller", "p"]) == 0
    header = capsys.readouterr().out
    assert "paper" in header and " p " in header
    assert main(["sweep", "--n", "1", "--controller", "p", "--beside", "none", "--json"]) == 0
    assert "beside" not in json.loads(capsys.readouterr().out)
    assert main(["sweep", "--n", "1", "--beside", "nobody"]) == 2
    assert "invalid choice: 'nobody'" in capsys.readouterr().err


def test_sweep_off_switches_fuzzynav_parts_off_and_its_failures_run_again(tmp_path, capsys):
    """`sweep --off "echo memory"`: without its memory fuzzynav times out on layout #3 of
    seed 1 (it reaches it with the memory); the failure's file and recording carry the
    --off that runs it again to the same end."""
    from tests.test_recording import Recording

    out_dir = tmp_path / "failed"
    assert (
        main(
            [
                "sweep",
                "--n",
                "4",
                "--seed",
                "1",
                "--controller",
                "fuzzynav",
                "--off",
                "echo memory",
                "--beside",
                "none",
                "--failures",
                str(out_dir),
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["parts_off"] == ["echo memory"]
    assert [(f["index"], f["outcome"]) for f in data["failures"]] == [(3, "timeout")]
    scenario_file = data["failures"][0]["scenario_file"]
    command = f"fuzzynav run {scenario_file} --controller fuzzynav --off 'echo memory'"
    assert command in Path(scenario_file).read_text()
    meta = Recording(data["failures"][0]["recording"]).text("/meta/run")
    assert command in meta  # the "reproduce" line
    assert (
        main(
            [
                "run",
                scenario_file,
                "--controller",
                "fuzzynav",
                "--off",
                "echo memory",
                "--seed",
                "1",
                "--json",
            ]
        )
        == 0
    )
    assert json.loads(capsys.readouterr().out)["outcome"] == "timeout"
    assert main(["run", scenario_file, "--controller", "fuzzynav", "--seed", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["outcome"] == "reached"


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--controller", "p", "--off", "echo memory"], "p has no parts to switch off"),
        (["--controller", "fuzzynav", "--off", "sonar"], "unknown fuzzynav part(s) ['sonar']"),
    ],
)
def test_sweep_off_is_refused_before_the_sweep(capsys, argv, needle):
    assert main(["sweep", "--n", "2", "--beside", "none", *argv]) == 2
    captured = capsys.readouterr()
    assert needle in captured.err and "success_rate" not in captured.out
