"""docs/viewer.md cannot drift (issue 38): every number it states about the shipped
controllers is recomputed here, from the rule bases as they are now, and compared with
the guide and with docs/data/viewer_guide.json. After a rule base changes, rerun
``scripts/viewer_guide.py`` (it writes both)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from load_file import load_file

from fuzzynav.controller.registry import controller_names

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif("paper" not in controller_names(), reason="no paper controller")


@pytest.fixture(scope="module")
def guide():
    return load_file(ROOT / "scripts" / "viewer_guide.py")


@pytest.fixture(scope="module")
def fresh(guide):
    return guide.compute()


def test_the_guides_numbers_are_the_shipped_controllers_now(guide, fresh):
    """Every generated part of docs/viewer.md is what the viewer gives today (the guide
    said 112.4 s and "MOM, SOM and LOM collide" long after the rule base changed)."""
    text = (ROOT / "docs/viewer.md").read_text(encoding="utf-8")
    assert text == guide.render_guide(text, fresh), (
        "docs/viewer.md is out of date: run .venv/bin/python scripts/viewer_guide.py"
    )
    stored = json.loads((ROOT / "docs/data/viewer_guide.json").read_text(encoding="utf-8"))
    assert stored == json.loads(json.dumps(fresh)), "docs/data/viewer_guide.json is out of date"


def test_the_guide_marks_every_number_it_quotes(guide, fresh):
    """The marked parts are all there, and no marker names a fact that is not computed."""
    text = (ROOT / "docs/viewer.md").read_text(encoding="utf-8")
    blocks = {m.group("name") for m in guide.BLOCK.finditer(text)}
    assert blocks == set(guide.render_blocks(fresh))
    keys = {m.group("key") for m in guide.INLINE.finditer(text)}
    assert keys and keys <= set(fresh["facts"])
    # the old hand-typed claims are gone
    assert "112.4 s" not in text and "12 design numbers" not in text
    # every choice of the Editor's dropdowns has its run in the guide
    shown = guide.render_blocks(fresh)["choices"]
    for run in fresh["choices"][1:]:
        assert re.search(rf"\| {run['label']} `{run['choice']}` \| {run['outcome']} \|", shown)


def test_the_guide_follows_a_changed_rule_base(guide, fresh, monkeypatch):
    """A refit changes the runs: the guide rendered from them changes with them (the
    check compares with a fresh computation, never a typed number)."""
    changed = json.loads(json.dumps(fresh))
    changed["choices"][0]["time_s"] += 1.0
    changed["choices"][0]["outcome"] = "collided"
    text = (ROOT / "docs/viewer.md").read_text(encoding="utf-8")
    assert guide.render_guide(text, changed) != guide.render_guide(text, fresh)
    assert "collides at" in guide.render_blocks(changed)["choices"]
