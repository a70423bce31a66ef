"""Issue 26, results files: ``--resume`` erases nothing it did not write, trusts no row
it reads back, reads only regular files of bounded size, and one file has one writer.
Counts are capped before any job is built. Each test failed before the issue."""

from __future__ import annotations

import json
import os
import threading
import time

import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.experiments import studies as experiments
from fuzzynav.app.experiments.resultlog import ResultLog, ResultLogError
from fuzzynav.app.experiments.rows import row_key


def run_cli(capsys, *argv):
    code = main(list(argv))
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err, captured.out


def sweep_argv(out, *extra):
    """A two-run sweep of the obstacle-blind ``p`` controller (fast), in this process."""
    return [
        "sweep",
        "--n",
        "2",
        "--seed",
        "2",
        "--controller",
        "p",
        "--beside",
        "none",
        "--executor",
        "serial",
        "--json",
        "--out",
        str(out),
        *extra,
    ]


@pytest.fixture(scope="module")
def good_rows(tmp_path_factory):
    """The two rows of a finished sweep, as written (lines with their newlines)."""
    out = tmp_path_factory.mktemp("rows") / "runs.jsonl"
    assert main(sweep_argv(out)) == 0
    return out.read_text().splitlines(keepends=True)


# --------------------------------------------------------------------------- item 1


@pytest.mark.parametrize(
    "content",
    [
        b'{"experiment":1}',  # one object without a newline: not a cut row of ours
        b'{"a": 1}\r{"b": 2}\r',  # carriage-return line ends: wiped whole before
        b"my notes, not a results file",
    ],
)
def test_resume_never_empties_a_file_that_is_not_a_results_log(capsys, tmp_path, content):
    """``sweep --out f.json --resume`` emptied it, wrote rows in and said 'an
    unfinished last line was dropped' (exit 0)."""
    out = tmp_path / "f.json"
    out.write_bytes(content)
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and str(out) in err and "line 1" in err
    assert out.read_bytes() == content


def test_resume_refuses_a_crlf_copy_of_a_real_results_file(capsys, tmp_path, good_rows):
    out = tmp_path / "runs.jsonl"
    content = "".join(good_rows).replace("\n", "\r\n").encode()
    out.write_bytes(content)
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and "carriage return" in err and out.read_bytes() == content


def test_a_cut_last_row_after_whole_rows_is_still_dropped(capsys, tmp_path, good_rows):
    """What --resume is for keeps working: a crash in the middle of row 2."""
    out = tmp_path / "runs.jsonl"
    out.write_text(good_rows[0] + good_rows[1][:30])
    code, err, stdout = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 0 and len(json.loads(stdout)["runs"]) == 2
    assert out.read_text() == "".join(good_rows)


# --------------------------------------------------------------------------- item 3


def _edited(good_rows, **changes):
    row = json.loads(good_rows[0])
    for name, value in changes.items():
        if value is KeyError:
            row.pop(name)
        else:
            row[name] = value
    return json.dumps(row) + "\n" + good_rows[1]


@pytest.mark.parametrize(
    "changes, needle",
    [
        ({"seed": [1]}, "seed = [1]: must be an integer"),
        ({"index": True}, "index = True: must be an integer"),
        ({"success": "false"}, "success = 'false': must be true or false"),
        ({"path_length_m": "1"}, "path_length_m = '1': must be a finite number"),
        ({"outcome": "won"}, "outcome = 'won': must be one of"),
        ({"score": 7.0}, "score = 7.0: must be from 0 to 1"),
        ({"fingerprint": KeyError}, "written by another fuzzynav version"),
    ],
)
def test_rows_read_back_are_checked_field_by_field(capsys, tmp_path, good_rows, changes, needle):
    """A wrong type was a TypeError traceback, 'success': 'false' counted as a success,
    'index': true as layout 1."""
    out = tmp_path / "runs.jsonl"
    out.write_text(_edited(good_rows, **changes))
    before = out.read_bytes()
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and f"{out} line 1: not a row of this study" in err and needle in err
    assert out.read_bytes() == before


def test_a_row_of_key_fields_only_and_a_deep_array_are_refused(capsys, tmp_path, good_rows):
    """KeyError and RecursionError tracebacks before."""
    row = json.loads(good_rows[0])
    keys_only = {k: row[k] for k in ("index", "controller", "parts_off", "family", "seed")}
    keys_only["perception"] = row["perception"]
    out = tmp_path / "runs.jsonl"
    out.write_text(json.dumps(keys_only) + "\n")
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and "line 1: not a row of this study" in err and "missing" in err
    out.write_text(good_rows[0] + "[" * 200_000 + "]" * 200_000 + "\n")
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and f"{out} line 2:" in err and "longer than any row" in err
    out.write_text(good_rows[0] + "[" * 30_000 + "]" * 30_000 + "\n")
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and f"{out} line 2:" in err


def test_rows_of_another_version_or_rule_base_are_not_merged(
    capsys, tmp_path, good_rows, monkeypatch
):
    """Rows were keyed by the options alone: rows of an older fuzzynav or another rule
    base merged in silently."""
    out = tmp_path / "runs.jsonl"
    out.write_text(_edited(good_rows, fingerprint="0123456789abcdef"))
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 2 and "line 1: a row of another study" in err and "0123456789abcdef" in err
    # what the fingerprint is made of: the version and the rule bases change it
    from fuzzynav.app.experiments.studies import study_fingerprint

    base = study_fingerprint("paper", (), "standard", 1, "ideal", {})
    import fuzzynav
    from fuzzynav.app.provenance import fuzzynav_version

    experiments._fingerprint.cache_clear()
    fuzzynav_version.cache_clear()  # read once per process: another version is another process
    monkeypatch.setattr(fuzzynav, "__version__", "99.0", raising=False)
    assert study_fingerprint("paper", (), "standard", 1, "ideal", {}) != base
    monkeypatch.undo()
    experiments._fingerprint.cache_clear()
    fuzzynav_version.cache_clear()
    monkeypatch.setitem(experiments._DIGESTS, ("paper", "husky"), "another rule base")
    assert study_fingerprint("paper", (), "standard", 1, "ideal", {}) != base
    assert study_fingerprint("paper", (), "standard", 1, "ideal", {"engine": "batch"}) != base
    experiments._fingerprint.cache_clear()


def test_failures_with_an_edited_outcome_is_bad_input_not_a_crash(capsys, tmp_path, good_rows):
    """A row whose outcome differs from the rerun raised RuntimeError (a traceback)."""
    from fuzzynav.app.experiments.rows import check_row

    row = json.loads(good_rows[0])
    row.update(outcome="timeout", reached=False, collided=False, success=False)
    if json.loads(good_rows[0])["outcome"] == "timeout":
        row.update(outcome="collided", collided=True)
    check_row(row)  # a valid row: only driving it again shows the edit
    out = tmp_path / "runs.jsonl"
    out.write_text(json.dumps(row) + "\n" + good_rows[1])
    failures = tmp_path / "failures"
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume", "--failures", str(failures)))
    assert code == 2 and f"rows read back from --out {out}" in err
    assert "does not hold this run's result" in err


# --------------------------------------------------------------------------- item 6


def test_resume_from_dev_zero_is_refused_without_reading(capsys):
    """It read 2.7 GB in 6 s."""
    start = time.perf_counter()
    code, err, _ = run_cli(capsys, *sweep_argv("/dev/zero", "--resume"))
    assert code == 2 and "/dev/zero" in err and time.perf_counter() - start < 5


@pytest.mark.timeout(20)
def test_a_fifo_as_resume_or_x0_is_refused_not_waited_on(capsys, tmp_path):
    """Both hung forever."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    code, err, _ = run_cli(capsys, *sweep_argv(fifo, "--resume"))
    assert code == 2 and str(fifo) in err and ("pipe" in err or "FIFO" in err)
    code, err, _ = run_cli(capsys, "tune", "--x0", str(fifo), "--out", str(tmp_path / "t.toml"))
    assert code == 2 and str(fifo) in err and "FIFO" in err


def test_a_results_file_over_the_cap_is_refused(tmp_path, monkeypatch):
    import fuzzynav.app.experiments.resultlog as resultlog

    out = tmp_path / "runs.jsonl"
    out.write_bytes(b"{}\n" * 100)
    monkeypatch.setattr(resultlog, "MAX_RESULTS_BYTES", 200)
    with pytest.raises(ResultLogError, match="at most 200 bytes"):
        ResultLog(out, resume=True, key=row_key)


# --------------------------------------------------------------------------- item 7


@pytest.mark.parametrize(
    "argv",
    [
        ["sweep", "--n", "100000000"],
        ["compare", "--sweep-n", "100000000"],
        ["sweep", "--workers", "300"],
    ],
)
def test_counts_are_capped_with_the_limit_named(capsys, argv):
    """--n 100000000 built 1.2 GB of jobs in 12 s before the first run."""
    start = time.perf_counter()
    code, err, _ = run_cli(capsys, *argv)
    assert code == 2 and "must be an integer from" in err and time.perf_counter() - start < 5
    assert ("100000" in err) or ("256" in err)


def test_no_more_workers_than_jobs(monkeypatch):
    """--workers 150 --n 1 started 150 processes."""
    import argparse

    from fuzzynav.app.experiments.executor import LocalExecutor, executor_from_args

    args = argparse.Namespace(executor="local", workers=150, scheduler=None)
    with executor_from_args(args, jobs=1) as executor:
        assert executor.workers == 1
    started = []

    class Pool:
        def __init__(self, processes, initializer=None):
            started.append(processes)

        def imap_unordered(self, function, items):
            return map(function, items)

    import multiprocessing

    context = multiprocessing.get_context("spawn")
    monkeypatch.setattr(type(context), "Pool", lambda self, n, initializer=None: Pool(n))
    executor = LocalExecutor(8, start_method="spawn")
    assert executor.map(abs, [-1, -2]) == [1, 2]
    assert started == [2]
    executor._pool = None


# --------------------------------------------------------------------------- item 9


def test_a_second_run_on_a_locked_results_file_refuses_with_the_pid(capsys, tmp_path, good_rows):
    """Two --resume runs on one file wrote every row twice."""
    out = tmp_path / "runs.jsonl"
    out.write_text(good_rows[0])
    first = ResultLog(out, resume=True, key=row_key).open()
    try:
        code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
        assert code == 2 and f"process {os.getpid()} is writing it" in err
        assert out.read_text() == good_rows[0]
    finally:
        first.close()
    code, err, _ = run_cli(capsys, *sweep_argv(out, "--resume"))
    assert code == 0 and out.read_text() == "".join(good_rows)


def test_the_lock_is_taken_before_the_workers_start(tmp_path, good_rows):
    """Two runs started together: only one gets the file."""
    out = tmp_path / "runs.jsonl"
    out.write_text(good_rows[0])
    logs = [ResultLog(out, resume=True, key=row_key) for _ in range(2)]
    outcomes = []

    def take(log):
        try:
            log.lock()
            outcomes.append("locked")
        except ResultLogError:
            outcomes.append("refused")

    threads = [threading.Thread(target=take, args=(log,)) for log in logs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(outcomes) == ["locked", "refused"]
    for log in logs:
        log.close()
