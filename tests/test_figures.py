"""The paper's figures: one file per expected name and format, valid PNG and SVG, not
blank; membership figures for a fuzzy controller; Fig. 27; --figures on the CLI."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.figures.comparison import _orient, write_comparison_figure
from fuzzynav.app.figures.membership import membership_figure_names, write_membership_figures
from fuzzynav.app.figures.numbering import RUN_FIGURES
from fuzzynav.app.figures.run_figures import write_run_figures
from fuzzynav.app.figures.style import FORMATS, check_writable_dir, obstacle_label
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
    from fuzzynav.controller.navigator.controller import fuzzynav_controller
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
    # one numbering everywhere: named as the report names them (Fig. 12 = s1's trajectory)
    from fuzzynav.app.figures.numbering import paper_figure_stem

    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        f"{paper_figure_stem('s1', n, 'p')}.{ext}" for n in RUN_FIGURES for ext in FORMATS
    )
    assert (out_dir / "fig12_s1_trajectory_p.png").exists()


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
    # s2 starts facing its target, and the P controller drives it straight, which
    # matplotlib rightly draws with a few points: a start facing +x makes it turn.
    from fuzzynav.world.scenario import load_scenario

    turning = build_simulation(load_scenario("s2").replace(heading_rad=0.0), "p").run()
    write_run_figures(turning, tmp_path / "turning", controller=None)
    svg = (tmp_path / "turning" / "trajectory.svg").read_text()
    longest = max(len(re.findall(r"\bL\b", d)) for d in re.findall(r' d="([^"]*)"', svg))
    assert longest > 20  # matplotlib simplifies a smooth path; a few markers have none


# ---------------------------------------------------------------------------------------
# The paper's figure set (issue 17 item 5)


def test_paper_figure_numbers():
    from fuzzynav.app.figures.numbering import (
        membership_figure_stem,
        paper_figure_number,
        paper_figure_stem,
    )

    expected = {"s1": range(12, 17), "s2": range(17, 22), "s3": range(22, 27)}
    for scenario, numbers in expected.items():
        assert [paper_figure_number(scenario, k) for k in RUN_FIGURES] == list(numbers)
    # the order within a scenario is the paper's: trajectory, distances, angles,
    # obstacle angles, voltages
    assert RUN_FIGURES == ("trajectory", "distances", "angles", "obstacle_angles", "voltages")
    assert paper_figure_stem("s1", "trajectory", "paper") == "fig12_s1_trajectory_paper"
    assert paper_figure_stem("s3", "voltages", "baseline") == "fig26_s3_voltages_baseline"
    assert paper_figure_number("trap", "trajectory") is None
    assert paper_figure_stem("trap", "trajectory", "paper") == "trap_trajectory_paper"
    assert membership_figure_stem("d_t", "paper") == "fig06_membership_d_t_paper"
    assert membership_figure_stem("right", "paper") == "fig11_membership_right_paper"
    assert membership_figure_stem("d_t", "baseline") == "membership_d_t_baseline"


@pytest.fixture(scope="module")
def s3_p_run():
    # the paper controller, which is still on its way during the disturbance (p is not)
    result = build_simulation("s3", "paper").run()
    assert result.log.time_s[-1] > 35.0
    return result


def _spans(ax):
    return [p for p in ax.patches if p.get_gid() == "disturbance"]


def test_s3_disturbance_is_shaded_on_every_time_axis(s3_p_run):
    from fuzzynav.app.figures.run_figures import run_figure

    window = (s3_p_run.scenario.disturbance.start_s, s3_p_run.scenario.disturbance.stop_s)
    assert window == (25.0, 35.0)
    for kind in RUN_FIGURES[1:]:  # every figure over time
        fig = run_figure(kind, s3_p_run)
        assert fig.axes, kind
        for ax in fig.axes:
            spans = _spans(ax)
            assert len(spans) == 1, (kind, ax.get_ylabel())
            box = spans[0].get_bbox()
            assert (box.x0, box.x1) == pytest.approx(window), (kind, ax.get_ylabel())
    # on the trajectory, the stretch driven during the disturbance is marked
    traj = run_figure("trajectory", s3_p_run)
    marked = [ln for ln in traj.axes[0].lines if ln.get_label().startswith("during the dist")]
    assert len(marked) == 1
    t = s3_p_run.log.time_s
    assert len(marked[0].get_xdata()) == np.count_nonzero((t >= 25.0) & (t <= 35.0))


def test_s1_has_no_disturbance_shading(p_runs):
    from fuzzynav.app.figures.run_figures import run_figure

    for kind in RUN_FIGURES:
        fig = run_figure(kind, p_runs["s1"])
        assert all(not _spans(ax) for ax in fig.axes), kind
        assert not any(
            ln.get_label().startswith("during the dist") for ax in fig.axes for ln in ax.lines
        )


def test_voltage_figure_draws_each_wheel_in_its_own_panel(s3_p_run):
    """Neither wheel hides the other: the left (v_s1) and right (v_s2) wheels each have a
    panel, sharing the time axis and the voltage scale, and a third shows the difference."""
    from fuzzynav.app.figures.run_figures import run_figure

    fig = run_figure("voltages", s3_p_run, controller_label="p")
    left, right, diff = fig.axes
    log = s3_p_run.log

    def applied(ax):
        (line,) = [ln for ln in ax.lines if ln.get_label().endswith(", applied")]
        return line

    assert applied(left).get_label() == "left (v_s1), applied"
    assert applied(right).get_label() == "right (v_s2), applied"
    np.testing.assert_array_equal(applied(left).get_ydata(), log.voltages_v[:, 0])
    np.testing.assert_array_equal(applied(right).get_ydata(), log.voltages_v[:, 1])
    (d,) = [ln for ln in diff.lines if ln.get_label().startswith("left − right")]
    np.testing.assert_allclose(d.get_ydata(), log.voltages_v[:, 0] - log.voltages_v[:, 1])
    assert left.get_shared_x_axes().joined(left, right)
    assert left.get_shared_x_axes().joined(left, diff)
    assert left.get_ylim() == right.get_ylim()
    assert "left" in left.get_ylabel() and "right" in right.get_ylabel()


def test_titles_name_the_geometry():
    from fuzzynav.app.figures.run_figures import run_figure
    from fuzzynav.world.scenario import load_scenario

    scenario = load_scenario("s1").replace(duration_s=2.0)
    for geometry in ("husky", "paper"):
        result = build_simulation(scenario, "p", geometry=geometry).run()
        for kind in RUN_FIGURES:
            fig = run_figure(kind, result, controller_label="p")
            titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
            assert titles and f"{geometry} geometry" in titles[0], (geometry, kind)
            assert "p controller" in titles[0]


def test_fig27_is_the_papers_3_by_2():
    """Rows s1-s3; columns the method of [19] (our stand-in, baseline) and the proposed
    method (paper), lettered (a)-(f) row by row as the paper's caption."""
    from fuzzynav.app.figures.comparison import comparison_figure
    from fuzzynav.app.figures.numbering import FIG27_COLUMNS, FIG27_TITLES
    from fuzzynav.world.scenario import load_scenario

    assert FIG27_COLUMNS == ("baseline", "paper")
    grid = {}
    for s in ("s1", "s2", "s3"):
        scenario = load_scenario(s).replace(duration_s=3.0)
        grid[s] = {
            c: build_simulation(scenario, c).run() for c in ("paper", "fuzzynav", "baseline")
        }
    fig = comparison_figure(grid, controllers=FIG27_COLUMNS, column_titles=FIG27_TITLES)
    assert len(fig.axes) == 6
    letters = iter("abcdef")
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        assert spec.get_geometry()[:2] == (3, 2)
        row, col = spec.rowspan.start, spec.colspan.start
        scenario, controller = f"s{row + 1}", FIG27_COLUMNS[col]
        assert ax.get_gid() == f"{scenario}/{controller}"
        assert ax.get_title().startswith(
            f"({next(letters)}) {FIG27_TITLES[controller]}, {scenario}"
        )
    assert "fuzzynav" not in " ".join(ax.get_title() for ax in fig.axes)


# ---------------------------------------------------------------------------------------
# Issue 28: one numbering, labels inside, one legend for Fig. 27, events, colours


def test_run_figure_titles_carry_the_papers_number(p_runs):
    from fuzzynav.app.figures.numbering import paper_figure_number
    from fuzzynav.app.figures.run_figures import run_figure

    for scenario, result in p_runs.items():
        for kind in RUN_FIGURES:
            fig = run_figure(kind, result, controller_label="p")
            title = next(ax.get_title() for ax in fig.axes if ax.get_title())
            assert title.startswith(f"Fig. {paper_figure_number(scenario, kind)}. "), title


def test_cli_figures_of_the_paper_controller_number_its_membership(tmp_path, capsys):
    from fuzzynav.world.scenario import load_scenario

    scenario = tmp_path / "s2.toml"  # a copy: not numbered (the paper has no such run)
    scenario.write_text(load_scenario("s2").replace(duration_s=2.0).to_toml())
    out_dir = tmp_path / "figs"
    assert main(["run", str(scenario), "--json", "--figures", str(out_dir)]) == 0
    capsys.readouterr()
    names = {p.stem for p in out_dir.glob("*.png")}
    assert "s2_trajectory_paper" in names  # no number outside s1-s3 of the paper
    assert "fig10_membership_left_paper" in names and "fig06_membership_d_t_paper" in names


def _inside(fig, artist, ax) -> bool:
    renderer = fig.canvas.get_renderer()
    box, frame = artist.get_window_extent(renderer), ax.get_window_extent(renderer)
    return (
        box.x0 >= frame.x0 - 1
        and box.x1 <= frame.x1 + 1
        and box.y0 >= frame.y0 - 1
        and box.y1 <= frame.y1 + 1
    )


def test_membership_labels_stay_inside_the_axes(tmp_path, paper_fis, monkeypatch):
    """VL peaks at the right end of the voltage range: its label reads inward."""
    import matplotlib.figure

    drawn = []
    real = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda self, *a, **k: drawn.append(self) or real(self, *a, **k),
    )
    write_membership_figures(paper_fis, tmp_path, formats=("png",))
    assert len(drawn) == len(paper_fis.inputs) + len(paper_fis.outputs)
    for fig in drawn:
        ax = fig.axes[0]
        for text in ax.texts:
            assert _inside(fig, text, ax), (ax.get_title(), text.get_text())


def test_trajectory_labels_stay_inside_and_closest_approaches_are_marked():
    """s1 in the paper's geometry: "obstacle 2" was cut off at the axes' edge."""
    from fuzzynav.app.figures.run_figures import run_figure
    from fuzzynav.app.figures.trajectory import closest_approaches

    result = build_simulation("s1", "paper", geometry="paper").run()
    fig = run_figure("trajectory", result, controller_label="paper")
    ax = fig.axes[0]
    fig.canvas.draw()
    assert {t.get_text() for t in ax.texts} >= {obstacle_label(i) for i in range(3)}
    for text in ax.texts:
        assert _inside(fig, text, ax), text.get_text()
    log = result.log
    for col, row, distance in closest_approaches(result):
        assert distance == np.nanmin(log.center_distance_m[:, col])
        assert any(t.get_text() == f"{distance:.2f} m, {log.time_s[row]:.1f} s" for t in ax.texts)
    fig = run_figure("distances", result, controller_label="paper")
    lines = [a for a in fig.axes[0].lines if a.get_gid() == "closest"]
    assert sorted(line.get_xdata()[0] for line in lines) == sorted(
        log.time_s[row] for _, row, _ in closest_approaches(result)
    )


def test_s2s_moving_obstacle_is_drawn_above_the_line_and_its_start_named(p_runs):
    from fuzzynav.app.figures.run_figures import run_figure
    from fuzzynav.app.figures.style import OBSTACLE_COLORS

    result = p_runs["s2"]
    ax = run_figure("trajectory", result).axes[0]
    labels = ax.get_legend_handles_labels()[1]
    moving = obstacle_label(1)  # s2's obstacles[1], the moving one
    assert f"{moving}'s path (moving)" in labels and f"{moving} at the start" in labels
    path = next(line for line in ax.lines if line.get_label() == f"{moving}'s path (moving)")
    straight = next(line for line in ax.lines if line.get_label() == "straight line")
    assert path.get_zorder() > straight.get_zorder()
    assert path.get_color() == OBSTACLE_COLORS[1]


def test_red_means_obstacle_0_only(s3_p_run, p_runs):
    from matplotlib.colors import to_hex

    from fuzzynav.app.figures.run_figures import run_figure
    from fuzzynav.app.figures.style import OBSTACLE_COLORS

    red = OBSTACLE_COLORS[0]
    for kind in ("angles", "voltages"):
        fig = run_figure(kind, s3_p_run)
        colours = {to_hex(line.get_color()) for ax in fig.axes for line in ax.lines}
        assert red not in colours, kind


def test_fig27_has_one_legend_and_its_own_limits_per_panel():
    from fuzzynav.app.figures.comparison import comparison_figure
    from fuzzynav.app.figures.numbering import FIG27_COLUMNS
    from fuzzynav.world.scenario import load_scenario

    grid = {}
    for s in ("s1", "s2"):
        scenario = load_scenario(s).replace(duration_s=6.0 if s == "s1" else 20.0)
        grid[s] = {c: build_simulation(scenario, c).run() for c in FIG27_COLUMNS}
    fig = comparison_figure(grid, controllers=FIG27_COLUMNS)
    assert all(ax.get_legend() is None for ax in fig.axes)
    [legend] = fig.legends
    texts = {t.get_text() for t in legend.get_texts()}
    assert {"robot (centre)", "target", "start"} <= texts
    assert f"{obstacle_label(1)}'s path (moving)" in texts  # s2's, not from panel (a)
    # every panel keeps its own limits (sharing a row's squashed (d) into (c)'s range)
    from fuzzynav.app.figures.style import _new_figure
    from fuzzynav.app.figures.trajectory import draw_trajectory

    for ax in fig.axes:
        scenario, controller = ax.get_gid().split("/")
        _, alone = _new_figure(4, 4)
        draw_trajectory(alone[0, 0], grid[scenario][controller], footprints=False, events=False)
        alone[0, 0].autoscale_view()
        assert ax.get_ylim() == alone[0, 0].get_ylim() and ax.get_xlim() == alone[0, 0].get_xlim()


# ---------------------------------------------------------------------------------------
# Issue 39 item 8: trajectory labels that never collide, every disc in the legend


def _label_boxes(fig, ax):
    from matplotlib.text import Text

    from fuzzynav.app.figures.trajectory import LABEL_GID

    renderer = fig.canvas.get_renderer()
    labels = [t for t in ax.texts if t.get_gid() == LABEL_GID]
    boxes = []
    for label in labels:
        label.update_positions(renderer)
        boxes.append((label.get_text(), Text.get_window_extent(label, renderer)))
    return boxes


def _assert_apart(fig, ax, where) -> None:
    boxes = _label_boxes(fig, ax)
    legend = ax.get_legend()
    if legend is not None:
        boxes.append(("legend", legend.get_window_extent(fig.canvas.get_renderer())))
    for i, (a, box_a) in enumerate(boxes):
        for b, box_b in boxes[i + 1 :]:
            assert not box_a.overlaps(box_b), (where, a, b)
    for label in ax.texts:
        assert _inside(fig, label, ax), (where, label.get_text())


@pytest.mark.parametrize("geometry", ["husky", "paper"])
def test_trajectory_labels_never_overlap(geometry):
    """Fig. 22's "obstacle 0" sat under a closest-approach label, the collided baseline's
    Fig. 12 stacked three, Fig. 27 (a)/(b) wrote "obstacle 1" over obstacle 0's; and the
    pale disc of a moving obstacle at its closest approach was not in the legend."""
    from fuzzynav.app.figures.comparison import comparison_figure
    from fuzzynav.app.figures.numbering import FIG27_COLUMNS
    from fuzzynav.app.figures.run_figures import run_figure
    from fuzzynav.app.figures.trajectory import _moving_columns

    grid = {}
    for s in ("s1", "s2", "s3"):
        grid[s] = {c: build_simulation(s, c, geometry=geometry).run() for c in FIG27_COLUMNS}
        for c, result in grid[s].items():
            fig = run_figure("trajectory", result, controller_label=c)
            fig.canvas.draw()
            ax = fig.axes[0]
            _assert_apart(fig, ax, (s, c))
            labels = ax.get_legend_handles_labels()[1]
            for col in _moving_columns(result.log):
                name = obstacle_label(result.log.obstacle_ids[col])
                assert f"{name} at its closest approach" in labels, (s, c, labels)
    fig = comparison_figure(grid, controllers=FIG27_COLUMNS)
    fig.canvas.draw()
    for ax in fig.axes:
        _assert_apart(fig, ax, ax.get_gid())


def test_membership_figures_under_the_papers_numbers_say_they_are_fitted(
    tmp_path, paper_fis, monkeypatch
):
    """Figs. 6-11 are drawn from fuzzynav's fitted membership functions: a figure under
    the paper's number says so on itself (its title); one without a number does not."""
    import matplotlib.figure

    from fuzzynav.app.figures.membership import FITTED_NOTE
    from fuzzynav.app.figures.numbering import MEMBERSHIP_FIGURE

    drawn = []
    monkeypatch.setattr(
        matplotlib.figure.Figure, "savefig", lambda self, *a, **k: drawn.append(self)
    )
    write_membership_figures(paper_fis, tmp_path, formats=("png",), numbers=MEMBERSHIP_FIGURE)
    titles = [fig.axes[0].get_title() for fig in drawn]
    assert len(titles) == 6
    for title in titles:
        assert title.startswith("Fig. ") and FITTED_NOTE in title, title
        assert "fitted" in FITTED_NOTE and "not the paper's" in FITTED_NOTE
    drawn.clear()
    write_membership_figures(paper_fis, tmp_path, formats=("png",))
    assert drawn and not any(FITTED_NOTE in fig.axes[0].get_title() for fig in drawn)
