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


@pytest.fixture(scope="session")
def matlab_twin():
    """The default paper controller's rule base (the Husky twin) with MATLAB's NONE: a
    system a .fis can hold. The shipped one reads Table 1's NONE as the text does, which
    a .fis cannot say (its export is refused)."""
    from fuzzynav.controller.rulebase import read_toml

    return read_toml(ROOT / "assets" / "rules" / "paper_husky.toml").replace(unsensed_none=())
