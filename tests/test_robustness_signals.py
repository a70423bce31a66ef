"""Issue 26, signals: SIGTERM is Ctrl-C everywhere (what was kept is said, no temporary
file stays, exit status 143, no traceback). Each test failed before the issue: SIGTERM
killed the process where it stood."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import pytest

CHILD_SWEEP = "import sys\nfrom fuzzynav.app.cli import main\nsys.exit(main(sys.argv[1:]))\n"

# A run whose recording is being renamed into place when SIGTERM arrives: the signal
# is sent by the process to itself at that instant, so the moment is exact.
CHILD_RUN = """
import os, signal, sys
import fuzzynav.safe_files as safe_files
from fuzzynav.app.cli import main

real = safe_files.commit

def commit(tmp, path):
    os.kill(os.getpid(), signal.SIGTERM)
    return real(tmp, path)

safe_files.commit = commit
sys.exit(main(sys.argv[1:]))
"""

TINY = (
    'name = "tiny"\nduration_s = 3.0\n[robot]\nstart = [0.0, 0.0]\n'
    "[target]\nposition = [2.5, 0.5]\n"
)


def test_sigterm_while_a_recording_is_written_leaves_no_temporary_file(tmp_path):
    """``run --rrd`` left a hidden .a.rrd.*.writing file for good."""
    scenario = tmp_path / "tiny.toml"
    scenario.write_text(TINY)
    rrd = tmp_path / "a.rrd"
    rrd.write_bytes(b"an old recording")
    child = subprocess.run(
        [sys.executable, "-c", CHILD_RUN, "run", str(scenario), "--controller", "p"]
        + ["--rrd", str(rrd)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert child.returncode == 143, child.stderr
    assert "Traceback" not in child.stderr and "interrupted" in child.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.rrd", "tiny.toml"]
    assert rrd.read_bytes() == b"an old recording"


@pytest.mark.timeout(180)
def test_sigterm_during_a_pooled_sweep_keeps_the_rows_and_says_so(tmp_path):
    """Exit 143 with worker BrokenPipe tracebacks and a leaked-semaphore warning."""
    out = tmp_path / "runs.jsonl"
    # the pymunk engine: one row per task, so the signal falls while rows still arrive
    argv = ["sweep", "--n", "40", "--seed", "4", "--controller", "p", "--beside", "none"]
    argv += ["--engine", "pymunk"]
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD_SWEEP, *argv, "--workers", "2", "--out", str(out), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and child.poll() is None:
        if out.exists() and out.read_text().count("\n") >= 1:
            break
        time.sleep(0.02)
    child.send_signal(signal.SIGTERM)
    _, err = child.communicate(timeout=60)
    assert child.returncode == 143, err
    assert "Traceback" not in err and "leaked" not in err and "BrokenPipe" not in err
    kept = [json.loads(line) for line in out.read_text().splitlines()]
    assert 1 <= len(kept) and f"interrupted: {len(kept)} of 40 runs are in {out}" in err
    assert [p.name for p in tmp_path.iterdir()] == ["runs.jsonl"]


def test_sigterm_handler_is_restored_after_main():
    from fuzzynav.app.cli import main

    before = signal.getsignal(signal.SIGTERM)
    assert main(["parts", "--json"]) == 0
    assert signal.getsignal(signal.SIGTERM) is before
