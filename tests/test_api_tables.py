"""Sweeps' tables from Python: the scenario's name in every row, a layout range,
summarize as the command line prints it, a progress bar, and a Ctrl-C that keeps the
finished rows."""

from __future__ import annotations

import json

import pytest

import fuzzynav
from fuzzynav.app.cli import main
from fuzzynav.world.layouts import generate_layout


def test_rows_name_their_scenario():
    rows = fuzzynav.sweep("p", scenarios=["s1", "s2"], engine="pymunk")
    assert [r["scenario"] for r in rows] == ["s1", "s2"]
    assert rows[0]["family"].startswith("set:")  # the set's digest still keys the rows
    generated = fuzzynav.sweep("p", n=1, seed=4)
    assert generated[0]["scenario"] == generate_layout("standard", 4, 0).name


def test_start_runs_a_range_of_layouts_equal_to_the_same_layouts_of_a_longer_sweep():
    whole = fuzzynav.sweep("p", n=4, seed=2)
    tail = fuzzynav.sweep("p", n=2, seed=2, start=2)
    assert [r["index"] for r in tail] == [2, 3]
    for a, b in zip(tail, whole[2:]):
        assert {k: v for k, v in a.items() if k != "fingerprint"} == {
            k: v for k, v in b.items() if k != "fingerprint"
        }
    with pytest.raises(ValueError, match="start"):
        fuzzynav.sweep("p", n=2, start=-1)
    with pytest.raises(ValueError, match="start"):
        fuzzynav.sweep("p", scenarios=["s1"], start=1)


def test_an_object_on_generated_layouts_keeps_the_family_and_seed():
    from toy_controller import BatchableToy

    rows = fuzzynav.sweep(BatchableToy(), n=2, seed=3, start=1)
    assert [(r["family"], r["seed"], r["index"]) for r in rows] == [
        ("standard", 3, 1),
        ("standard", 3, 2),
    ]
    by_name = fuzzynav.sweep("p", n=2, seed=3, start=1)  # another controller, same layouts
    assert [r["scenario"] for r in rows] == [r["scenario"] for r in by_name]


def test_summarize_returns_and_prints_what_the_command_line_does(capsys):
    rows = fuzzynav.sweep("p", n=3, seed=5)
    assert main(["sweep", "--controller", "p", "--n", "3", "--seed", "5", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    summary = fuzzynav.summarize(rows)
    printed = capsys.readouterr().out
    for key, value in summary.items():
        assert cli[key] == value, key
    assert "runs" not in summary and summary["n"] == 3
    assert "success_rate" in printed and "sweep: standard layouts, seed 5" in printed
    assert fuzzynav.summarize(rows, show=False) == summary
    assert capsys.readouterr().out == ""
    other = fuzzynav.sweep("baseline", n=1, seed=5)
    with pytest.raises(ValueError, match="2 studies"):
        fuzzynav.summarize(rows + other)


def test_progress_true_draws_the_command_lines_bar(capsys):
    fuzzynav.sweep("p", n=2, seed=1, progress=True)
    assert "2/2" in capsys.readouterr().err
    with pytest.raises(ValueError, match="progress"):
        fuzzynav.sweep("p", n=2, seed=1, progress="yes")


def test_a_ctrl_c_keeps_the_finished_batches(monkeypatch, tmp_path):
    """Ctrl-C in the third batch: the two finished batches come back (and are in out)."""
    from fuzzynav.app.experiments import batch_runs, studies

    monkeypatch.setattr(batch_runs, "MIN_BATCH", 2)
    monkeypatch.setattr(batch_runs, "MAX_BATCH", 2)
    real = studies.run_task
    calls = []

    def interrupted(item):
        calls.append(item)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(item)

    monkeypatch.setattr(studies, "run_task", interrupted)
    out = tmp_path / "rows.jsonl"
    with pytest.raises(fuzzynav.SweepInterrupted) as caught:
        fuzzynav.sweep("p", n=6, seed=1, out=out)
    assert isinstance(caught.value, KeyboardInterrupt)
    assert [r["index"] for r in caught.value.rows] == [0, 1, 2, 3]
    assert len(out.read_text().splitlines()) == 4
    monkeypatch.setattr(studies, "run_task", real)
    rows = fuzzynav.sweep("p", n=6, seed=1, out=out, resume=True)
    assert rows[:4] == caught.value.rows


def test_a_batch_holds_at_most_500_runs():
    from fuzzynav.app.experiments.batch_runs import MAX_BATCH, tasks
    from fuzzynav.app.experiments.studies import sweep_jobs

    items, _ = tasks(list(sweep_jobs("p", 1200, 1)), workers=1)
    assert MAX_BATCH == 500
    assert max(len(batch) for kind, batch in items) <= 500


def test_to_dataframe_holds_the_trace_and_a_moving_obstacles_path():
    import numpy as np

    run = fuzzynav.simulate("crossing")  # one obstacle crossing at 0.3 m/s along y
    frame = run.to_dataframe()
    assert len(frame) == len(run.result.log)
    for name, column in run.trace.items():
        np.testing.assert_array_equal(frame[name].to_numpy(), column)
    assert list(frame.columns[-2:]) == ["obstacle_0_x_m", "obstacle_0_y_m"]
    t = frame["time_s"].to_numpy()
    assert np.all(frame["obstacle_0_x_m"] == 5.5)
    # where it was at each step: its start plus 0.3 m/s x t, not its start throughout
    np.testing.assert_allclose(frame["obstacle_0_y_m"], -3.5 + 0.3 * t, atol=1e-12)
    assert frame["obstacle_0_y_m"].iloc[-1] > 0.0
