"""Executors (app/experiments/executor.py), the results file (app/experiments/resultlog.py) and resuming a study:
the same rows serially, on a local pool and on a real Dask LocalCluster; an interrupted
sweep resumed ends equal to an uninterrupted one."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.experiments import studies as experiments
from fuzzynav.app.experiments.executor import (
    DaskExecutor,
    LocalExecutor,
    SerialExecutor,
    available_cpus,
    chunk_size,
    default_start_method,
    make_executor,
)
from fuzzynav.app.experiments.objective import Case
from fuzzynav.app.experiments.resultlog import ResultLog, ResultLogError
from fuzzynav.app.experiments.rows import row_key
from fuzzynav.app.experiments.studies import run_jobs, sweep_jobs
from fuzzynav.app.experiments.tuning import tune
from fuzzynav.controller.tuning import tunable
from fuzzynav.world.scenario import ObstacleSpec, load_scenario

# Small and fast: few layouts, a coarse control period (a build_simulation keyword, the
# way a --geometry option would pass through).
FAST = {"control_period_s": 0.1}


def small_jobs():
    return sweep_jobs("paper", 3, 1, options=FAST) + sweep_jobs("p", 3, 1, options=FAST)


@pytest.fixture(scope="module")
def serial_rows():
    return run_jobs(small_jobs(), SerialExecutor())


def test_available_cpus_and_chunks():
    assert available_cpus() >= 1
    if hasattr(os, "sched_getaffinity"):
        assert available_cpus() == len(os.sched_getaffinity(0))
    assert chunk_size(1, 4) == 1 and chunk_size(1000, 2) == 4 and chunk_size(0, 2) == 1
    assert chunk_size(20, 2) == 2  # about 8 tasks per worker
    assert default_start_method() in ("forkserver", "spawn")
    if sys.platform in ("darwin", "win32"):
        assert default_start_method() == "spawn"


def test_bad_executor_options_are_refused():
    with pytest.raises(ValueError, match="executor = 'threads'"):
        make_executor("threads")
    with pytest.raises(ValueError, match="workers = 0"):
        make_executor("local", 0)
    with pytest.raises(ValueError, match="only with --executor dask"):
        make_executor("local", 2, "tcp://127.0.0.1:8786")


def test_rows_carry_the_job_and_the_benchmark(serial_rows):
    assert [r["index"] for r in serial_rows] == [0, 1, 2, 0, 1, 2]
    assert [r["controller"] for r in serial_rows] == ["paper"] * 3 + ["p"] * 3
    for r in serial_rows:
        assert r["family"] == "standard" and r["seed"] == 1 and r["options"] == FAST
        assert r["shortest_path_m"] >= r["straight_line_m"] - 1e-12
        assert (r["score"] > 0) == r["success"]
        if r["success"]:
            assert r["path_ratio"] == r["path_length_m"] / r["shortest_path_m"]
            assert 0.125 <= r["score"] <= 0.5
    # the same layouts for both controllers: the same references
    assert [r["shortest_path_m"] for r in serial_rows[:3]] == [
        r["shortest_path_m"] for r in serial_rows[3:]
    ]


def test_local_pool_rows_equal_serial_rows(serial_rows):
    with LocalExecutor(2) as executor:
        assert run_jobs(small_jobs(), executor) == serial_rows
        # ordered map through the same pool (what tune's DE uses)
        assert executor.map(abs, [-3, 2, -1]) == [3, 2, 1]
    with LocalExecutor(1, start_method="spawn") as executor:
        assert run_jobs(small_jobs()[:2], executor) == serial_rows[:2]


def test_dask_local_cluster_rows_equal_serial_rows(serial_rows):
    pytest.importorskip("distributed")
    with DaskExecutor(2) as executor:
        assert executor._cluster is not None and len(executor.client.nthreads()) == 2
        assert run_jobs(small_jobs(), executor) == serial_rows
        assert executor.map(abs, range(-5, 0)) == [5, 4, 3, 2, 1]


def test_dask_keeps_a_bounded_window_of_chunks_in_flight():
    """Issue 26: the Dask executor submitted every chunk at once (a future each)."""
    pytest.importorskip("distributed")
    from app.experiments.executor import DASK_CHUNKS_IN_FLIGHT_PER_WORKER, chunk_size

    drawn = []

    def items():
        for k in range(2000):
            drawn.append(k)
            yield k

    with DaskExecutor(1) as executor:
        results = executor.imap_unordered(abs, items(), total=2000)
        next(results)
        size = chunk_size(2000, 1)
        window = DASK_CHUNKS_IN_FLIGHT_PER_WORKER * executor.workers
        # the first result came back with at most the window (and one more) drawn
        assert len(drawn) <= (window + 1) * size < 2000
        assert len([0, *results]) == 2000  # and every item still comes back
        assert sorted(executor.imap_unordered(abs, range(-50, 0), total=50)) == list(range(1, 51))


def test_tune_de_is_the_same_on_a_pool():
    sc = load_scenario("s1").replace(
        target=(2.5, 0.5), duration_s=4.0, obstacles=(ObstacleSpec((1.5, -1.2), 0.2),)
    )
    case = [Case(sc, "ideal", "tiny")]
    t = tunable("paper")
    serial = tune(
        controller=t,
        cases=case,
        method="de",
        generations=1,
        popsize=1,
        seed=3,
        control_period_s=0.1,
    )
    with LocalExecutor(2) as executor:
        pooled = tune(
            controller=t,
            cases=case,
            method="de",
            generations=1,
            popsize=1,
            seed=3,
            control_period_s=0.1,
            executor=executor,
        )
    assert np.array_equal(serial.vector, pooled.vector) and serial.cost == pooled.cost


def test_tune_cmaes_is_the_same_on_a_pool():
    sc = load_scenario("s1").replace(
        target=(2.5, 0.5), duration_s=4.0, obstacles=(ObstacleSpec((1.5, -1.2), 0.2),)
    )
    case = [Case(sc, "ideal", "tiny")]
    t = tunable("paper")
    kwargs = dict(generations=2, popsize=4, seed=3, control_period_s=0.1, method="cmaes")
    serial = tune(controller=t, cases=case, **kwargs)
    with LocalExecutor(2) as executor:
        pooled = tune(controller=t, cases=case, executor=executor, **kwargs)
    assert np.array_equal(serial.vector, pooled.vector) and serial.cost == pooled.cost


def test_workers_beyond_two_are_accepted_and_zero_refused(capsys):
    assert main(["sweep", "--n", "1", "--beside", "none", "--workers", "3", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n"] == 1
    assert main(["sweep", "--n", "1", "--workers", "0"]) == 2
    assert "--workers: '0': must be an integer from 1 to 256" in capsys.readouterr().err
    assert main(["sweep", "--n", "1", "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "only with --executor dask" in capsys.readouterr().err


# --------------------------------------------------------------------------- results file


def _lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def _sweep(tmp_path, *extra):
    return [
        "sweep",
        "--n",
        "4",
        "--seed",
        "2",
        "--controller",
        "p",
        "--beside",
        "none",
        "--json",
        *extra,
    ]


def test_out_writes_one_row_per_run_and_an_existing_file_is_refused(tmp_path, capsys):
    out = tmp_path / "runs.jsonl"
    assert main(_sweep(tmp_path, "--executor", "serial", "--out", str(out))) == 0
    summary = json.loads(capsys.readouterr().out)
    rows = _lines(out)
    assert sorted(r["index"] for r in rows) == [0, 1, 2, 3]
    assert sorted(rows, key=lambda r: r["index"]) == summary["runs"]
    for key in ("index", "family", "seed", "controller", "outcome", "shortest_path_m", "score"):
        assert all(key in r for r in rows)
    before = out.read_bytes()
    assert main(_sweep(tmp_path, "--executor", "serial", "--out", str(out))) == 2
    err = capsys.readouterr().err
    assert f"--out {out}: the file exists" in err and "--resume" in err
    assert out.read_bytes() == before  # nothing overwritten
    # resumed with nothing left to run: the same summary, no row written twice
    assert main(_sweep(tmp_path, "--executor", "serial", "--out", str(out), "--resume")) == 0
    assert json.loads(capsys.readouterr().out)["runs"] == summary["runs"]
    assert out.read_bytes() == before
    # a file of another study is refused, named
    assert main([*_sweep(tmp_path, "--out", str(out), "--resume"), "--seed", "3"]) == 2
    assert f"{out} line 1: a row of another study" in capsys.readouterr().err
    assert main(_sweep(tmp_path, "--resume")) == 2
    assert "--resume: give the --out" in capsys.readouterr().err


def test_resume_drops_a_cut_last_line_and_refuses_a_bad_one(tmp_path, capsys):
    out = tmp_path / "runs.jsonl"
    assert main(_sweep(tmp_path, "--executor", "serial", "--out", str(out))) == 0
    whole = json.loads(capsys.readouterr().out)["runs"]
    lines = out.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:2]) + lines[2][:25])  # a crash in the middle of line 3
    assert main(_sweep(tmp_path, "--executor", "serial", "--out", str(out), "--resume")) == 0
    assert json.loads(capsys.readouterr().out)["runs"] == whole
    rows = _lines(out)
    assert len(rows) == 4 and sorted(r["index"] for r in rows) == [0, 1, 2, 3]
    out.write_text(lines[0] + "not json\n" + lines[1])
    assert main(_sweep(tmp_path, "--out", str(out), "--resume")) == 2
    assert f"{out} line 2: not JSON" in capsys.readouterr().err
    with pytest.raises(ResultLogError, match="is a directory"):
        ResultLog(tmp_path, resume=True, key=row_key)
    with pytest.raises(ResultLogError, match="does not exist"):
        ResultLog(tmp_path / "no" / "x.jsonl", resume=False, key=row_key)


def test_keyboard_interrupt_after_k_rows_keeps_them_and_resume_completes(
    tmp_path, capsys, monkeypatch
):
    """Ctrl-C injected after 2 finished runs: exit 130, the 2 rows kept, a message; then
    --resume runs only the other 2 and ends equal to an uninterrupted sweep. (The pymunk
    engine: the interrupt is injected into its per-run task; the batch engine's resume is
    tests/test_batch.py's.)"""
    out = tmp_path / "runs.jsonl"
    assert main(_sweep(tmp_path, "--engine", "pymunk", "--executor", "serial")) == 0
    uninterrupted = json.loads(capsys.readouterr().out)["runs"]
    real = experiments.run_layout
    calls = []

    def interrupted_after_two(job):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(job.index)
        return real(job)

    monkeypatch.setattr(experiments, "run_layout", interrupted_after_two)
    assert (
        main(_sweep(tmp_path, "--engine", "pymunk", "--executor", "serial", "--out", str(out)))
        == 130
    )
    err = capsys.readouterr().err
    assert f"interrupted: 2 of 4 runs are in {out}" in err and "--resume" in err
    assert [r["index"] for r in _lines(out)] == [0, 1]
    monkeypatch.setattr(experiments, "run_layout", real)
    ran = []
    monkeypatch.setattr(experiments, "run_layout", lambda job: ran.append(job.index) or real(job))
    assert (
        main(
            _sweep(
                tmp_path,
                "--engine",
                "pymunk",
                "--executor",
                "serial",
                "--out",
                str(out),
                "--resume",
            )
        )
        == 0
    )
    assert ran == [2, 3]
    assert json.loads(capsys.readouterr().out)["runs"] == uninterrupted
    assert [r["index"] for r in _lines(out)] == [0, 1, 2, 3]


CHILD = (
    "import signal, sys\n"
    "signal.signal(signal.SIGINT, signal.default_int_handler)\n"  # not inherited as ignored
    "from fuzzynav.app.cli import main\n"
    "sys.exit(main(sys.argv[1:]))\n"
)


@pytest.mark.slow
def test_a_sweep_sent_sigint_keeps_its_rows_and_resumes_to_the_same_end(tmp_path, capsys):
    """A real interrupt: a sweep on a 2-worker pool in a subprocess, SIGINT once 2 rows
    are in the file; every row written is kept and whole, exit status 130; --resume
    (here on another executor) ends equal to an uninterrupted serial sweep."""
    out = tmp_path / "runs.jsonl"
    argv = [
        "sweep",
        "--n",
        "16",
        "--seed",
        "4",
        "--controller",
        "fuzzynav",
        "--beside",
        "none",
        "--json",
    ]
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, *argv, "--workers", "2", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and child.poll() is None:
        if out.exists() and out.read_text().count("\n") >= 2:
            break
        time.sleep(0.05)
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    assert child.returncode == 130, err
    kept = _lines(out)
    assert 2 <= len(kept) < 16 and len({r["index"] for r in kept}) == len(kept)
    assert f"interrupted: {len(kept)} of 16 runs are in {out}" in err
    assert main([*argv, "--executor", "serial", "--out", str(out), "--resume"]) == 0
    resumed = json.loads(capsys.readouterr().out)
    rows = _lines(out)
    assert len(rows) == 16 and sorted(r["index"] for r in rows) == list(range(16))
    assert rows[: len(kept)] == kept  # kept as written
    assert main([*argv, "--executor", "serial"]) == 0
    uninterrupted = json.loads(capsys.readouterr().out)
    assert resumed["runs"] == uninterrupted["runs"]
    for key in ("success_rate", "mean_score", "median_path_ratio", "median_time_ratio"):
        assert resumed[key] == uninterrupted[key]
