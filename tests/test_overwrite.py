"""No output replaces a file that its command did not write, unless asked.

Every file a command names itself (in a folder the user gave: a report's, a sweep's
failures, figures, a .fis block export; a partial recording; a default name) is either
refused when a file is there (the path named, exit 2, nothing replaced) or written under
a fresh name that is said; ``--force`` / ``overwrite=True`` replaces. The rule is
``fuzzynav.safe_files.OutputScope``; docs/robustness.md states it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

import fuzzynav
from fuzzynav.app.cli import main
from tests.test_robustness_edges import run_cli

MINE = b"a file of the user's own\n"


def _listing(folder) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# ------------------------------------------------------------------- the one helper


def test_a_scope_refuses_what_it_did_not_write_and_rewrites_its_own(tmp_path):
    from fuzzynav.safe_files import OutputScope, write_text_atomically

    mine, new = tmp_path / "mine.txt", tmp_path / "new.txt"
    mine.write_bytes(MINE)
    with OutputScope("OUT") as scope:
        with pytest.raises(ValueError, match=r"mine.txt: exists already.*--force"):
            write_text_atomically(mine, "replaced")
        write_text_atomically(new, "one")
        write_text_atomically(new, "two")  # its own file: written again
        with pytest.raises(ValueError, match="mine.txt"):
            scope.check([new, mine])
    assert mine.read_bytes() == MINE and new.read_text() == "two"
    assert _listing(tmp_path) == ["mine.txt", "new.txt"]  # no temporary file left
    write_text_atomically(mine, "asked")  # outside a scope: a path named is asked for
    with OutputScope("OUT", overwrite=True):
        write_text_atomically(new, "forced")
    assert new.read_text() == "forced"


def test_a_partial_file_never_replaces_an_earlier_one(tmp_path):
    from fuzzynav.safe_files import discard, free_path

    target = tmp_path / "run.rrd"
    (tmp_path / "run.partial.rrd").write_bytes(MINE)
    assert free_path(tmp_path / "run.partial.rrd") == tmp_path / "run.partial-2.rrd"
    tmp = tmp_path / ".run.rrd.x.writing"
    tmp.write_bytes(b"partial bytes")
    kept = discard(tmp, target, keep_partial=True)
    assert kept == tmp_path / "run.partial-2.rrd" and kept.read_bytes() == b"partial bytes"
    assert (tmp_path / "run.partial.rrd").read_bytes() == MINE


# ------------------------------------------------------------------------- report


@pytest.mark.timeout(600)
def test_report_never_replaces_a_file_in_its_folders_unless_forced(capsys, tmp_path):
    """``report DIR --readme-images IMG`` replaced DIR/table4.md and IMG's pictures."""
    out, images = tmp_path / "r", tmp_path / "docs" / "img"
    argv = ["report", out, "--controllers", "p", "--geometry", "husky"]
    out.mkdir()
    (out / "table4.md").write_bytes(MINE)
    code, err = run_cli(capsys, *argv)
    assert code == 2 and "table4.md: exists already" in err and "--force" in err
    assert _listing(out) == ["table4.md"] and (out / "table4.md").read_bytes() == MINE
    (out / "table4.md").unlink()
    images.mkdir(parents=True)
    (images / "s1_p_trajectory.png").write_bytes(MINE)
    code, err = run_cli(capsys, *argv, "--readme-images", images)
    assert code == 2 and "s1_p_trajectory.png: exists already" in err
    assert (images / "s1_p_trajectory.png").read_bytes() == MINE and _listing(out) == []
    (images / "s1_p_trajectory.png").unlink()
    # a figure's name, known only as it is drawn: refused at its write, nothing replaced
    figure = out / "figures" / "husky" / "fig12_s1_trajectory_p.svg"
    figure.parent.mkdir(parents=True)
    figure.write_bytes(MINE)
    code, err = run_cli(capsys, *argv, "--readme-images", images)
    assert code == 2 and "fig12_s1_trajectory_p.svg: exists already" in err
    assert figure.read_bytes() == MINE and not (out / "table4.md").exists()
    assert not (images.parent / "table4.md").exists()
    # asked: everything written, the user's figure replaced
    code, err = run_cli(capsys, *argv, "--readme-images", images, "--force")
    assert code == 0 and figure.read_bytes() != MINE
    assert (images.parent / "table4.md").read_text() == (out / "table4.md").read_text()
    written = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    # run again: the earlier report is refused before a run, every file as it was
    code, err = run_cli(capsys, *argv, "--readme-images", images)
    assert code == 2 and "exists already" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == written


# -------------------------------------------------------------------- sweep --failures


def _sweep(*extra) -> list[str]:
    argv = ["sweep", "--n", "4", "--seed", "1", "--controller", "p", "--beside", "none"]
    return [*argv, *map(str, extra)]


@pytest.mark.timeout(300)
def test_sweep_failures_never_replace_a_file_in_the_folder(capsys, tmp_path):
    """``sweep --failures DIR`` replaced the scenario and .rrd files already in DIR."""
    from fuzzynav.app.experiments.sweep import write_failures

    folder = tmp_path / "failed"
    assert main(_sweep("--failures", folder, "--json")) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["failures"], "the obstacle-blind P controller should fail somewhere"
    first = data["failures"][0]
    scenario_file, recording = Path(first["scenario_file"]), Path(first["recording"])
    scenario_file.write_bytes(MINE)
    recording.write_bytes(MINE)
    before = _listing(folder)
    # refused before the sweep: its names are known for every layout
    code, err = run_cli(capsys, *_sweep("--failures", folder, "--json"))
    assert code == 2 and f"{scenario_file.name}: exists already" in err and "--force" in err
    assert _listing(folder) == before
    assert scenario_file.read_bytes() == MINE and recording.read_bytes() == MINE
    # from code: refused before any file is written
    with pytest.raises(ValueError, match="exists already"):
        write_failures(data, folder)
    assert scenario_file.read_bytes() == MINE and recording.read_bytes() == MINE
    # asked
    assert main(_sweep("--failures", folder, "--json", "--force")) == 0
    capsys.readouterr()
    assert scenario_file.read_bytes() != MINE and recording.read_bytes() != MINE
    assert _listing(folder) == before


# -------------------------------------------------------- Run.figures, run --figures


TINY = 'name = "mine"\nduration_s = 2.0\n[robot]\nstart = [0.0, 0.0]\n[target]\nposition = [2.5, 0.5]\n'


def test_run_figures_never_replaces_a_file_unless_overwrite(tmp_path, write_toml):
    """``Run.figures(folder)`` replaced a file of the same name."""
    run = fuzzynav.simulate(write_toml(TINY, name="mine.toml"), controller="p")
    tmp_path = tmp_path / "figures"
    tmp_path.mkdir()
    (tmp_path / "voltages.png").write_bytes(MINE)
    with pytest.raises(ValueError, match=r"voltages.png: exists already.*overwrite=True"):
        run.figures(tmp_path)
    assert _listing(tmp_path) == ["voltages.png"]  # refused before any figure
    (tmp_path / "voltages.png").unlink()
    written = run.figures(tmp_path)
    assert sorted(p.name for p in written) == _listing(tmp_path)
    with pytest.raises(ValueError, match="exists already"):  # an earlier call's too
        run.figures(tmp_path)
    (tmp_path / "voltages.png").write_bytes(MINE)
    assert run.figures(tmp_path, overwrite=True) == written
    assert (tmp_path / "voltages.png").read_bytes() != MINE


def test_an_overwrite_that_is_no_bool_is_refused_and_replaces_nothing(tmp_path, write_toml):
    """``overwrite="no"`` (a true text) replaced the user's file; every scope (Run.figures,
    a navigator's save and block export, the report) now takes True or False only."""
    from fuzzynav.safe_files import OutputScope

    run = fuzzynav.simulate(write_toml(TINY, name="mine.toml"), controller="p")
    tmp_path = tmp_path / "figures"
    tmp_path.mkdir()
    (tmp_path / "voltages.png").write_bytes(MINE)
    for bad in ("no", 1, None):
        with pytest.raises(TypeError, match=f"overwrite = {bad!r}: must be True or False"):
            run.figures(tmp_path, overwrite=bad)
        with pytest.raises(TypeError, match="OUT: overwrite = "):
            OutputScope("OUT", overwrite=bad)
    assert _listing(tmp_path) == ["voltages.png"]
    assert (tmp_path / "voltages.png").read_bytes() == MINE


def test_run_figures_option_never_replaces_a_file_unless_forced(capsys, tmp_path, write_toml):
    """``run --figures DIR``: refused before the run, the other outputs not written."""
    scenario = write_toml(TINY, name="mine.toml")
    figures, trace = tmp_path / "figs", tmp_path / "t.csv"
    figures.mkdir()
    (figures / "mine_trajectory_p.svg").write_bytes(MINE)
    argv = ["run", scenario, "--controller", "p", "--figures", figures, "--trace", trace]
    code, err = run_cli(capsys, *argv)
    assert code == 2 and "mine_trajectory_p.svg: exists already" in err and "--force" in err
    assert _listing(figures) == ["mine_trajectory_p.svg"] and not trace.exists()
    assert (figures / "mine_trajectory_p.svg").read_bytes() == MINE
    code, err = run_cli(capsys, *argv, "--force")
    assert code == 0 and (figures / "mine_trajectory_p.svg").read_bytes() != MINE


# ------------------------------------------------------------------------------ tune


@pytest.mark.timeout(300)
def test_tune_default_name_taken_meanwhile_gets_a_fresh_name(capsys, tmp_path, monkeypatch):
    """``tune`` checked ./paper_tuned.toml at its start only: a file made there while it
    tuned (another tune) was replaced at its end."""
    from fuzzynav.app.experiments import tuning

    monkeypatch.chdir(tmp_path)
    tune_for_real = tuning._tune_with_progress

    def another_tune_finishes_first(*args, **kwargs):
        (tmp_path / "paper_tuned.toml").write_bytes(MINE)
        return tune_for_real(*args, **kwargs)

    monkeypatch.setattr(tuning, "_tune_with_progress", another_tune_finishes_first)
    tiny = ["--scenarios", "", "--layouts", "standard", "--n", "1", "--perception", "ideal"]
    options = ["--maxiter", "1", "--popsize", "1", "--executor", "serial", "--json"]
    code, err = run_cli(capsys, "tune", *tiny, *options)
    assert code == 0 and "paper_tuned.toml exists now" in err and "paper_tuned-2.toml" in err
    assert (tmp_path / "paper_tuned.toml").read_bytes() == MINE
    assert "# tuned vector:" in (tmp_path / "paper_tuned-2.toml").read_text()


def test_fit_paper_default_name_taken_meanwhile_gets_a_fresh_name(capsys, tmp_path, monkeypatch):
    """``fit-paper`` as ``tune``: ./paper.toml made while it fitted is kept."""
    from fuzzynav.app.experiments import paper_fit_command
    from fuzzynav.controller.paper_design import PaperDesignTunable

    monkeypatch.chdir(tmp_path)

    def another_fit_finishes_first(*args, **kwargs):  # the fit itself is not what is tested
        (tmp_path / "paper.toml").write_bytes(MINE)
        return PaperDesignTunable().initial_vector(), 1.0, 1, 2

    monkeypatch.setattr(paper_fit_command, "fit", another_fit_finishes_first)
    code, err = run_cli(capsys, "fit-paper", "--maxiter", "1", "--popsize", "2", "--json")
    assert code == 0 and "paper.toml exists now" in err and "paper-2.toml" in err
    assert (tmp_path / "paper.toml").read_bytes() == MINE
    assert "# tuned vector:" in (tmp_path / "paper-2.toml").read_text()


# ------------------------------------------------------------------------ fis export


def test_fis_export_into_a_folder_never_replaces_a_file_unless_forced(capsys, tmp_path):
    """``fis export DIR --controller fuzzynav``: the names in DIR are the command's."""
    folder = tmp_path / "blocks"
    folder.mkdir()
    (folder / "fuzzynav_avoid.fis").write_bytes(MINE)
    code, err = run_cli(capsys, "fis", "export", folder, "--controller", "fuzzynav")
    assert code == 2 and "fuzzynav_avoid.fis: exists already" in err and "--force" in err
    assert _listing(folder) == ["fuzzynav_avoid.fis"]
    assert (folder / "fuzzynav_avoid.fis").read_bytes() == MINE
    assert main(["fis", "export", str(folder), "--controller", "fuzzynav", "--force"]) == 0
    assert (folder / "fuzzynav_avoid.fis").read_text().startswith("[System]")


def test_the_blocks_export_from_code_never_replaces_a_file_unless_overwrite(tmp_path):
    from fuzzynav.controller.navigator.controller import export_fis

    (tmp_path / "fuzzynav_avoid.fis").write_bytes(MINE)
    with pytest.raises(ValueError, match=r"fuzzynav_avoid.fis: exists already.*overwrite=True"):
        export_fis(tmp_path)
    assert _listing(tmp_path) == ["fuzzynav_avoid.fis"]  # neither block written
    assert export_fis(tmp_path, overwrite=True) == [
        tmp_path / "fuzzynav_goal.fis",
        tmp_path / "fuzzynav_avoid.fis",
    ]
    assert (tmp_path / "fuzzynav_avoid.fis").read_text().startswith("[System]")


def test_tuned_memberships_never_replace_rule_bases_beside_the_file(tmp_path):
    """``FuzzyNavTunable(tune_memberships=True).save(x, path)`` wrote the two rule bases
    beside ``path`` over whatever was there."""
    from fuzzynav.controller.navigator.tuning import FuzzyNavTunable

    tunable = FuzzyNavTunable(tune_memberships=True)
    x = tunable.initial_vector()
    (tmp_path / "fuzzynav_goal.toml").write_bytes(MINE)
    with pytest.raises(ValueError, match="fuzzynav_goal.toml: exists already"):
        tunable.save(x, tmp_path / "params.toml")
    assert _listing(tmp_path) == ["fuzzynav_goal.toml"]  # not even the parameters
    written = tunable.save(x, tmp_path / "params.toml", overwrite=True)
    assert [p.name for p in written] == ["params.toml", "fuzzynav_goal.toml", "fuzzynav_avoid.toml"]
    assert (tmp_path / "fuzzynav_goal.toml").read_bytes() != MINE


# --------------------------------------------------------------- partial recordings


def test_an_interrupted_run_keeps_an_earlier_partial_recording(tmp_path, monkeypatch, capsys):
    """Ctrl-C during ``run --rrd x.rrd`` replaced an earlier ``x.partial.rrd``."""
    from fuzzynav.controller.proportional import ProportionalController

    class InterruptedAfter(ProportionalController):
        calls = 0

        def __call__(self, inputs):
            InterruptedAfter.calls += 1
            if InterruptedAfter.calls > 30:
                raise KeyboardInterrupt
            return super().__call__(inputs)

    import fuzzynav.app.runs

    monkeypatch.setattr(
        fuzzynav.app.runs, "make_controller", lambda name, fis_path=None, **kw: InterruptedAfter()
    )
    (tmp_path / "x.partial.rrd").write_bytes(MINE)
    assert main(["run", "s1", "--controller", "p", "--rrd", str(tmp_path / "x.rrd")]) == 130
    err = capsys.readouterr().err
    assert "x.partial-2.rrd" in err
    assert (tmp_path / "x.partial.rrd").read_bytes() == MINE
    assert os.listdir(tmp_path) and sorted(os.listdir(tmp_path)) == [
        "x.partial-2.rrd",
        "x.partial.rrd",
    ]
