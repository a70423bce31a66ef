"""Type checkers see fuzzynav's public API (issue 40 item 3): a user's script over the
whole API type-checks, and wrong uses are caught (mypy, on the package as installed)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent / "typed_scripts"

pytest.importorskip("mypy")


def _package_tree(tmp_path: Path) -> Path:
    """The import package as installed: the folders joined under one fuzzynav/."""
    package = tmp_path / "site" / "fuzzynav"
    package.mkdir(parents=True)
    for folder in ("world", "controller", "app", "assets"):
        (package / folder).symlink_to(ROOT / folder)
    for file in (ROOT / "fuzzynav").iterdir():
        if file.suffix == ".py" or file.name == "py.typed":
            (package / file.name).symlink_to(file)
    return package.parent


def _mypy(tmp_path: Path, script: Path) -> subprocess.CompletedProcess:
    site = _package_tree(tmp_path)
    shutil.copy(script, tmp_path / script.name)
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--no-incremental",
            "--ignore-missing-imports",
            "--follow-imports=silent",
            script.name,
        ],
        cwd=tmp_path,
        env={"MYPYPATH": str(site), "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_a_users_script_over_the_whole_api_type_checks(tmp_path):
    done = _mypy(tmp_path, HERE / "user_script.py")
    assert done.returncode == 0, done.stdout + done.stderr


def test_wrong_uses_of_the_api_are_caught(tmp_path):
    done = _mypy(tmp_path, HERE / "user_mistakes.py")
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stdout.count("Incompatible types in assignment") == 2, done.stdout
