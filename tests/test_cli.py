"""The command line as a user calls it: JSON keys, tables, exit codes, errors on stderr."""

import json
import subprocess
import sys

import pytest

from fuzzynav.app.cli import main

RUN_KEYS = {
    "scenario",
    "controller",
    "perception",
    "reached",
    "collided",
    "time_to_target_s",
    "path_length_m",
    "mad_m",
    "rmse_m",
    "min_center_distance_m",
    "min_clearance_m",
    "max_abs_voltage_v",
    "sim_time_s",
    "steps",
    "wall_time_s",
}


def test_run_json_has_the_documented_keys(capsys):
    assert main(["run", "s1", "--controller", "p", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert RUN_KEYS <= set(out)
    assert out["scenario"] == "s1" and out["controller"] == "p" and out["perception"] == "ideal"
    # The P controller is obstacle-blind: on s1 it drives into the second obstacle.
    assert out["collided"] is True and out["reached"] is False and out["time_to_target_s"] is None
    assert out["steps"] > 100 and out["max_abs_voltage_v"] <= 12.0


def test_run_reaches_an_open_target(write_toml, capsys):
    path = write_toml(
        'name = "open"\nduration_s = 60.0\n[robot]\nstart = [0.0, 0.0]\n'
        "[target]\nposition = [5.0, -3.0]\n"
    )
    assert (
        main(["run", str(path), "--controller", "p", "--json", "--perception", "ultrasonic"]) == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["reached"] is True and out["time_to_target_s"] > 0
    assert out["min_clearance_m"] is None  # no obstacles at all


def test_run_table(capsys):
    assert main(["run", "s2", "--controller", "p"]) == 0
    out = capsys.readouterr().out
    assert "path_length_m" in out and "Scenario 2" in out


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["run", "no-such-scenario", "--controller", "p"], "no such scenario file"),
        (
            ["run", "s1", "--controller", "p", "--dt", "-1"],
            "argument --dt: '-1': must be a number from 0.001 to 1 s",
        ),
    ],
)
def test_bad_input_exits_2_with_message(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and "error" in err


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["run", "s1", "--seed", "-3"], "argument --seed: '-3': must be an integer >= 0"),
        (["sweep", "--n", "0"], "argument --n: '0': must be an integer from 1 to 100000"),
        (["sweep", "--seed", "x"], "argument --seed: 'x': must be an integer >= 0"),
        (["compare", "--sweep-seed", "-1"], "argument --sweep-seed: '-1'"),
        (
            ["serve", "--port", "99999"],
            "argument --port: '99999': must be an integer from 0 to 65535",
        ),
    ],
)
def test_bad_integer_options_are_refused_before_anything_runs(capsys, argv, needle):
    # argparse refuses it (status 2) and names the option and the value
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert needle in captured.err
    assert "sweep" not in captured.out  # no progress bar was started


def test_bad_scenario_file_names_file_key_value(write_toml, capsys):
    path = write_toml(
        'name = "x"\nduration_s = 10.0\nwobble = 3\n[robot]\nstart = [0.0, 0.0]\n'
        "[target]\nposition = [5.0, 5.0]\n"
    )
    assert main(["run", str(path), "--controller", "p"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "wobble" in err and "3" in err


def test_console_script_entry_point():
    proc = subprocess.run(
        [sys.executable, "-m", "fuzzynav.app.cli", "run", "s1", "--controller", "p", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["scenario"] == "s1"


def test_run_off_switches_fuzzynav_parts_off(capsys):
    """`run --controller fuzzynav --off PART`: the part is off for the run (another path),
    and the result says so; an unknown part or a controller without parts is refused."""
    assert main(["run", "s1", "--controller", "fuzzynav", "--json"]) == 0
    shipped = json.loads(capsys.readouterr().out)
    assert (
        main(["run", "s1", "--controller", "fuzzynav", "--off", "bearing planner", "--json"]) == 0
    )
    off = json.loads(capsys.readouterr().out)
    assert off["controller"] == "fuzzynav without bearing planner"
    assert off["path_length_m"] != shipped["path_length_m"]
    assert main(["run", "s1", "--controller", "fuzzynav", "--off", "sonar"]) == 2
    assert "unknown fuzzynav part(s) ['sonar']" in capsys.readouterr().err
    assert main(["run", "s1", "--controller", "paper", "--off", "echo memory"]) == 2
    assert "only fuzzynav has parts" in capsys.readouterr().err


def test_a_reader_that_leaves_early_gets_no_traceback():
    """`fuzzynav run s1 --json | head -1`: the pipe closes before the JSON is written;
    the command ends quietly with 141 (128 + SIGPIPE), as a shell reports such a process."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "fuzzynav.app.cli", "run", "s1", "--controller", "p", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # the reader is gone before anything is written
    stderr = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, stderr
    assert "Traceback" not in stderr and "BrokenPipe" not in stderr, stderr


def test_parts_lists_what_off_takes(capsys):
    """`fuzzynav parts`: every name it lists is one `run --off` takes."""
    from fuzzynav.controller.navigator.parts import load_parts

    assert main(["parts", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [p["name"] for p in listed] == [p.name for p in load_parts()]
    assert (
        main(
            [
                "run",
                "s1",
                "--controller",
                "fuzzynav",
                "--json",
                "--off",
                ",".join(p["name"] for p in listed),
            ]
        )
        == 0
    )
    assert json.loads(capsys.readouterr().out)["controller"].startswith("fuzzynav without ")
    assert main(["parts"]) == 0
    assert "echo memory" in capsys.readouterr().out
