"""Every public function of fuzzynav's API documents each of its parameters in a
numpydoc ``Parameters`` section (as python-control's docstrings_test.py asks), and
production code names no issue numbers (a reader cannot open them; history is in git)."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

import fuzzynav
from fuzzynav import api

PUBLIC = [
    name
    for name in fuzzynav.__all__
    if name not in ("__version__", "Run", "Evaluation", "Outcome", "SweepRow")  # types
    # an exception class takes the message alone
    and not (inspect.isclass(getattr(api, name)) and issubclass(getattr(api, name), Exception))
]


def documented(doc: str) -> set[str]:
    """The names a numpydoc Parameters section lists (``name : type`` lines, and
    ``a, b : type`` for several)."""
    if "Parameters\n" not in doc:
        return set()
    section = doc.split("Parameters\n", 1)[1].split("\nReturns", 1)[0]
    lines = re.findall(r"^(\w+(?:, \w+)*) :", section, re.M)
    return {name for line in lines for name in line.split(", ")}


@pytest.mark.parametrize("name", PUBLIC)
def test_every_parameter_is_documented(name):
    func = getattr(api, name)
    params = [p for p in inspect.signature(func).parameters if p not in ("self", "kwargs")]
    missing = set(params) - documented(inspect.getdoc(func) or "")
    assert not missing, f"fuzzynav.{name} does not document {sorted(missing)}"


def test_an_undocumented_parameter_is_found():
    def f(a, b):
        """Doc.

        Parameters
        ----------
        a : int
            The first.
        """

    assert set(inspect.signature(f).parameters) - documented(inspect.getdoc(f)) == {"b"}


ROOT = Path(__file__).resolve().parents[1]
PRODUCTION = ("world", "controller", "app", "fuzzynav")

#: "issue 35", "issues 25 and 35", "(issue 35)", "issue-35", "issue #35", and the same
#: broken over a line ("issue\n    # 35"); a web address (``.../issues/1387``) is not one.
ISSUE_NUMBER = re.compile(r"\bissues?\b[\s#:\-]*[0-9]+", re.IGNORECASE)

#: Files another piece of work is rewriting; each leaves this set once its references go
#: (test_pending_files_still_name_issues says when).
PENDING: set[str] = set()


def issue_references(text: str) -> list[tuple[int, str]]:
    """(line number, matched text) of every issue number in ``text``."""
    return [
        (text.count("\n", 0, m.start()) + 1, " ".join(m.group(0).split()))
        for m in ISSUE_NUMBER.finditer(text)
    ]


def production_files() -> list[Path]:
    return sorted(
        path
        for folder in PRODUCTION
        for path in (ROOT / folder).rglob("*.py")
        if "__pycache__" not in path.parts
    )


def test_production_code_names_no_issue_numbers():
    found = [
        f"{path.relative_to(ROOT).as_posix()}:{line}: {match}"
        for path in production_files()
        if path.relative_to(ROOT).as_posix() not in PENDING
        for line, match in issue_references(path.read_text(encoding="utf-8"))
    ]
    assert found == [], "say what the reference meant, or point into docs/:\n" + "\n".join(found)


def test_pending_files_still_name_issues():
    """An allowance outlives its reason once the file is clean: delete it from PENDING."""
    clean = sorted(
        name
        for name in PENDING
        if not (ROOT / name).exists()
        or not issue_references((ROOT / name).read_text(encoding="utf-8"))
    )
    assert clean == [], f"now clean, delete from PENDING in {__file__}: {clean}"


@pytest.mark.parametrize(
    "text",
    [
        "as issue 35 asked",
        "(issues 25 and 35)",
        "fixed in issue-35",
        "see Issue #35",
        "(issue\n        # 38: the grid)",
        "issues: 12",
    ],
)
def test_an_issue_number_is_found(text):
    assert len(issue_references(text)) == 1, text


@pytest.mark.parametrize(
    "text",
    ["https://github.com/rerun-io/rerun/issues/1387", "no issue here, 35 rows", "tissue 3"],
)
def test_what_is_not_an_issue_number(text):
    assert issue_references(text) == [], text
