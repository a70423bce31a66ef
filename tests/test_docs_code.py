"""Every Python block of the README and docs/*.md runs (issue 40: docs that run).

The blocks of one page run in order, in one namespace (a later block may use what an
earlier one made), in a fresh folder, in a subprocess of their own, as a reader would
paste them. A page whose example raises, or names an API that no longer exists, fails
here with the page and the block's first line."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(page: Path) -> list[str]:
    return BLOCK.findall(page.read_text(encoding="utf-8"))


WITH_CODE = [p for p in PAGES if python_blocks(p)]


def test_the_pages_with_python_are_found():
    names = {p.name for p in WITH_CODE}
    assert {"README.md", "api.md"} <= names, names


@pytest.mark.parametrize("page", WITH_CODE, ids=lambda p: p.name)
def test_every_python_block_runs(page, tmp_path):
    script = "\n\n".join(
        f"# -- block {k + 1} of {page.name}\n{block}" for k, block in enumerate(python_blocks(page))
    )
    (tmp_path / "blocks.py").write_text(script, encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "blocks.py"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, f"{page.name}:\n{done.stderr[-3000:]}"


def test_a_failing_block_is_caught(tmp_path):
    page = tmp_path / "bad.md"
    page.write_text("text\n\n```python\nimport fuzzynav\nfuzzynav.no_such_thing()\n```\n")
    script = "\n".join(python_blocks(page))
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode != 0 and "no_such_thing" in done.stderr
