"""Every public function of fuzzynav's API documents each of its parameters in a
numpydoc ``Parameters`` section (as python-control's docstrings_test.py asks)."""

from __future__ import annotations

import inspect
import re

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
