"""Issue 37, "nothing lost, nothing exhausted": the installed package, users' files and
the Python interface's edges. Every writer (command line and API) goes through the one
output guard (fuzzynav.safe_files.check_output_path); the API's arguments are checked by
the command line's rules; a script without a main guard, a taken last port and a
multi-line description end with a sentence. Each test failed before the fix."""

from __future__ import annotations

import math
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fuzzynav
from fuzzynav.app.cli import main
from fuzzynav.resources import asset_path, escape_controls
from fuzzynav.world.scenario import ScenarioError, load_scenario, loads_scenario

TINY = (
    'name = "tiny"\nduration_s = 3.0\n[robot]\nstart = [0.0, 0.0]\n'
    "[target]\nposition = [2.5, 0.5]\n[[obstacles]]\nposition = [1.5, -1.2]\nradius_m = 0.2\n"
)
INSIDE = "is inside the installed fuzzynav package"


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(TINY)
    return path


@pytest.fixture(scope="module")
def p_run():
    return fuzzynav.simulate("s1", controller="p")  # 0.1 s: a run to write out


# ------------------------------------------------- 1. never into the installed package


def test_api_writers_never_write_into_the_installed_package(p_run):
    """``write_fis(system, <assets>/rules/paper.toml)`` and ``save_rrd(<assets>/...)``
    wrote over the shipped files every later run reads."""
    shipped = asset_path("rules", "paper.toml")
    before = shipped.read_bytes()
    system = fuzzynav.make_controller("paper").fis
    try:
        with pytest.raises(ValueError, match=f"write_fis: path .*{INSIDE}"):
            fuzzynav.write_fis(system, shipped)
        with pytest.raises(ValueError, match=INSIDE):
            fuzzynav.write_fis(system, asset_path("rules", "new.fis"))
        s1 = asset_path("scenarios", "s1.toml")
        s1_before = s1.read_bytes()
        with pytest.raises(ValueError, match=f"save_rrd: path .*{INSIDE}"):
            p_run.save_rrd(s1)
        assert s1.read_bytes() == s1_before
        with pytest.raises(ValueError, match=f"figures: folder .*{INSIDE}"):
            p_run.figures(asset_path("scenarios"))
    finally:
        if shipped.read_bytes() != before:  # the old behaviour: restore what it broke
            shipped.write_bytes(before)
    assert shipped.read_bytes() == before
    assert not asset_path("rules", "new.fis").exists()


def test_api_save_rrd_never_replaces_the_runs_scenario(tiny):
    run = fuzzynav.simulate(tiny, controller="p")
    with pytest.raises(ValueError, match="is one of this run's inputs"):
        run.save_rrd(tiny)
    assert tiny.read_text() == TINY


def test_report_readme_images_never_into_the_package_and_before_any_run(capsys, tmp_path):
    """``report R --readme-images <package>/assets/img`` ran everything, then made
    assets/img and wrote table4.md into the package."""
    out = tmp_path / "r"
    started = time.perf_counter()
    code, err = run_cli(
        capsys, "report", out, "--controllers", "p", "--geometry", "husky",
        "--readme-images", asset_path("img"),
    )  # fmt: skip
    assert code == 2 and "--readme-images" in err and INSIDE in err
    assert time.perf_counter() - started < 20  # refused before the runs
    assert not out.exists() and not asset_path("img").exists()
    assert not asset_path("table4.md").exists()


# ------------------------------------- 2. a name the command chose never replaces a file


def test_fis_export_default_name_never_replaces_a_file(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper.fis").write_text("my own tuning\n")
    code, err = run_cli(capsys, "fis", "export")
    assert code == 2 and "paper.fis: exists already" in err and "--force" in err
    assert (tmp_path / "paper.fis").read_text() == "my own tuning\n"
    # asked, or a name given: the paper controller's rules read NONE as the text does,
    # which has no .fis form; nothing written
    for argv in (["--force"], ["paper.fis"]):
        code, err = run_cli(capsys, "fis", "export", *argv)
        assert code == 2 and "paper.fis: not written" in err and "a .fis cannot say" in err
        assert (tmp_path / "paper.fis").read_text() == "my own tuning\n"
    # several blocks: the default folder's files, all checked before one is written
    (tmp_path / "fuzzynav_fis").mkdir()
    (tmp_path / "fuzzynav_fis" / "fuzzynav_avoid.fis").write_text("mine\n")
    capsys.readouterr()
    code, err = run_cli(capsys, "fis", "export", "--controller", "fuzzynav")
    assert code == 2 and "exists already" in err and "--force" in err
    assert sorted(p.name for p in (tmp_path / "fuzzynav_fis").iterdir()) == ["fuzzynav_avoid.fis"]
    assert (tmp_path / "fuzzynav_fis" / "fuzzynav_avoid.fis").read_text() == "mine\n"
    assert main(["fis", "export", "--controller", "fuzzynav", "--force"]) == 0  # asked
    assert (tmp_path / "fuzzynav_fis" / "fuzzynav_avoid.fis").read_text().startswith("[System]")


@pytest.mark.timeout(120)
def test_tune_and_fit_paper_default_names_never_replace_a_file(capsys, tmp_path, monkeypatch):
    """``tune`` and ``fit-paper`` without --out replaced ./paper_tuned.toml and
    ./paper.toml, an earlier result, before the tuning even started."""
    monkeypatch.chdir(tmp_path)
    for name in ("paper_tuned.toml", "paper.toml"):
        (tmp_path / name).write_text("# an earlier result\n")
    tiny = ["--scenarios", "", "--layouts", "standard", "--n", "1", "--perception", "ideal"]
    code, err = run_cli(
        capsys, "tune", *tiny, "--maxiter", "1", "--popsize", "1", "--executor", "serial"
    )
    assert code == 2 and "paper_tuned.toml: exists already" in err and "--force" in err
    code, err = run_cli(capsys, "fit-paper", "--maxiter", "1", "--popsize", "2")
    assert code == 2 and "paper.toml: exists already" in err and "--force" in err
    for name in ("paper_tuned.toml", "paper.toml"):
        assert (tmp_path / name).read_text() == "# an earlier result\n"
    # --force is there on both, and documented in their help
    for command in ("tune", "fit-paper"):
        assert main([command, "--help"]) == 0
        assert "--force" in capsys.readouterr().out


def test_report_never_replaces_the_table_beside_the_images_unless_forced(capsys, tmp_path):
    """``report OUT --readme-images docs/img`` replaced the user's docs/table4.md."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "table4.md").write_text("my table\n")
    argv = ["report", tmp_path / "r", "--controllers", "p", "--geometry", "husky"]
    code, err = run_cli(capsys, *argv, "--readme-images", docs / "img")
    assert code == 2 and "table4.md: exists already" in err and "--force" in err
    assert (docs / "table4.md").read_text() == "my table\n" and not (tmp_path / "r").exists()
    code, err = run_cli(capsys, *argv, "--readme-images", docs / "img", "--force")
    assert code == 0
    assert (docs / "table4.md").read_text() == (tmp_path / "r" / "table4.md").read_text()


# --------------------------------------------------------- 3. two outputs on one file


@pytest.mark.parametrize(
    "pair", [("--trace", "--rrd"), ("--rrd", "--figures"), ("--trace", "--figures")]
)
def test_two_outputs_on_one_file_are_refused_before_the_run(capsys, tiny, tmp_path, pair):
    """``run s1 --trace same.out --rrd same.out`` said both were written; the recording
    was lost."""
    same = tmp_path / "same.out"
    argv = ["run", tiny, "--controller", "p"]
    code, err = run_cli(capsys, *argv, pair[0], same, pair[1], same)
    assert code == 2 and "two outputs of one command on one file" in err
    assert not same.exists()


def test_two_outputs_on_one_file_through_a_link(capsys, tiny, tmp_path):
    real = tmp_path / "real.csv"
    real.write_text("old")
    link = tmp_path / "link.rrd"
    link.symlink_to(real)
    code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--trace", real, "--rrd", link)
    assert code == 2 and "two outputs of one command on one file" in err
    assert real.read_text() == "old"


# ------------------------------------------------ 6. a script without a main guard


@pytest.mark.timeout(150)
def test_sweep_with_workers_in_a_script_without_main_guard_ends(tmp_path):
    """``fuzzynav.sweep('paper', n=4, workers=2)`` at a script's top level respawned
    failing workers for ever (626 tracebacks in 45 s)."""
    script = tmp_path / "unguarded.py"
    script.write_text("import fuzzynav\nrows = fuzzynav.sweep('paper', n=4, workers=2)\n")
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=60, cwd=tmp_path
    )
    assert time.perf_counter() - started < 60
    assert done.returncode != 0
    assert 'if __name__ == "__main__":' in done.stderr and "line 2" in done.stderr
    assert done.stderr.count("Traceback") == 1  # this process's own, no worker's
    # with the guard (however the work is wrapped) it runs on two workers
    script = tmp_path / "guarded.py"
    script.write_text(
        textwrap.dedent(
            """\
            import fuzzynav


            def main():
                print(len(fuzzynav.sweep("p", n=2, workers=2)))


            if __name__ == "__main__":
                main()
            """
        )
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=90, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "2"


# ------------------------------------------------ 7. a .fis assigned binds by name


def test_a_fis_assigned_to_a_controller_binds_by_name(tmp_path):
    """``c.fis = read_fis(f)`` with the inputs renumbered bound them by position and
    timed out, where ``simulate(..., fis=f)`` bound by name and reached. Both now drive
    as the system in its own order does."""
    from fuzzynav.controller.fis_controller import reordered

    c = fuzzynav.make_controller("paper")
    system = c.fis.replace(unsensed_none=())  # MATLAB's NONE: a system a .fis can hold
    renumbered = tmp_path / "renumbered.fis"
    fuzzynav.write_fis(reordered(system, inputs=(2, 0, 3, 1), outputs=(1, 0)), renumbered)
    c.fis = fuzzynav.read_fis(renumbered)
    assert [v.name for v in c.fis.inputs] == ["d_t", "d_o", "phi_t", "phi_o"]
    assert [v.name for v in c.fis.outputs] == ["left", "right"]
    assigned = fuzzynav.simulate("s1", controller=c)
    by_option = fuzzynav.simulate("s1", fis=renumbered)
    in_order = fuzzynav.simulate("s1", fis=system)
    assert assigned.outcome == by_option.outcome == in_order.outcome
    np.testing.assert_array_equal(assigned.trace["x_m"], in_order.trace["x_m"])
    np.testing.assert_array_equal(by_option.trace["x_m"], in_order.trace["x_m"])


def test_a_fis_that_cannot_drive_is_refused_when_assigned():
    from fuzzynav.controller.fuzzy import FuzzySystem, Rule

    c = fuzzynav.make_controller("paper")
    three = FuzzySystem(c.fis.inputs[:3], c.fis.outputs, [Rule((0, 0, 0), (0, 0))], name="3")
    with pytest.raises(ValueError, match="has 3 inputs and 2 outputs"):
        c.fis = three
    assert c.fis.n_inputs == 4  # unchanged


# ------------------------------------- 10. a scenario the project writes loads again


def test_a_multi_line_unicode_description_round_trips():
    """``Scenario.to_toml`` wrote a multi-line description raw: invalid TOML (a
    recording's /meta/scenario, saved as its reproduce command says, did not load)."""
    text = 'Zwei Zeilen:\n"über" \\ Hindernisse → Ziel\tund\r\x1b zurück ✓'
    scenario = load_scenario("s1").replace(description=text, name='s1 ✓ "quoted"')
    back = loads_scenario(scenario.to_toml(), "saved.toml")
    assert back.description == escape_controls(text, keep="\n\t")
    assert back.name == 's1 ✓ "quoted"'
    assert back.replace(description=text) == scenario


@given(
    description=st.text(max_size=80),
    name=st.text(min_size=1, max_size=20),
)
def test_to_toml_always_loads_again(description, name):
    scenario = load_scenario("s1").replace(description=description, name=name)
    text = scenario.to_toml()
    back = loads_scenario(text, "saved.toml")
    assert back.description == escape_controls(description, keep="\n\t")
    assert back.name == escape_controls(name)
    # what was read writes the same text again: a fixed point after one pass
    assert loads_scenario(back.to_toml(), "again.toml").to_toml() == back.to_toml()


# ------------------------------------------------- 11. the last port, taken


@pytest.mark.timeout(90)
def test_serve_on_a_taken_last_port_says_so_and_ends():
    """``serve --port 65535`` while it was taken printed a thread's OverflowError and
    hung until Ctrl-C."""
    holder = socket.socket()
    try:
        try:
            holder.bind(("127.0.0.1", 65535))
            holder.listen()
        except OSError:
            pass  # taken already: the case itself
        done = subprocess.run(
            [sys.executable, "-m", "fuzzynav", "serve", "--port", "65535"],
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        holder.close()
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert lines[0].startswith("fuzzynav: error: --port 65535: port 65535 is in use")


# ---------------------------------------------------- 13. the API's arguments


@pytest.mark.parametrize(
    ("n", "words"), [(2.5, "n = 2.5: must be an integer"), (True, "n = True: must be")]
)
def test_sweep_refuses_a_count_that_is_no_integer(n, words):
    with pytest.raises(ValueError, match=words):
        fuzzynav.sweep("p", n=n)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"field_of_view_deg": True}, "field_of_view_deg = True: must be a number from 1 to 360"),
        ({"control_period_s": True}, "control_period_s = True: must be a number from 0.001"),
        ({"sensor_noise_std_m": 1e300}, "sensor_noise_std_m = 1e\\+300: must be a number from 0 to 10 m"),
        ({"sensor_noise_std_m": math.nan}, "sensor_noise_std_m = nan"),
        ({"sonar_side_deg": 120}, "sonar_side_deg = 120: must be a number from 1 to 90"),
        ({"seed": True}, "seed = True"),
    ],
)  # fmt: skip
def test_simulate_checks_its_arguments_as_the_command_line_does(kwargs, words):
    with pytest.raises(ValueError, match=words):
        fuzzynav.simulate("s1", controller="p", **kwargs)


def test_the_noise_limit_is_the_command_lines(capsys):
    code, err = run_cli(capsys, "run", "s1", "--controller", "p", "--noise", "1e300")
    assert code == 2 and "must be a number from 0 to 10 m" in err  # the same words


def test_a_controller_without_reset_is_refused_up_front():
    class NoReset:
        def __call__(self, inputs):
            return (1.0, 1.0)

    with pytest.raises(ValueError, match=r"has no reset\(\) method; a controller is an object"):
        fuzzynav.simulate("s1", controller=NoReset())


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (math.nan, "duration_s = nan: must be finite"),
        (-5.0, "duration_s = -5.0: must be positive"),
        (0.0, "duration_s = 0.0: must be positive"),
    ],
)
def test_a_scenario_duration_is_checked_when_replaced(value, words):
    with pytest.raises(ScenarioError, match=words):
        load_scenario("s1").replace(duration_s=value)


def test_unchanged_paths_still_work(tmp_path, p_run, matlab_twin):
    """The guard refuses what it must and nothing else."""
    out = fuzzynav.write_fis(matlab_twin, tmp_path / "mine.fis")
    assert Path(out).read_text().startswith("[System]")
    assert fuzzynav.write_fis(fuzzynav.read_fis(out), out) == out  # a path given: replaced


@pytest.mark.parametrize(
    ("argument", "value"),
    [
        ("popsize", 0),  # ran, CMA-ES taking 4
        ("popsize", math.nan),  # "cannot convert float NaN to integer"
        ("seed", -1),  # numpy's "expected non-negative integer"
        ("seed", math.nan),  # numpy's TypeError
        ("workers", 0),  # ran in this process
        ("engine", "gpu"),  # ran on pymunk
        ("control_period_s", math.nan),  # taken, unused without cases
        ("clearance_weight", math.nan),
        ("radius", math.nan),  # scipy's "argument of inverse must be within the given bounds"
        ("radius", -1.0),  # "centres must be at least three and increasing"
        ("generations", 10**9),  # the command line's --maxiter stops at 100,000
        ("x0", [1.0, 2.0]),  # "operands could not be broadcast together"
        ("x0", [math.nan] * 12),
        ("x0", "abc"),
        ("free", [99]),  # IndexError
        ("free", [-1]),  # ran, searching the last number
        ("free", []),  # "not enough values to unpack"
    ],
)
def test_tune_refuses_each_argument_out_of_reason_by_name(argument, value):
    """tune's arguments are held to the command line's ranges before any cost is asked:
    each refusal is a ValueError naming the argument and its value (some ran, the others
    failed deep in numpy or scipy with words that named neither)."""
    asked = []

    def cost(controller):
        asked.append(controller)
        return 1.0

    with pytest.raises(ValueError, match=f"^{argument} = "):
        fuzzynav.tune(cost, **{"generations": 1, argument: value})
    assert not asked
    with pytest.raises(TypeError, match="cost = 5: not callable"):
        fuzzynav.tune(5, generations=1)


def test_evaluate_and_sweep_name_layouts_and_costs_of_the_wrong_kind():
    """``layouts=2.0`` and ``scenarios=5`` raised "'float' object is not iterable", a numpy
    count was taken for scenarios, a cost that is no function failed after every run and
    one returning text failed with float()'s words."""
    for bad in (2.0, math.nan, True):
        with pytest.raises(ValueError, match=f"layouts = {bad!r}: an integer"):
            fuzzynav.evaluate(["p"], layouts=bad)
    with pytest.raises(ValueError, match="scenarios = 5: not a scenario"):
        fuzzynav.sweep("p", scenarios=5)
    with pytest.raises(ValueError, match="scenarios = "):
        fuzzynav.evaluate(["p"], layouts={"s1": 1})
    assert len(fuzzynav.evaluate(["p"], layouts=np.int64(1)).scenarios) == 1
    started = []
    with pytest.raises(TypeError, match="cost = 5: not callable"):
        fuzzynav.evaluate(["p"], layouts=1, cost=5, progress=lambda *a: started.append(a))
    assert not started  # refused before the runs
    with pytest.raises(ValueError, match="cost returned 'x': must return a real number"):
        fuzzynav.evaluate(["p"], layouts=1, cost=lambda m: "x")


def test_the_interface_names_paths_and_switches_of_the_wrong_kind(tmp_path):
    """A path that is no path (5, None, "") and a switch that is no bool ("no" is true)
    are refused by name: ``resume="no"`` went on with a file, ``summarize(show="no")``
    printed, ``write_fis("text", ...)`` raised AttributeError, ``load_scenario(5)`` and
    ``simulate(None)`` looked for a file called "5" or "None"."""
    with pytest.raises(TypeError, match="resume = 'no': must be True or False"):
        fuzzynav.sweep("p", n=1, out=tmp_path / "rows.jsonl", resume="no")
    assert not (tmp_path / "rows.jsonl").exists()
    with pytest.raises(TypeError, match="out = 5: must be a path"):
        fuzzynav.sweep("p", n=1, out=5)
    rows = fuzzynav.sweep("p", n=1)
    with pytest.raises(TypeError, match="show = 'no'"):
        fuzzynav.summarize(rows, show="no")
    with pytest.raises(ValueError, match=r"rows\[0\]: not a row of fuzzynav.sweep"):
        fuzzynav.summarize([{"a": 1}], show=False)
    with pytest.raises(TypeError, match="system = str: not a FuzzySystem"):
        fuzzynav.write_fis("text", tmp_path / "a.fis")
    with pytest.raises(TypeError, match="read_fis: path = None"):
        fuzzynav.read_fis(None)
    for bad in (5, None, ""):
        with pytest.raises(TypeError, match=f"scenario = {bad!r}: a shipped scenario's name"):
            fuzzynav.simulate(bad)
    run = fuzzynav.simulate("s1", "p")
    with pytest.raises(TypeError, match="save_rrd: path = 5"):
        run.save_rrd(5)
    with pytest.raises(TypeError, match="figures: folder = ''"):
        run.figures("")


def test_serve_refuses_switches_and_paths_of_the_wrong_kind_before_serving(monkeypatch):
    """``serve(block="no")`` served until Ctrl-C ("no" is true), ``classroom="no"``
    started a classroom, ``lesson=5`` raised os.fspath's TypeError without its name."""
    import fuzzynav.app.viewer.serve as serve_module

    started = []
    monkeypatch.setattr(serve_module, "serve", lambda *a, **k: started.append(k))
    for name in ("block", "classroom", "open_message"):
        with pytest.raises(TypeError, match=f"{name} = 'no': must be True or False"):
            fuzzynav.serve(port=0, **{name: "no"})
    with pytest.raises(TypeError, match="lesson = 5: must be a path"):
        fuzzynav.serve(port=0, block=False, lesson=5)
    assert started == []
    fuzzynav.serve(port=0, block=False)
    assert len(started) == 1
