"""Studies from Python (issue 40 items 1 and 4): any controller, any scenarios, on every
executor, with the command line's ``--out``/``--resume`` and defaults."""

from __future__ import annotations

import json

import pytest
from toy_controller import BatchableToy, ToyController

import fuzzynav
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.scenario import ObstacleSpec

OUTCOME_FIELDS = ("index", "outcome", "path_length_m", "min_clearance_m")


def _pick(rows):
    return [tuple(row[k] for k in OUTCOME_FIELDS) for row in rows]


@pytest.fixture
def folder(tmp_path):
    """Three layouts written as scenario files of a folder of one's own."""
    for i in range(3):
        text = generate_layout("standard", 4, i).to_toml()
        (tmp_path / f"layout_{i}.toml").write_text(text, encoding="utf-8")
    return tmp_path


def test_a_controller_object_and_a_folder_of_scenarios_run_on_every_executor(folder):
    serial = fuzzynav.sweep(ToyController(), scenarios=folder, engine="pymunk")
    assert len(serial) == 3 and all(r["family"].startswith("set:") for r in serial)
    local = fuzzynav.sweep(ToyController(), scenarios=folder, engine="pymunk", workers=2)
    assert _pick(local) == _pick(serial)
    dask = fuzzynav.sweep(
        ToyController(), scenarios=folder, engine="pymunk", executor="dask", workers=2
    )
    assert _pick(dask) == _pick(serial)
    # the same layouts by name and as one's own object: the same runs
    named = [fuzzynav.simulate(f, ToyController()) for f in sorted(folder.glob("*.toml"))]
    assert [r["outcome"] for r in serial] == [run.outcome for run in named]


def test_the_batch_entry_point_drives_a_batchable_object_as_pymunk_does(folder):
    batch = fuzzynav.sweep(BatchableToy(), scenarios=folder, engine="batch")
    pymunk = fuzzynav.sweep(BatchableToy(), scenarios=folder, engine="pymunk")
    assert [r["outcome"] for r in batch] == [r["outcome"] for r in pymunk]
    for b, p in zip(batch, pymunk):
        assert b["path_length_m"] == pytest.approx(p["path_length_m"], rel=0.02)


def test_an_object_on_generated_layouts_and_a_list_of_scenarios(folder):
    rows = fuzzynav.sweep(ToyController(), n=2, seed=3, engine="pymunk")
    assert [r["index"] for r in rows] == [0, 1]
    scenarios = [fuzzynav.load_scenario("s1"), generate_layout("standard", 3, 0)]
    listed = fuzzynav.sweep("p", scenarios=scenarios)
    assert [r["n_obstacles"] for r in listed] == [len(s.obstacles) for s in scenarios]
    with pytest.raises(ValueError, match="not with scenarios"):
        fuzzynav.sweep("p", n=3, scenarios=folder)


def test_a_scenario_built_in_code_is_validated_as_a_file_is():
    s1 = fuzzynav.load_scenario("s1")
    on_the_robot = s1.replace(obstacles=(ObstacleSpec(tuple(s1.start), 0.5),))
    with pytest.raises(ValueError, match="start"):
        fuzzynav.sweep("p", scenarios=[on_the_robot])


def test_out_and_resume_from_python_keep_rows_and_refuse_to_overwrite(tmp_path):
    out = tmp_path / "rows.jsonl"
    first = fuzzynav.sweep("p", n=3, seed=2, out=out)
    assert len(out.read_text().splitlines()) == 3
    with pytest.raises(ValueError, match="exists|resume"):
        fuzzynav.sweep("p", n=3, seed=2, out=out)
    calls = []
    again = fuzzynav.sweep(
        "p", n=5, seed=2, out=out, resume=True, progress=lambda d, t: calls.append(d)
    )
    assert calls[0] == 3  # the three kept rows were not run again
    assert _pick(again[:3]) == _pick(first)
    assert len([json.loads(line) for line in out.read_text().splitlines()]) == 5
    with pytest.raises(ValueError, match="resume: give out"):
        fuzzynav.sweep("p", n=3, resume=True)


def test_python_and_the_command_line_share_their_defaults():
    import inspect

    from fuzzynav.app.cli import build_parser
    from fuzzynav.app.experiments import sweep as command

    args = build_parser().parse_args(["sweep"])
    assert (args.n, args.seed) == (command.DEFAULT_N, command.DEFAULT_SEED)
    defaults = inspect.signature(fuzzynav.sweep).parameters
    assert defaults["n"].default is None and defaults["seed"].default is None  # = the CLI's


def test_a_callable_that_is_no_controller_is_refused_with_what_it_lacks():
    # a function of the inputs is a controller (controller/function.py); one of no
    # arguments is neither that nor a controller object
    with pytest.raises(ValueError, match="no reset"):
        fuzzynav.sweep(lambda: (1.0, 1.0), n=2)


def test_simulate_checks_a_scenario_built_in_code_as_a_file_is():
    s1 = fuzzynav.load_scenario("s1")
    with pytest.raises(ValueError, match="overlaps the robot"):
        fuzzynav.simulate(s1.replace(obstacles=(ObstacleSpec(tuple(s1.start), 0.5),)), "p")
    with pytest.raises(ValueError, match="radius_m = -0.5: must be positive"):
        fuzzynav.simulate(s1.replace(obstacles=(ObstacleSpec((5.0, 5.0), -0.5),)), "p")
    assert fuzzynav.simulate(s1, "p").outcome == fuzzynav.simulate("s1", "p").outcome
