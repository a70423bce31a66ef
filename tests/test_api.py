"""The Python interface (fuzzynav.api): the same runs as the command line, the trace as
arrays equal to the CSV, recordings and figures from a run, sweeps as rows, lazy
imports, refusals; and the examples/ run as a user would run them."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from load_file import load_file

import fuzzynav
from fuzzynav.app.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


@pytest.fixture(scope="module")
def s1_run():
    return fuzzynav.simulate("s1")


def test_everything_in_all_is_there():
    for name in fuzzynav.__all__:
        assert getattr(fuzzynav, name) is not None, name
    with pytest.raises(AttributeError):
        fuzzynav.no_such_thing  # noqa: B018


def test_import_is_lazy():
    code = "import sys, fuzzynav; print(sorted(m for m in ('numpy', 'pymunk', 'scipy') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_simulate_equals_the_command_line(s1_run, capsys, tmp_path):
    trace = tmp_path / "s1.csv"
    assert main(["run", "s1", "--json", "--trace", str(trace)]) == 0
    row = json.loads(capsys.readouterr().out)
    metrics = s1_run.metrics
    assert set(metrics) == set(row) - {"wall_time_s"}  # a machine's time: in timing
    assert s1_run.timing["wall_time_s"] > 0
    for key, value in row.items():
        if key == "wall_time_s":
            continue
        mine = metrics[key]
        assert mine == value, key  # None where it does not apply, as the JSON's null
    assert s1_run.outcome == row["outcome"] == "reached"
    # The trace's arrays are the CSV's columns, bit for bit.
    with trace.open() as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    assert list(s1_run.trace) == header
    for k, name in enumerate(header):
        column = np.array([float(r[k]) if r[k] else np.nan for r in body])
        np.testing.assert_array_equal(s1_run.trace[name], column, err_msg=name)
    assert len(s1_run.trace["x_m"]) == len(s1_run.result.log)


def test_simulate_options_change_the_run():
    ideal = fuzzynav.simulate("s2")
    sonar = fuzzynav.simulate("s2", perception="ultrasonic")
    assert ideal.metrics["perception"] == "ideal" and sonar.metrics["perception"] == "ultrasonic"
    n = min(len(ideal.trace["d_o_m"]), len(sonar.trace["d_o_m"]))
    assert not np.array_equal(ideal.trace["d_o_m"][:n], sonar.trace["d_o_m"][:n], equal_nan=True)
    paper = fuzzynav.simulate("s1", controller="p", geometry="paper")
    assert paper.metrics["geometry"] == "paper"


def test_a_changed_controller_object_drives(s1_run):
    controller = fuzzynav.make_controller("paper")
    phi_t = next(v for v in controller.fis.inputs if v.name == "phi_t")
    zero = phi_t.terms[phi_t.term_index("Z")]
    assert zero.shape == "trimf" or zero.shape == "gaussmf"
    wider = [2.0 * p for p in zero.params] if zero.shape == "trimf" else [2 * zero.params[0], 0.0]
    controller.fis = controller.fis.with_term_params("phi_t", "Z", wider)
    changed = fuzzynav.simulate("s1", controller=controller)
    n = min(len(changed.trace["x_m"]), len(s1_run.trace["x_m"]))
    assert not np.array_equal(changed.trace["x_m"][:n], s1_run.trace["x_m"][:n])
    # The unchanged controller object gives the named controller's run exactly.
    same = fuzzynav.simulate("s1", controller=fuzzynav.make_controller("paper"))
    np.testing.assert_array_equal(same.trace["x_m"], s1_run.trace["x_m"])


def test_fis_round_trip_and_fis_option(tmp_path, matlab_twin):
    """The default controller's rules read NONE as the text does, which a .fis cannot
    say: its writer refuses them; the twin with MATLAB's NONE goes through a file and
    drives as it does in memory."""
    with pytest.raises(ValueError, match="a .fis cannot say"):
        fuzzynav.write_fis(fuzzynav.make_controller("paper").fis, tmp_path / "text.fis")
    assert not (tmp_path / "text.fis").exists()
    path = fuzzynav.write_fis(matlab_twin, tmp_path / "paper.fis")
    back = fuzzynav.read_fis(path)
    assert back == matlab_twin
    in_memory = fuzzynav.simulate("s1", fis=matlab_twin)
    by_file = fuzzynav.simulate("s1", fis=path)
    by_system = fuzzynav.simulate("s1", fis=back)
    np.testing.assert_array_equal(by_file.trace["x_m"], in_memory.trace["x_m"])
    np.testing.assert_array_equal(by_system.trace["x_m"], in_memory.trace["x_m"])


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"seed": -1}, "seed = -1"),
        ({"seed": 1.5}, "seed = 1.5"),
        ({"perception": "sonar"}, "sonar"),
        ({"controller": "nope"}, "nope"),
        ({"controller": 3}, "controller = 3"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, words):
    with pytest.raises(ValueError, match=words):
        fuzzynav.simulate("s1", **kwargs)


def test_unknown_keywords_are_refused():
    with pytest.raises(TypeError):
        fuzzynav.simulate("s1", perceptoin="ideal")


def test_unknown_scenario_names_the_file():
    with pytest.raises(ValueError, match="no such scenario"):
        fuzzynav.load_scenario("s9")
    assert fuzzynav.load_scenario("s2").name


def test_save_rrd_and_figures(tmp_path):
    pytest.importorskip("rerun")
    run = fuzzynav.simulate("s1", controller="p")
    path = run.save_rrd(tmp_path / "run.rrd")
    assert path.stat().st_size > 10_000
    files = run.figures(tmp_path / "figs")
    assert files and all(f.exists() and f.stat().st_size > 1000 for f in files)
    assert any(f.suffix == ".png" for f in files)


def test_sweep_returns_the_command_lines_rows(tmp_path):
    rows = fuzzynav.sweep("p", n=3, seed=2)
    assert [r["index"] for r in rows] == [0, 1, 2]
    out = tmp_path / "rows.jsonl"
    assert main(["sweep", "--controller", "p", "--n", "3", "--seed", "2", "--out", str(out)]) == 0
    from_cli = [json.loads(line) for line in out.read_text().splitlines() if line.strip()]
    from_cli = [r for r in from_cli if r["controller"] == "p"]  # not its comparison's rows
    keep = {"index", "outcome", "success", "path_length_m", "min_clearance_m"}
    assert [{k: r[k] for k in keep} for r in rows] == [
        {k: r[k] for k in keep} for r in sorted(from_cli, key=lambda r: r["index"])
    ]


def _example(name: str):
    return load_file(EXAMPLES / f"{name}.py", f"example_{name}")


def test_every_example_has_a_docstring_and_one_main():
    files = sorted(EXAMPLES.glob("*.py"))
    assert len(files) >= 3
    for path in files:
        module = _example(path.stem)
        assert module.__doc__ and len(module.__doc__.strip()) > 80, path.name
        assert callable(module.main), path.name


def test_example_teaching_walkthrough(tmp_path, capsys):
    out = _example("teaching_walkthrough").main(["--out", str(tmp_path)])
    assert out["figure"].stat().st_size > 20_000
    before, after = out["before"], out["after"]
    assert before.outcome == "reached"
    n = min(len(before.trace["x_m"]), len(after.trace["x_m"]))
    assert not np.array_equal(before.trace["x_m"][:n], after.trace["x_m"][:n])
    assert "phi_t 'Z' was" in capsys.readouterr().out


def test_example_sweep_table(tmp_path):
    out = _example("sweep_table").main(["--n", "3", "--out", str(tmp_path / "t.csv")])
    with out["csv"].open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(out["rows"]) == 6
    for name, summary in out["summary"].items():
        mine = [r for r in out["rows"] if r["controller"] == name]
        assert summary["success_rate"] == sum(r["success"] for r in mine) / len(mine)


def test_example_read_recording(tmp_path):
    pytest.importorskip("rerun")
    out = _example("read_recording").main(["--out", str(tmp_path / "s2.rrd")])
    run, volts = out["run"], out["voltages_v"]
    assert len(out["time_s"]) == len(run.result.log)
    np.testing.assert_array_equal(out["time_s"], np.round(run.trace["time_s"] * 1e9) / 1e9)
    np.testing.assert_array_equal(volts[:-1, 0], run.trace["v_left_v"][:-1])


def test_simulate_takes_the_field_of_view_and_the_sonar_mounting():
    """``field_of_view_deg`` and ``sonar_side_deg`` are ``run``'s ``--field-of-view`` and
    ``--sonar-side``: the same run as the command line's, and a different one from the
    defaults (s1: a 60-degree cone ahead; the sonars 45 degrees apart)."""
    from fuzzynav.app.cli import main

    all_around = fuzzynav.simulate("s1", field_of_view_deg=360)
    front = fuzzynav.simulate("s1")
    assert front._simulation.perception.field_of_view_rad == pytest.approx(math.radians(60))
    assert all_around._simulation.perception.field_of_view_rad == 2 * math.pi
    assert all_around.metrics["path_length_m"] != front.metrics["path_length_m"]
    gapless = fuzzynav.simulate("s1", perception="ultrasonic", sonar_side_deg=15)
    mounts = [m.angle_rad for m in gapless._simulation.sensors.config.mounts]
    assert mounts == pytest.approx([math.radians(15), 0.0, -math.radians(15)])
    default = fuzzynav.simulate("s1", perception="ultrasonic")
    assert gapless.metrics["path_length_m"] != default.metrics["path_length_m"]
    with pytest.raises(ValueError, match="field_of_view_deg"):
        fuzzynav.simulate("s1", field_of_view_deg=0.0)
    assert main(["run", "s1", "--perception", "ultrasonic", "--sonar-side", "15", "--json"]) == 0
