import os
from pathlib import Path

import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]

# Hypothesis: deterministic in CI, and no deadline (the machine is shared by 2 workers).
settings.register_profile("fuzzynav", deadline=None, derandomize=True, print_blob=True)
settings.load_profile("fuzzynav")


@pytest.fixture
def write_toml(tmp_path):
    """Write TOML text to a file in tmp_path and return its path."""

    def write(text: str, name: str = "scenario.toml") -> Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write


def in_ci() -> bool:
    return bool(os.environ.get("CI"))
