"""fuzzynav tune's local-search options: --method, --x0, --free, --radius, --clearance-weight."""

import argparse
import math

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.experiments.objective import CLEARANCE_WEIGHT, Case, Objective, run_cost
from fuzzynav.app.experiments.tuning import (
    free_indices,
    read_vector,
    reproduce_command,
    tune,
)
from fuzzynav.controller.tuning import tunable
from fuzzynav.world.scenario import ObstacleSpec, load_scenario


def tiny_case():
    sc = load_scenario("s1").replace(
        target=(2.5, 0.5), duration_s=4.0, obstacles=(ObstacleSpec((1.5, -1.2), 0.2),)
    )
    return [Case(sc, "ideal", "tiny")]


def test_read_vector_from_a_saved_rule_base_and_from_a_checkpoint(tmp_path):
    t = tunable("paper")
    x = t.initial_vector() * 1.01
    [path] = t.save(x, tmp_path / "x.toml")
    assert np.allclose(read_vector(path, t.parameter_names()), x, rtol=1e-5)
    ck = tmp_path / "ck.txt"
    ck.write_text(" ".join(repr(float(v)) for v in x) + "\n")
    assert np.array_equal(read_vector(ck, t.parameter_names()), x)
    ck.write_text("1 2 3\n")
    with pytest.raises(ValueError):
        read_vector(ck, t.parameter_names())


def test_a_starting_vector_file_of_nonsense_is_named_before_the_search(tmp_path, capsys):
    """``--x0`` of twelve NaNs started the search (its progress bar drawn) and failed in
    it without naming the file; a header item without ``=`` failed with dict()'s words
    ("dictionary update sequence element #0 has length 1")."""
    t = tunable("paper")
    names = t.parameter_names()
    ck = tmp_path / "ck.txt"
    ck.write_text(" ".join(["nan"] * len(names)) + "\n")
    with pytest.raises(ValueError, match=f"ck.txt: {names[0]} = nan: must be a finite number"):
        read_vector(ck, names)
    [saved] = t.save(t.initial_vector(), tmp_path / "x.toml")
    text = saved.read_text()
    header = next(line for line in text.splitlines() if line.startswith("# tuned vector:"))
    first = header.split(":", 1)[1].split(",")[0].strip()
    for bad, why in (
        (first.split("=")[0], "is not NAME=NUMBER"),
        (first.split("=")[0] + "=inf", "must be a finite number"),
        (first.split("=")[0] + "=abc", "could not convert"),
    ):
        saved.write_text(text.replace(first, bad, 1))
        with pytest.raises(ValueError, match=f"x.toml: .*{why}"):
            read_vector(saved, names)
    out = tmp_path / "o.toml"
    code = main(["tune", "--scenarios", "s1", "--maxiter", "1", "--x0", str(ck), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "ck.txt" in err and "Traceback" not in err and not out.exists()
    assert "generation" not in err  # refused before the search started


def test_free_indices():
    names = tunable("paper").parameter_names()
    idx = free_indices(names, ["phi_t", "d_o"])
    assert [names[i] for i in idx] == [n for n in names if n.startswith(("phi_t", "d_o"))]
    assert free_indices(names, None) is None
    with pytest.raises(ValueError):
        free_indices(names, ["nope"])


@pytest.mark.parametrize("method", ["nelder-mead", "powell"])
def test_local_search_keeps_the_fixed_parameters_and_is_deterministic(method):
    t = tunable("paper")
    names, x0 = t.parameter_names(), t.initial_vector()
    free = free_indices(names, ["phi_o.vp", "d_o.near"])
    runs = [
        tune(
            controller=t,
            cases=tiny_case(),
            generations=2,
            method=method,
            free=free,
            control_period_s=0.1,
        )
        for _ in range(2)
    ]
    assert np.array_equal(runs[0].vector, runs[1].vector) and runs[0].cost == runs[1].cost
    x = runs[0].vector
    assert x.shape == x0.shape
    fixed = [i for i in range(len(x0)) if i not in free]
    assert np.array_equal(x[fixed], x0[fixed])


def test_de_radius_narrows_the_bounds_around_the_start():
    t = tunable("paper")
    x0 = t.initial_vector()
    lo, hi = np.array(t.bounds()).T
    result = tune(
        controller=t,
        cases=tiny_case(),
        method="de",
        generations=1,
        popsize=1,
        seed=1,
        radius=0.01,
        control_period_s=0.1,
    )
    assert np.all(np.abs(result.vector - x0) <= 0.01 * (hi - lo) + 1e-12)


def test_clearance_weight_scales_the_hinge():
    class R:  # a reached run that passed 0.1 m from an obstacle
        scenario = load_scenario("s1")
        outcome = "reached"
        collided = False
        metrics = {"path_length_m": 12.0, "time_to_target_s": 50.0, "min_clearance_m": 0.1}

    base = run_cost(R(), clearance_weight=0.0)
    assert run_cost(R()) == pytest.approx(base + CLEARANCE_WEIGHT * 0.2)
    assert run_cost(R(), clearance_weight=100.0) == pytest.approx(base + 100.0 * 0.2)


def test_reproduce_command_names_the_options_that_change_the_result():
    args = argparse.Namespace(
        controller="paper",
        scenarios=["s1"],
        layouts=None,
        n=0,
        layout_seed=0,
        perception=["ideal"],
        maxiter=5,
        popsize=1,
        seed=0,
        dt=0.05,
        method="nelder-mead",
        x0=None,
        free=["phi_t"],
        radius=None,
        clearance_weight=CLEARANCE_WEIGHT,
    )
    cmd = reproduce_command(args)
    assert "--method nelder-mead" in cmd and "--free phi_t" in cmd and "--seed" not in cmd
    assert "--clearance-weight" not in cmd
    args.method, args.radius, args.clearance_weight = "de", 0.1, 50.0
    cmd = reproduce_command(args)
    assert "--method" not in cmd and "--radius 0.1" in cmd and "--clearance-weight 50.0" in cmd
    # CMA-ES draws its candidates from the seed, popsize of them a generation
    args.method, args.sigma = "cmaes", 0.02
    cmd = reproduce_command(args)
    assert "--method cmaes" in cmd and "--sigma 0.02" in cmd
    assert "--popsize 1" in cmd and "--seed 0" in cmd


def test_tune_cli_local_search(tmp_path, write_toml, capsys):
    import json

    tiny = write_toml(
        'name = "tiny"\nduration_s = 5.0\n[robot]\nstart = [0.0, 0.0]\n'
        "[target]\nposition = [2.5, 0.5]\n[[obstacles]]\nposition = [1.5, -1.2]\n"
        "radius_m = 0.2\n"
    )
    out = tmp_path / "tuned.toml"
    assert (
        main(
            [
                "tune",
                "--scenarios",
                str(tiny),
                "--perception",
                "ideal",
                "--method",
                "nelder-mead",
                "--free",
                "phi_o",
                "--maxiter",
                "1",
                "--workers",
                "1",
                "--dt",
                "0.1",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert "--method nelder-mead --free phi_o" in data["command"]
    assert data["command"] in out.read_text()
    # --x0 from the file just written: a valid start
    assert (
        main(
            [
                "tune",
                "--scenarios",
                str(tiny),
                "--perception",
                "ideal",
                "--method",
                "powell",
                "--x0",
                str(out),
                "--free",
                "d_o.near",
                "--maxiter",
                "1",
                "--workers",
                "1",
                "--dt",
                "0.1",
                "--out",
                str(tmp_path / "again.toml"),
                "--json",
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert main(["tune", "--free", "nope", "--maxiter", "1"]) == 2


def _fake_run(outcome, path_xy, collided=False):
    """A finished s1 run that drove along ``path_xy`` (no clearance problem)."""
    path_xy = np.asarray(path_xy, float)

    class Log:
        pose = np.column_stack([path_xy, np.zeros(len(path_xy))])
        target_xy = np.tile([8.0, 8.0], (len(path_xy), 1))

        def __len__(self):
            return len(path_xy)

    class R:
        scenario = load_scenario("s1")
        log = Log()
        perception = "ultrasonic"
        metrics = {"path_length_m": 12.0, "time_to_target_s": 50.0, "min_clearance_m": 1.0}

    R.outcome, R.collided = outcome, collided
    return R()


def test_a_timeout_is_graded_by_its_nearest_approach_and_ranks_between():
    reached = run_cost(_fake_run("reached", [(0, 0), (8, 8)]))
    # an orbit that passed 0.3 m from the target and ended 3 m away
    orbit = run_cost(_fake_run("timeout", [(0, 0), (8.3, 8.0), (11.0, 8.0)]))
    # a dead end that never came nearer than 5.7 m and stopped there
    dead_end = run_cost(_fake_run("timeout", [(0, 0), (4.0, 4.0)]))
    crash_near = run_cost(_fake_run("timeout", [(0, 0), (7.5, 7.5)], collided=True))
    assert reached < orbit < dead_end < crash_near
    assert orbit == pytest.approx(5.0 + 8.0 * 0.3 / math.hypot(8, 8))


def test_cmaes_never_returns_worse_than_its_start():
    t = tunable("paper")
    x0 = t.initial_vector()
    objective = Objective(t, tiny_case(), control_period_s=0.1)
    result = tune(
        controller=t,
        cases=tiny_case(),
        generations=1,
        popsize=4,
        seed=3,
        method="cmaes",
        sigma0=0.3,
        x0=x0,
        control_period_s=0.1,
    )
    assert result.cost <= objective(x0) + 1e-12
    assert result.cost == pytest.approx(objective(result.vector))
