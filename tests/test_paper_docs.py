"""docs/paper-controller.md cannot drift: its generated blocks are what
``scripts/paper_check.py`` renders from docs/data/*.json, and the data are what the
shipped rule bases do today; the viewer names the rule base that drives."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from fuzzynav.app.experiments import paper_docs

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "docs" / "data"
PAGE = ROOT / "docs" / "paper-controller.md"


def _load(name):
    path = DATA / name
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else None


def _close(a, b, path="") -> None:
    """Equal, floats to 1e-9 relative (the same runs on another machine's libm)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{path}[{k}]")
    elif isinstance(a, float) and isinstance(b, float):
        assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12), (path, a, b)
    else:
        assert a == b, (path, a, b)


@pytest.fixture(scope="module")
def fresh():
    return paper_docs.shipped_runs()


def test_the_data_are_what_the_shipped_rule_bases_do(fresh):
    """docs/data/paper_controller.json holds today's runs (run scripts/paper_check.py
    after changing a rule base, a scenario or the loop)."""
    _close(json.loads(json.dumps(fresh)), _load("paper_controller.json"))


def test_the_profiles_are_the_shipped_rule_bases():
    """docs/data/paper_profiles.json: each number moved +-10 %, today's rule base."""
    _close(json.loads(json.dumps(paper_docs.profiles())), _load("paper_profiles.json"))


def test_the_page_is_rendered_from_the_data():
    blocks = paper_docs.blocks(
        _load("paper_controller.json"),
        _load("paper_readings.json"),
        _load("paper_generalise.json"),
        _load("paper_profiles.json"),
        _load("paper_binds.json"),
        _load("paper_twin_binds.json"),
        _load("paper_readings_count.json"),
        _load("paper_readings_behaviour.json"),
    )
    found = paper_docs.generated(PAGE.read_text(encoding="utf-8"))
    assert set(blocks) <= set(found), set(blocks) - set(found)
    for name, body in blocks.items():
        assert found[name] == body.strip("\n"), (
            f"block {name!r} is stale: run scripts/paper_check.py"
        )


def test_the_readme_headline_is_rendered_from_the_data():
    blocks = paper_docs.readme_blocks(
        _load("paper_controller.json"),
        _load("paper_generalise.json"),
        _load("readme_compare.json"),
    )
    found = paper_docs.generated((ROOT / "README.md").read_text(encoding="utf-8"))
    assert set(blocks) <= set(found), set(blocks) - set(found)
    for name, body in blocks.items():
        assert found[name] == body.strip("\n"), f"README block {name!r} is stale"


def test_the_readings_table_selects_what_ships():
    """The shipped paper rule base and the scenario files take the reading the readings
    table with the behaviour selects: its NONE, its field of view, its horizon, its
    layout."""
    from fuzzynav.app.experiments.paper_fit import SHIPPED_READING, Reading, select_reading
    from fuzzynav.controller.paper import PAPER_RULES
    from fuzzynav.controller.rulebase import read_toml
    from fuzzynav.world.scenario import load_scenario

    results = _load("paper_readings_behaviour.json")["results"]
    chosen = select_reading(results)
    assert (
        chosen["reading"]
        == Reading(
            0.0,
            SHIPPED_READING.none_reading,
            load_scenario("s1").field_of_view_deg,
            SHIPPED_READING.horizon,
            SHIPPED_READING.layout,
        ).label
    )
    unsensed = "NONE unsensed" in chosen["reading"]
    assert (read_toml(PAPER_RULES).unsensed_none == ("d_o",)) == unsensed
    assert not chosen["design_rules_broken"]


def test_a_stale_block_is_found():
    text = "a\n<!-- generated:x -->\nold\n<!-- /generated:x -->\nb\n"
    assert paper_docs.generated(text) == {"x": "old"}
    new = paper_docs.with_blocks(text, {"x": "new"})
    assert paper_docs.generated(new) == {"x": "new"} and new.startswith("a\n")
    with pytest.raises(ValueError, match="no generated block"):
        paper_docs.with_blocks(text, {"y": "z"})


def test_the_viewer_names_the_rule_base_that_drives():
    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.server import ViewerServer

    for geometry, words, file in (
        ("husky", "paper (Husky twin)", "paper_husky.toml"),
        ("paper", "paper (fitted in the paper&#x27;s geometry)", "paper.toml"),
    ):
        server = ViewerServer(ViewerApp("s1", "paper", geometry=geometry), port=0)
        try:
            status = server.status_line._status_html(server.app.snapshot())
            assert words in status, status
            assert f"rules/{file}" in server.controls.controller_dd.hint
        finally:
            server.stop()


def test_the_readme_table_is_todays_compare(capsys):
    """The README's random-layouts table (docs/data/readme_compare.json) is what
    ``fuzzynav compare`` gives today, for the controllers the batch engine sweeps fast
    (fuzzynav's row is its guard, measured by tests/test_fuzzynav.py's sweeps)."""
    from fuzzynav.app.cli import main

    stored = _load("readme_compare.json")
    for perception in ("ideal", "ultrasonic"):
        argv = ["compare", "--json", "--perception", perception, "--controllers", "paper,p"]
        assert main(argv + ["--executor", "serial"]) == 0
        fresh = {r["controller"]: r for r in json.loads(capsys.readouterr().out)["sweeps"]}
        for row in stored[perception]["sweeps"]:
            if row["controller"] in fresh:
                for key in ("n", "seed", "success_rate", "safe_success_rate"):
                    assert fresh[row["controller"]][key] == row[key], (
                        perception,
                        row["controller"],
                        key,
                    )


def _probe(label: str, smallest: dict, bound: float = 0.731) -> dict:
    return {
        "label": label,
        "mad_bound_m": bound,
        "evaluations": 10,
        "safe_arrivals": {p: int(v is not None) for p, v in smallest.items()},
        "smallest_safe_mad_m": smallest,
    }


def test_the_mad_alone_block_says_whether_any_safe_arrival_meets_the_bound():
    """``paper_binds.py --twin-mad``'s summary line reads the probes: none within the
    bound, or the modes where one is."""
    from fuzzynav.app.experiments.paper_binds_docs import render_twin_binds

    none_within = {
        "experiments": [],
        "mad_alone": [
            _probe("a", {"ideal": 1.3, "ultrasonic": None}),
            _probe("b", {"ideal": 1.2, "ultrasonic": 1.25}),
        ],
    }
    text = render_twin_binds(none_within)
    assert "Of 20 candidates, no safe arrival within the bound in either mode" in text
    assert "1.200 m (ideal), 1.250 m (ultrasonic)" in text
    assert "| a | 10 | 1 / 0 | 1.300 / — |" in text
    one_within = dict(none_within, mad_alone=[_probe("c", {"ideal": 0.7, "ultrasonic": 0.9})])
    assert "safe arrivals within the bound in ideal perception." in render_twin_binds(one_within)


def test_the_generalisation_data_are_the_shipped_rule_bases_runs():
    """docs/data/paper_generalise.json was made with today's rule bases (each paper row
    names its rule base's content digest; rerun scripts/paper_generalise.py after
    changing one)."""
    from load_file import load_file

    from fuzzynav.controller.paper import RULES_BY_GEOMETRY

    digest = load_file(ROOT / "scripts" / "paper_generalise.py").rule_base_digest
    rows = [r for r in _load("paper_generalise.json")["rows"] if r["controller"] == "paper"]
    assert {r["geometry"] for r in rows} == set(RULES_BY_GEOMETRY)
    for row in rows:
        shipped = RULES_BY_GEOMETRY[row["geometry"]]
        assert row["rule_base"] == shipped.name
        assert row["rule_base_sha256"] == digest(shipped), (
            f"{row['rule_base']} changed since its generalisation runs"
        )
