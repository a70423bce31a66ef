"""Type checkers see fuzzynav's public API through the install the Makefile makes (an
editable install in setuptools' strict mode: a tree of links mypy follows, not an import
hook it cannot): a user's script over the whole API passes ``mypy --strict``, and a
script that names a wrong type fails it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent / "typed_scripts"

pytest.importorskip("mypy")


def _mypy(tmp_path: Path, script: Path) -> subprocess.CompletedProcess:
    """``mypy --strict`` on ``script`` from an empty folder, as a user runs it: fuzzynav
    is found where this interpreter has it installed, or not at all."""
    shutil.copy(script, tmp_path / script.name)
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "PYTHONPATH")}
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", script.name],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_a_users_script_over_the_whole_api_type_checks(tmp_path):
    done = _mypy(tmp_path, HERE / "user_script.py")
    assert "import-not-found" not in done.stdout, (
        "mypy cannot find fuzzynav: install it as the Makefile does "
        "(pip install -e . --config-settings editable_mode=strict)\n" + done.stdout
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_wrong_uses_of_the_api_are_caught(tmp_path):
    done = _mypy(tmp_path, HERE / "user_mistakes.py")
    assert done.returncode == 1, done.stdout + done.stderr
    lines = [line for line in done.stdout.splitlines() if ": error:" in line]
    wrong = {int(line.split(":")[1]) for line in lines}
    source = (HERE / "user_mistakes.py").read_text().splitlines()
    expected = {k + 1 for k, line in enumerate(source) if line.endswith("# mypy: wrong")}
    assert wrong == expected, done.stdout
