"""What the Python interface promises a study built on it: a missing scenario file is a
FileNotFoundError (and still the documented ValueError), a run's wall-clock time is kept
apart from its metrics, and the library prints nothing (what it has to say is a
warning)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import fuzzynav


def test_a_missing_scenario_file_is_a_file_not_found_error(tmp_path):
    missing = tmp_path / "nowhere.toml"
    for call in (
        lambda: fuzzynav.load_scenario(missing),
        lambda: fuzzynav.simulate(missing),
        lambda: fuzzynav.simulate("no-such-scenario"),
    ):
        with pytest.raises(FileNotFoundError, match="no such scenario file") as error:
            call()
        assert isinstance(error.value, ValueError)  # still the documented ValueError


def test_wall_time_is_timing_not_a_metric():
    run = fuzzynav.simulate("s1", "p")
    again = fuzzynav.simulate("s1", "p")
    assert "wall_time_s" not in run.metrics
    assert run.metrics == again.metrics  # the same run: the same metrics, every time
    assert run.timing["wall_time_s"] > 0.0


def test_the_library_prints_nothing():
    code = """
import warnings
warnings.simplefilter("ignore")
import fuzzynav
fuzzynav.simulate("s1", "p")
fuzzynav.sweep("p", n=2, seed=1)
fuzzynav.sweep("fuzzynav", n=1, seed=1, engine="batch")  # falls back: a warning, no print
fuzzynav.make_controller("paper")
fuzzynav.load_scenario("s2")
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "" and done.stderr == ""


def test_what_a_sweep_has_to_say_goes_to_the_fuzzynav_logger(tmp_path, caplog, capsys):
    out = tmp_path / "rows.jsonl"
    fuzzynav.sweep("p", n=2, seed=1, out=out)
    with out.open("a") as f:
        f.write('{"index": 7, "contr')  # a run cut off mid-line
    with caplog.at_level("WARNING", logger="fuzzynav"):
        rows = fuzzynav.sweep("p", n=3, seed=1, out=out, resume=True)
    assert len(rows) == 3
    assert any("unfinished last line was dropped" in r.getMessage() for r in caplog.records)
    assert capsys.readouterr() == ("", "")  # said to the logger, not printed


@pytest.mark.parametrize("folder", ["assets", "world", "controller", "fuzzynav"])
def test_no_output_goes_into_the_package_however_it_is_installed(folder):
    """An editable install as the Makefile makes it (a tree of links) or as an import
    hook, or a wheel: the package's own folders are never written into."""
    import os
    from importlib.util import find_spec

    name = "fuzzynav" if folder == "fuzzynav" else f"fuzzynav.{folder}"
    where = os.path.dirname(os.path.realpath(find_spec(name).origin))
    target = os.path.join(where, "written_by_a_test.fis")
    with pytest.raises(ValueError, match="inside the installed fuzzynav package"):
        fuzzynav.write_fis(fuzzynav.make_controller("paper").fis, target)
    assert not os.path.exists(target)
