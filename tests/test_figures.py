"""The paper's figures: one file per expected name and format, valid PNG and SVG, not
blank; membership figures for a fuzzy controller; Fig. 27; --figures on the CLI."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.figures import (
    FORMATS,
    RUN_FIGURES,
    _orient,
    check_writable_dir,
    membership_figure_names,
    write_comparison_figure,
    write_membership_figures,
    write_run_figures,
)
from fuzzynav.app.runs import build_simulation
from fuzzynav.controller.fis_controller import FisController
from fuzzynav.controller.rulebase import read_toml

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def assert_valid_png(path) -> None:
    from matplotlib.image import imread

    assert path.read_bytes()[:8] == PNG_MAGIC, path
    pixels = imread(path)
    assert pixels.ndim == 3 and pixels.shape[0] > 200 and pixels.shape[1] > 200, path
    grey = pixels[..., :3].mean(axis=2)
    assert grey.std() > 0.05, f"{path} looks blank"
    assert (grey < 0.5).mean() > 0.005, f"{path} has (almost) nothing drawn"


def assert_valid_svg(path) -> None:
    root = ET.parse(path).getroot()
    assert root.tag.endswith("svg"), path
    drawn = [e for e in root.iter() if e.tag.endswith(("path", "use", "polyline", "line"))]
    assert len(drawn) > 20, f"{path} has almost nothing drawn"


def assert_figures(paths, out_dir, names) -> None:
    expected = {out_dir / f"{name}.{ext}" for name in names for ext in FORMATS}
    assert set(paths) == expected and len(paths) == len(expected)
    for path in paths:
        assert path.stat().st_size > 1000
        (assert_valid_png if path.suffix == ".png" else assert_valid_svg)(path)


@pytest.fixture(scope="module")
def paper_fis():
    pytest.importorskip("fuzzynav.controller.fuzzy")
    from fuzzynav.world.scenario import ASSETS_DIR

    return read_toml(ASSETS_DIR / "rules" / "paper.toml")


@pytest.fixture(scope="module")
def p_runs():
    return {s: build_simulation(s, "p").run() for s in ("s1", "s2")}


@pytest.fixture(scope="module")
def s2_figures(tmp_path_factory, p_runs):
    out_dir = tmp_path_factory.mktemp("figs")
    return out_dir, write_run_figures(p_runs["s2"], out_dir, controller=None)


def test_run_figures_of_the_p_controller(s2_figures):
    out_dir, paths = s2_figures
    assert_figures(paths, out_dir, RUN_FIGURES)


def test_run_figures_with_a_prefix_and_a_fuzzy_controller(tmp_path, paper_fis):
    from fuzzynav.world.scenario import load_scenario

    scenario = load_scenario("s3").replace(duration_s=6.0)
    sim = build_simulation(scenario, controller_object=FisController(paper_fis))
    result = sim.run()
    paths = write_run_figures(result, tmp_path, controller=sim.controller, prefix="s3_fz_")
    names = [f"s3_fz_{n}" for n in RUN_FIGURES + tuple(membership_figure_names(paper_fis))]
    assert_figures(paths, tmp_path, names)
    assert len(membership_figure_names(paper_fis)) == 6  # 4 inputs, 2 outputs


def test_run_figures_of_fuzzynav_show_both_blocks_membership(tmp_path):
    """fuzzynav has no single ``fis``: its figures carry the membership functions of
    both blocks' inputs and outputs (goal: phi_t, d_t; avoidance: left, front, right,
    side), outputs named by block."""
    from fuzzynav.controller.fuzzynav import fuzzynav_controller
    from fuzzynav.world.scenario import load_scenario

    scenario = load_scenario("s1").replace(duration_s=4.0)
    sim = build_simulation(scenario, controller_object=fuzzynav_controller())
    paths = write_run_figures(sim.run(), tmp_path, controller=sim.controller, formats=("png",))
    variables = (
        "phi_t",
        "d_t",
        "left",
        "front",
        "right",
        "side",
        "goal_speed",
        "goal_turn",
        "avoid_speed",
        "avoid_turn",
    )
    names = list(RUN_FIGURES) + [f"membership_{v}" for v in variables]
    assert sorted(paths) == sorted(tmp_path / f"{n}.png" for n in names)
    for path in paths:
        assert_valid_png(path)


def test_membership_figures(tmp_path, paper_fis):
    paths = write_membership_figures(paper_fis, tmp_path, formats=("png",))
    names = [f"membership_{v}" for v in ("d_t", "d_o", "phi_t", "phi_o", "left", "right")]
    assert sorted(paths) == sorted(tmp_path / f"{n}.png" for n in names)
    for path in paths:
        assert_valid_png(path)


def test_comparison_figure(tmp_path, p_runs):
    gentle = build_simulation("s1", "p")
    gentle.controller.gain_heading_v_per_rad = 2.0
    grid = {"s1": {"p": p_runs["s1"], "p gentle": gentle.run()}, "s2": {"p": p_runs["s2"]}}
    paths = write_comparison_figure(grid, tmp_path)
    assert_figures(paths, tmp_path, ["comparison"])
    with pytest.raises(ValueError):
        write_comparison_figure({}, tmp_path)


def test_comparison_accepts_the_mapping_either_way_round(p_runs):
    by_scenario = {
        "s1": {"a": p_runs["s1"], "b": p_runs["s1"]},
        "s2": {"a": p_runs["s2"], "b": p_runs["s2"]},
    }
    by_controller = {
        "a": {"s1": p_runs["s1"], "s2": p_runs["s2"]},
        "b": {"s1": p_runs["s1"], "s2": p_runs["s2"]},
    }
    assert _orient(by_scenario) is by_scenario
    assert _orient(by_controller) == by_scenario


def test_figures_of_a_partial_run(tmp_path):
    sim = build_simulation("s2", "p")
    for _ in range(30):
        sim.step()
    paths = write_run_figures(sim.result(), tmp_path, formats=("png",))
    assert sorted(paths) == sorted(tmp_path / f"{n}.png" for n in RUN_FIGURES)
    for path in paths:
        assert_valid_png(path)


def test_cli_figures(tmp_path, capsys):
    out_dir = tmp_path / "new" / "figs"
    assert main(["run", "s1", "--controller", "p", "--json", "--figures", str(out_dir)]) == 0
    captured = capsys.readouterr()
    assert str(out_dir) in captured.err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        f"{n}.{ext}" for n in RUN_FIGURES for ext in FORMATS
    )


def test_cli_unwritable_figures_dir_fails_before_the_run(tmp_path, monkeypatch, capsys):
    from fuzzynav.world.simulation import Simulation

    def never(self, *a, **k):
        raise AssertionError("the run started")

    monkeypatch.setattr(Simulation, "run", never)
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    for target in (blocker, blocker / "sub"):
        assert main(["run", "s1", "--controller", "p", "--figures", str(target)]) == 2
        err = capsys.readouterr().err
        assert "--figures" in err and str(target) in err


def test_check_writable_dir_leaves_nothing_behind(tmp_path):
    target = tmp_path / "a" / "b"
    assert check_writable_dir(target) == target
    assert target.is_dir() and list(target.iterdir()) == []


def test_trajectory_is_drawn_where_the_robot_went(tmp_path, p_runs, s2_figures):
    """The trajectory differs from another run's (not a constant picture), and its SVG
    holds the robot's path as one long polyline."""
    import re

    from matplotlib.image import imread

    out_dir, _ = s2_figures
    other = write_run_figures(p_runs["s1"], tmp_path, formats=("png",))[0]
    assert other.name == "trajectory.png"
    assert not np.array_equal(imread(other), imread(out_dir / "trajectory.png"))
    svg = (out_dir / "trajectory.svg").read_text()
    longest = max(len(re.findall(r"\bL\b", d)) for d in re.findall(r' d="([^"]*)"', svg))
    assert longest > 20  # matplotlib simplifies a smooth path; a few markers have none
