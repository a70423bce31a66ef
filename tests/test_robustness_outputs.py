"""Issue 26, outputs: no file a user names is changed unless it is the output of a
command that succeeded. Outputs never overwrite the run's inputs or the installed
package, links are followed (never replaced), pipes are streamed to, and every file is
written whole through the one atomic writer. Each test failed before the issue."""

from __future__ import annotations

import errno
import os
import threading
from pathlib import Path

import pytest

from fuzzynav.app.cli import main
from fuzzynav.resources import asset_path

TINY = (
    'name = "tiny"\nduration_s = 3.0\n[robot]\nstart = [0.0, 0.0]\n'
    "[target]\nposition = [2.5, 0.5]\n[[obstacles]]\nposition = [1.5, -1.2]\nradius_m = 0.2\n"
)


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


# --------------------------------------------------------------------------- item 2


@pytest.mark.parametrize("option", ["--trace", "--rrd"])
def test_an_output_that_is_the_runs_scenario_is_refused(capsys, tiny, option):
    """``run mine.toml --trace mine.toml`` replaced the scenario with the trace."""
    code, err = run_cli(capsys, "run", tiny, option, tiny, "--controller", "p")
    assert code == 2 and f"{option} {tiny}: is one of this run's inputs" in err
    assert tiny.read_text() == TINY


def test_an_output_that_is_the_runs_fis_is_refused_through_a_link(
    capsys, tiny, tmp_path, matlab_twin
):
    from fuzzynav.controller.fis import write_fis

    fis = tmp_path / "mine.fis"  # (the shipped rules read NONE as the text does: no .fis)
    write_fis(matlab_twin, fis)
    before = fis.read_bytes()
    link = tmp_path / "link.csv"
    link.symlink_to(fis)
    capsys.readouterr()
    code, err = run_cli(capsys, "run", tiny, "--fis", fis, "--trace", link)
    assert code == 2 and "is one of this run's inputs" in err
    assert fis.read_bytes() == before


@pytest.mark.parametrize("option", ["--rrd", "--trace"])
def test_no_output_lands_in_the_installed_package(capsys, tiny, option):
    """``run s2 --rrd <assets>/rules/paper.toml`` broke every later run."""
    shipped = asset_path("rules", "paper.toml")
    before = shipped.read_bytes()
    try:
        code, err = run_cli(capsys, "run", tiny, "--controller", "p", option, shipped)
        assert code == 2 and "is inside the installed fuzzynav package" in err
    finally:
        if shipped.read_bytes() != before:  # main: restore what it broke
            shipped.write_bytes(before)
    code, err = run_cli(capsys, "fis", "export", asset_path("rules", "paper.fis"))
    assert code == 2 and "is inside the installed fuzzynav package" in err
    assert not asset_path("rules", "paper.fis").exists()
    code, err = run_cli(capsys, "serve", "s1", "--port", "0", "--rrd", asset_path("x.rrd"))
    assert code == 2 and "is inside the installed fuzzynav package" in err
    code, err = run_cli(capsys, "report", asset_path("report"), "--controllers", "p")
    assert code == 2 and "is inside the installed fuzzynav package" in err
    code, err = run_cli(capsys, "sweep", "--n", "1", "--out", asset_path("x.jsonl"))
    assert code == 2 and "is inside the installed fuzzynav package" in err
    assert not asset_path("x.rrd").exists() and not asset_path("report").exists()
    assert not asset_path("x.jsonl").exists()


def test_an_output_through_a_link_replaces_the_file_and_keeps_the_link(capsys, tiny, tmp_path):
    """As root, ``--rrd /dev/stdout`` renamed the recording over the /dev/stdout link;
    here a link of our own, so that the old behaviour breaks nothing on the machine."""
    target = tmp_path / "real.csv"
    target.write_text("old")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--trace", link)
    assert code == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text().startswith("time_s,x_m,y_m")


@pytest.mark.timeout(60)
def test_a_trace_to_a_pipe_is_streamed(capsys, tiny, tmp_path):
    """A FIFO was refused as 'not a regular file'; a pipe is written as a stream."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []

    def read():
        with open(fifo, "rb") as stream:
            got.append(stream.read())

    reader = threading.Thread(target=read)
    reader.start()
    try:
        code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--trace", fifo)
    finally:
        if reader.is_alive():  # unblock the reader if the run never opened the pipe
            try:
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # ENXIO: the reader closed it meanwhile (it got the stream)
                pass
        reader.join(10)
    assert code == 0 and got and got[0].startswith(b"time_s,x_m,y_m")
    assert fifo.is_fifo()


def test_a_recording_to_a_device_is_still_refused(capsys, tiny):
    code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--rrd", "/dev/full")
    assert code == 2 and "not a regular file" in err


# --------------------------------------------------------------------------- item 4


def test_figures_on_a_full_disk_leave_the_old_files_whole(capsys, monkeypatch, tiny, tmp_path):
    """A full disk left a truncated trajectory.png (and SVG) over the good ones."""
    from matplotlib.figure import Figure

    figs = tmp_path / "figs"
    assert main(["run", str(tiny), "--controller", "p", "--figures", str(figs)]) == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in figs.iterdir()}
    names = set(before)
    assert any(n.endswith(".png") and "trajectory" in n for n in names), names
    assert any(n.endswith(".svg") and "trajectory" in n for n in names), names

    def full(self, fname, *args, **kwargs):
        with open(fname, "wb") as stream:
            stream.write(b"\x89PNG truncated")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full)
    code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--figures", figs, "--force")
    assert code == 2 and "No space left on device" in err
    assert {p.name: p.read_bytes() for p in figs.iterdir()} == before  # no temporaries


def _tune(tmp_path, tiny, *extra):
    return [
        "tune",
        "--scenarios",
        str(tiny),
        "--perception",
        "ideal",
        "--maxiter",
        "1",
        "--method",
        "cmaes",
        "--popsize",
        "4",
        "--executor",
        "serial",
        "--dt",
        "0.1",
        "--seed",
        "3",
        "--out",
        str(tmp_path / "tuned.toml"),
        "--json",
        *extra,
    ]


def test_a_checkpoint_on_a_full_disk_warns_and_the_tune_goes_on(
    capsys, monkeypatch, tiny, tmp_path
):
    """The checkpoint was rewritten in place: a full disk truncated the old one and
    aborted the tune without writing --out."""
    import fuzzynav.safe_files as safe_files

    checkpoint = tmp_path / "ck.txt"
    checkpoint.write_text("an old checkpoint\n")
    real_commit = safe_files.commit

    def full_for_the_checkpoint(tmp, path):
        if Path(path) == checkpoint:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_commit(tmp, path)

    monkeypatch.setattr(safe_files, "commit", full_for_the_checkpoint)
    code, err = run_cli(capsys, *_tune(tmp_path, tiny, "--checkpoint", checkpoint))
    err = " ".join(err.split())  # rich wraps the message where the path's length puts it
    assert code == 0 and "--checkpoint" in err and "not written" in err
    assert checkpoint.read_text() == "an old checkpoint\n"
    assert (tmp_path / "tuned.toml").read_text().count("[system]") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ck.txt", "mine.toml", "tuned.toml"]


def test_tune_out_on_a_full_disk_keeps_the_old_file(capsys, monkeypatch, tiny, tmp_path):
    import fuzzynav.safe_files as safe_files

    out = tmp_path / "tuned.toml"
    out.write_text("an old rule base")

    def full(tmp, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(safe_files, "commit", full)
    code, err = run_cli(capsys, *_tune(tmp_path, tiny))
    assert code == 2 and str(out) in err and "No space left on device" in err
    assert out.read_text() == "an old rule base"


def test_tune_refuses_an_out_that_is_its_x0_or_shipped(capsys, tiny, tmp_path):
    x0 = tmp_path / "x0.toml"
    x0.write_text("1 2 3\n")
    code, err = run_cli(capsys, "tune", "--x0", x0, "--out", x0)
    assert code == 2 and "is one of this run's inputs" in err and x0.read_text() == "1 2 3\n"
    code, err = run_cli(capsys, "tune", "--out", asset_path("rules", "paper.toml"))
    assert code == 2 and "inside the installed fuzzynav package" in err


def test_a_full_disk_names_the_trace_and_keeps_the_old_one(capsys, monkeypatch, tiny, tmp_path):
    import fuzzynav.safe_files as safe_files

    trace = tmp_path / "run.csv"
    trace.write_text("an old trace")

    def full(tmp, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(safe_files, "commit", full)
    code, err = run_cli(capsys, "run", tiny, "--controller", "p", "--trace", trace)
    assert code == 2 and f"{trace}: No space left on device" in err
    assert trace.read_text() == "an old trace"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.toml", "run.csv"]


def test_a_full_disk_names_the_results_file(capsys, monkeypatch, tmp_path):
    import fuzzynav.app.experiments.resultlog as resultlog

    out = tmp_path / "runs.jsonl"

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(resultlog.os, "fsync", full)
    argv = ["sweep", "--n", "1", "--controller", "p", "--beside", "none", "--executor"]
    code, err = run_cli(capsys, *argv, "serial", "--json", "--out", out)
    assert code == 2 and f"{out}: No space left on device" in err


# --------------------------------------------------------------------------- item 11


@pytest.mark.parametrize("command", ["fit-paper", "tune"])
@pytest.mark.parametrize("sigma", ["nan", "-1", "0", "inf", "2"])
def test_sigma_is_checked(capsys, command, sigma):
    """``fit-paper --sigma nan`` ran 30 generations at cost inf and exited 0."""
    code, err = run_cli(capsys, command, "--sigma", sigma)
    assert code == 2 and f"argument --sigma: '{sigma}': must be a number from 1e-06 to 1" in err


def test_cmaes_refuses_a_bad_sigma_from_code():
    from fuzzynav.app.experiments.evolution import cmaes

    with pytest.raises(ValueError, match="sigma0 = nan"):
        cmaes(lambda x: 0.0, [(0, 1)], [0.5], float("nan"), 1, 4, 0, map)


def test_report_with_no_controller_named_keeps_the_old_table(capsys, tmp_path):
    """``report DIR --controllers ,`` wrote an empty table over the earlier one, exit 0."""
    table = tmp_path / "table4.json"
    table.write_text('{"an": "earlier table"}')
    for value in (",", " , ,"):
        code, err = run_cli(capsys, "report", tmp_path, "--controllers", value)
        assert code == 2 and "names no controller" in err
    assert table.read_text() == '{"an": "earlier table"}'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table4.json"]


def test_the_paper_geometry_checks_the_start_against_a_point_robot(capsys, tmp_path):
    """An obstacle 0.45 m ahead overlaps the Husky's 0.99 m footprint but not the paper's
    point robot: ``--geometry paper`` refused it."""
    path = tmp_path / "near.toml"
    path.write_text(
        'name = "near"\nduration_s = 2.0\n[robot]\nstart = [0.0, 0.0]\n'
        "[target]\nposition = [3.0, 2.0]\n[[obstacles]]\nposition = [0.45, 0.0]\nradius_m = 0.1\n"
    )
    code, err = run_cli(capsys, "run", path, "--controller", "p", "--geometry", "paper", "--json")
    assert code == 0, err
    code, err = run_cli(capsys, "run", path, "--controller", "p")
    assert code == 2 and "overlaps the robot's footprint at its start" in err


def test_a_fit_paper_checkpoint_on_a_full_disk_warns_and_keeps_the_old_one(
    capsys, monkeypatch, tmp_path
):
    import fuzzynav.safe_files as safe_files
    from fuzzynav.app.experiments.paper_fit import _write_checkpoint

    checkpoint = tmp_path / "ck.txt"
    checkpoint.write_text("an old checkpoint\n")

    def full(tmp, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(safe_files, "commit", full)
    _write_checkpoint(checkpoint, ["a"], [1.0, 0.5], 2.0, 3)
    assert "not written at generation 3" in capsys.readouterr().err
    assert checkpoint.read_text() == "an old checkpoint\n"
    assert [p.name for p in tmp_path.iterdir()] == ["ck.txt"]


def test_a_recording_to_stdout_through_a_pipe_is_the_recording_alone(tmp_path, tiny):
    """``run --rrd /dev/stdout | ...`` wrote the run's table after the recording's bytes
    (and, as root into a file, renamed the recording over the /dev/stdout link)."""
    import subprocess
    import sys

    reader = pytest.importorskip("rerun.chunk").RrdReader
    child = subprocess.run(
        [sys.executable, "-m", "fuzzynav", "run", str(tiny), "--controller", "p"]
        + ["--rrd", "/dev/stdout"],
        capture_output=True,
        timeout=120,
    )
    assert child.returncode == 0, child.stderr
    assert b"min_clearance_m" in child.stderr and b"min_clearance_m" not in child.stdout
    got = tmp_path / "piped.rrd"
    got.write_bytes(child.stdout)
    assert reader(got).recordings()
