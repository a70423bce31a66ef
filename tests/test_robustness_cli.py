"""Issue 19, command line and recordings: bad options refused before any work, write
failures said plainly (exit 2, no traceback), Ctrl-C at start-up quiet, recordings whole
or not at all. Each failed before the issue."""

from __future__ import annotations

import errno
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fuzzynav.app.cli import main

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402

from fuzzynav.app.recordings import blueprint, documents  # noqa: E402
from fuzzynav.app.recordings import record as recording  # noqa: E402
from fuzzynav.app.recordings.live import LiveRecorder  # noqa: E402


def run_cli(capsys, *argv):
    code = main(list(argv))
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err


@pytest.mark.parametrize("dt", ["1e-5", "1e-6", "1e-300", "nan", "inf", "5"])
def test_dt_beyond_reason_is_refused_with_the_bound(capsys, dt):
    """1e-5 used 4.3 GB; 1e-300 said only 'Maximum allowed dimension exceeded'."""
    code, err = run_cli(capsys, "run", "s1", "--dt", dt)
    assert code == 2 and f"argument --dt: '{dt}': must be a number from 0.001 to 1 s" in err


def test_a_run_longer_than_the_step_limit_is_refused(capsys, tmp_path):
    from fuzzynav.world.scenario import load_scenario
    from fuzzynav.world.simulation import MAX_STEPS

    path = tmp_path / "long.toml"
    path.write_text(load_scenario("s1").replace(duration_s=3600.0).to_toml())
    code, err = run_cli(capsys, "run", str(path), "--dt", "0.001")
    assert code == 2 and f"more than one run may take ({MAX_STEPS})" in err


@pytest.mark.parametrize(
    "option, value",
    [("--clearance-weight", "nan"), ("--clearance-weight", "-1"), ("--radius", "inf")],
)
def test_tune_refuses_non_finite_weights(capsys, option, value):
    """--clearance-weight nan ran to 'best cost nan' and exited 0."""
    code, err = run_cli(capsys, "tune", option, value)
    assert code == 2 and f"argument {option}: '{value}'" in err


def test_tune_refuses_an_unwritable_out_before_tuning(capsys, monkeypatch, tmp_path):
    """It failed only after the tuning was done."""
    import fuzzynav.app.experiments.tuning as tuning

    def never(*args, **kwargs):
        raise AssertionError("tuning started")

    monkeypatch.setattr(tuning, "tune", never)
    code, err = run_cli(capsys, "tune", "--out", str(tmp_path / "missing" / "t.toml"))
    assert code == 2 and "--out" in err and "does not exist" in err
    code, err = run_cli(capsys, "tune", "--out", str(tmp_path))
    assert code == 2 and "is a directory" in err
    real_mkstemp = tuning_mkstemp = __import__("tempfile").mkstemp

    def read_only(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr("tempfile.mkstemp", read_only)
    code, err = run_cli(capsys, "tune", "--out", str(tmp_path / "t.toml"))
    monkeypatch.setattr("tempfile.mkstemp", real_mkstemp)
    assert code == 2 and "cannot write in" in err and "Permission denied" in err
    del tuning_mkstemp


def test_fis_export_to_a_read_only_place_is_a_clear_error(capsys, monkeypatch, tmp_path):
    """An OSError traceback before. (The tests may run as root, who writes anywhere:
    the file system's refusal is simulated.)"""
    import fuzzynav.safe_files as safe_files

    def refuse(*args, **kwargs):
        raise PermissionError(errno.EROFS, "Read-only file system")

    # (the baseline's blocks: the paper controller's rules have no .fis form)
    old = tmp_path / "baseline_goal.fis"
    old.write_text("an old file")
    monkeypatch.setattr(safe_files.tempfile, "mkstemp", refuse)
    code, err = run_cli(
        capsys, "fis", "export", str(tmp_path), "--controller", "baseline", "--force"
    )
    assert code == 2 and "baseline_goal.fis: not written (Read-only file system)" in err
    assert old.read_text() == "an old file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["baseline_goal.fis"]
    code, err = run_cli(
        capsys, "fis", "export", "/proc/no-such-dir/blocks", "--controller", "baseline"
    )
    assert code == 2 and "error" in err


def test_fis_export_on_a_full_disk_keeps_the_old_file(capsys, monkeypatch, tmp_path):
    import fuzzynav.safe_files as safe_files

    def full(tmp, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    old = tmp_path / "baseline_goal.fis"  # (the paper controller's rules: no .fis form)
    old.write_text("an old file")
    monkeypatch.setattr(safe_files, "commit", full)
    code, err = run_cli(
        capsys, "fis", "export", str(tmp_path), "--controller", "baseline", "--force"
    )
    assert code == 2 and "No space left on device" in err
    assert old.read_text() == "an old file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["baseline_goal.fis"]  # no temporaries


def test_figures_on_a_full_disk_are_a_clear_error_and_the_recording_is_kept(
    capsys, monkeypatch, tmp_path
):
    import fuzzynav.app.figures.run_figures as figures

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(figures, "write_run_figures", full)
    rrd = tmp_path / "run.rrd"
    code, err = run_cli(capsys, "run", "s1", "--figures", str(tmp_path / "figs"), "--rrd", str(rrd))
    assert code == 2 and "--figures" in err and "No space left on device" in err
    assert rrd.is_file() and RrdReader(rrd).recordings()


def test_a_full_disk_keeps_the_old_recording_and_says_so(capsys, monkeypatch, tmp_path):
    """A full disk said "recording written", exit 0, and left a truncated file (which
    replaced a good one)."""
    rrd = tmp_path / "run.rrd"
    rrd.write_bytes(b"a good old recording")

    real_open = open

    def full_open(file, mode="r", *args, **kwargs):
        handle = real_open(file, mode, *args, **kwargs)
        if "w" in mode and Path(file).name.startswith(".run.rrd."):

            class Full:
                def __enter__(self):
                    return self

                def __exit__(self, *exc):
                    handle.close()
                    return False

                def write(self, data):
                    handle.write(data[: len(data) // 2])
                    raise OSError(errno.ENOSPC, "No space left on device")

            return Full()
        return handle

    monkeypatch.setattr("builtins.open", full_open)
    code, err = run_cli(capsys, "run", "s1", "--rrd", str(rrd))
    monkeypatch.undo()
    assert code == 2
    assert "the recording was not written (No space left on device)" in err
    assert "the file there before is unchanged" in err and "recording written" not in err
    assert rrd.read_bytes() == b"a good old recording"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]


def test_rrd_to_a_device_is_refused_before_the_run(capsys):
    """--rrd /dev/full: a RuntimeError traceback before."""
    code, err = run_cli(capsys, "run", "s1", "--rrd", "/dev/full")
    assert code == 2 and "/dev/full: is not a regular file" in err


def test_ctrl_c_while_the_recording_is_written_keeps_the_old_file(capsys, monkeypatch, tmp_path):
    """Exit 130 and a file with 1-30 of 38 entities, written in place, before."""
    rrd = tmp_path / "run.rrd"
    rrd.write_bytes(b"a good old recording")
    real = documents.metrics

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(documents, "metrics", interrupted)
    code, err = run_cli(capsys, "run", "s1", "--rrd", str(rrd))
    monkeypatch.setattr(documents, "metrics", real)
    assert code == 130
    assert "interrupted while writing the recording" in err and "old file is unchanged" in err
    assert rrd.read_bytes() == b"a good old recording"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]


def test_live_recorder_on_a_full_disk_keeps_the_partial_file_by_its_name(tmp_path, monkeypatch):
    from fuzzynav.app.runs import build_simulation

    path = tmp_path / "live.rrd"
    path.write_bytes(b"old")
    sim = build_simulation("s1", "p")
    live = LiveRecorder(path, chunk_steps=20, min_interval_s=0.0)
    for _ in range(50):
        sim.step()
        live.update(sim)
    original = live._writer.send

    def full(*args, **kwargs):
        raise RuntimeError("Failed to write: No space left on device (os error 28)")

    monkeypatch.setattr(live._writer, "send", full)
    for _ in range(30):
        sim.step()
    with pytest.raises(recording.RecordingError) as info:
        live.update(sim)
    del original
    message = str(info.value)
    assert "No space left on device" in message and "live.partial.rrd" in message
    assert path.read_bytes() == b"old"
    assert (tmp_path / "live.partial.rrd").stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["live.partial.rrd", "live.rrd"]


def test_two_runs_have_their_own_layouts(tmp_path):
    """Every recording used application id 'fuzzynav' and a blueprint with the run's
    time range: s1 opened after s2 showed s2's time range and rule count."""
    from fuzzynav.app.runs import build_simulation

    ids = []
    for scenario, controller in (("s1", "paper"), ("s2", "paper"), ("s1", "fuzzynav")):
        sim = build_simulation(scenario, controller)
        for _ in range(30):
            sim.step()
        path = recording.record_run(
            sim.result(), tmp_path / f"{scenario}-{controller}.rrd", controller=sim.controller
        )
        ids.append(RrdReader(path).recordings()[0].application_id)
    assert [i.rsplit("-", 1)[0] for i in ids] == [
        "fuzzynav-s1-paper-husky",
        "fuzzynav-s2-paper-husky",
        "fuzzynav-s1-fuzzynav-husky",
    ]
    # The layout holds no absolute time (it must fit any run of that application).
    import rerun.blueprint as rrb

    seen = []
    real = rrb.TimeRangeBoundary.absolute
    rrb.TimeRangeBoundary.absolute = lambda *a, **k: seen.append(a) or real(*a, **k)
    try:
        sim = build_simulation("s1", "paper")
        result = sim.run()
        blueprint.blueprint(result.scenario, [0, 1, 2], 40, result.log)
    finally:
        rrb.TimeRangeBoundary.absolute = real
    assert seen == []


def test_world_bounds_follow_the_robot_not_a_far_obstacle():
    from fuzzynav.app.recordings.blueprint import world_bounds
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.world.scenario import ObstacleSpec

    sim = build_simulation("s1", "paper")
    far = ObstacleSpec((4.0, 4.0), 0.3, velocity=(0.0, 0.0), acceleration=(1.0, 0.0))
    sim.reset(scenario=sim.scenario.replace(obstacles=sim.scenario.obstacles[:2] + (far,)))
    result = sim.run()
    assert result.log.obstacle_xy[:, 2, 0].max() > 1000  # it leaves for the horizon
    (x0, x1), (y0, y1) = world_bounds(result.scenario, result.log)
    assert x1 - x0 < 15 and y1 - y0 < 15  # the robot's 8 m x 8 m, with margins


@pytest.mark.parametrize("after_s", [0.02, 0.05, 0.15, 0.3, 0.6, 1.0])
def test_ctrl_c_during_start_up_prints_no_traceback(after_s):
    """A KeyboardInterrupt traceback before, while the libraries loaded. The signal comes
    ``after_s`` after fuzzynav's command-line module has loaded (``-X importtime`` says
    when; before it, Python's own import machinery runs, and right after it the line of
    pip's generated ``fuzzynav`` script that calls main(): a Ctrl-C in those few
    microseconds no program can catch), that is among the imports of numpy, scipy,
    pymunk, rich and the rest, the parsing and the run."""
    import threading

    script = Path(sys.executable).with_name("fuzzynav")
    if not script.exists():
        pytest.skip("the fuzzynav command is not installed beside this Python")
    process = subprocess.Popen(
        # a 1 ms loop makes the run itself last seconds, so that every delay below falls
        # while fuzzynav runs (on a quick machine a 20 ms run of s1 is over within 1 s and
        # a late signal met the interpreter's own exit)
        [sys.executable, "-X", "importtime", str(script), "run", "s1", "--dt", "0.001"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: list[str] = []
    loaded = threading.Event()

    def read():
        for line in process.stderr:
            lines.append(line)
            if line.rstrip().endswith("fuzzynav.app.cli"):
                loaded.set()
        loaded.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    assert loaded.wait(60)
    time.sleep(after_s)
    process.send_signal(signal.SIGINT)
    process.wait(timeout=60)
    reader.join(timeout=10)
    text = "".join(line for line in lines if not line.startswith("import time:"))
    assert "Traceback" not in text, text
    assert process.returncode in (0, 130), (process.returncode, text)


def test_an_empty_list_option_is_refused_not_taken_for_its_default(capsys, monkeypatch, tmp_path):
    """``report OUT --controllers ''`` wrote the whole default report, ``compare
    --controllers ''`` ran every controller, ``tune --free ''`` searched every number:
    an option that names nothing is refused (exit 2, nothing run), as ``,,`` was."""
    import fuzzynav.app.experiments.compare as compare_module
    import fuzzynav.app.experiments.tuning as tuning_module
    import fuzzynav.app.figures.report as report_module

    ran = []
    monkeypatch.setattr(report_module, "write_report", lambda *a, **k: ran.append("report"))
    monkeypatch.setattr(compare_module, "compare", lambda *a, **k: ran.append("compare"))
    monkeypatch.setattr(tuning_module, "tune", lambda *a, **k: ran.append("tune"))
    for argv in (
        ["report", str(tmp_path / "out"), "--controllers", ""],
        ["compare", "--controllers", ""],
        ["tune", "--free", "", "--out", str(tmp_path / "t.toml")],
        ["tune", "--perception", "", "--out", str(tmp_path / "t.toml")],
    ):
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2 and "Traceback" not in err, argv
        assert "''" in err and ("names nothing" in err or "names no controller" in err), err
    assert ran == [] and not (tmp_path / "out").exists()
