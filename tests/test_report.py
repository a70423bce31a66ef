"""`fuzzynav report`: recordings, figures and Table 4 for s1-s3 in one go."""

import json
import re

import numpy as np
import pytest

from fuzzynav.app.cli import main
from fuzzynav.app.figures.report import percent_difference


def test_report_writes_everything(tmp_path, capsys):
    out = tmp_path / "report"
    images = tmp_path / "img"
    argv = ["report", str(out), "--controllers", "p", "--geometry", "husky"]
    assert main(argv + ["--readme-images", str(images)]) == 0
    table = json.loads((out / "table4.json").read_text())
    assert table["geometries"] == ["husky"]
    assert [r["scenario"] for r in table["rows"]] == ["s1", "s2", "s3"]
    assert all(r["controller"] == "p" and r["paper"] is None for r in table["rows"])
    assert all(r["difference_percent"] is None for r in table["rows"])
    markdown = (out / "table4.md").read_text()
    assert markdown.count("\n| husky | s") == 3 and "path_length_m" in markdown
    for scenario, first in (("s1", 12), ("s2", 17), ("s3", 22)):
        assert (out / "rrd" / "husky" / f"{scenario}_p.rrd").stat().st_size > 10_000
        for ext in ("png", "svg"):
            name = f"fig{first}_{scenario}_trajectory_p.{ext}"
            assert (out / "figures" / "husky" / name).stat().st_size > 10_000
        assert (images / f"{scenario}_p_trajectory.png").exists()  # the docs' names
    # p is neither of Fig. 27's pair: it is drawn beside it, as 27b
    assert not (out / "figures" / "husky" / "fig27_comparison.png").exists()
    assert (out / "figures" / "husky" / "fig27b_p.png").stat().st_size > 10_000
    assert (tmp_path / "table4.md").read_text() == markdown  # the README's copy, beside img/
    assert not (images / "paper_membership.png").exists()  # only when paper is reported
    assert_index_is_complete(out / "figures")


def _index_rows(figures_dir):
    """The index's table rows as dicts of its columns, with the linked files."""
    rows = []
    for line in (figures_dir / "index.md").read_text().splitlines():
        if not line.startswith("| ") or line.startswith("| figure "):
            continue
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        figure, what, scenario, controller, geometry, files = cells
        rows.append(
            {
                "figure": figure,
                "what": what,
                "scenario": scenario,
                "controller": controller,
                "geometry": geometry,
                "files": re.findall(r"\]\(([^)]+)\)", files),
            }
        )
    return rows


def assert_index_is_complete(figures_dir):
    """Every file under figures/ is linked from the index, and every link exists."""
    rows = _index_rows(figures_dir)
    linked = [f for r in rows for f in r["files"]]
    assert len(linked) == len(set(linked))
    on_disk = {
        p.relative_to(figures_dir).as_posix()
        for p in figures_dir.rglob("*")
        if p.is_file() and p.name != "index.md"
    }
    assert set(linked) == on_disk
    for row in rows:
        assert row["files"], row
        for f in row["files"]:
            assert f.startswith(f"{row['geometry']}/"), row
    return rows


def test_percent_difference():
    assert percent_difference(11.0, 10.0) == pytest.approx(10.0)
    assert percent_difference(0.2, 0.25) == pytest.approx(-20.0)
    assert percent_difference(None, 1.0) is None
    assert percent_difference(1.0, None) is None
    assert percent_difference(1.0, 0.0) is None
    assert percent_difference(float("nan"), 1.0) is None


@pytest.fixture(scope="module")
def paper_geometry_report(tmp_path_factory):
    """``report --geometry paper`` of the two controllers Fig. 27 compares (PNG only, to
    keep it fast: SVGs are written by the test above)."""
    from fuzzynav.app.figures import style as figures

    out = tmp_path_factory.mktemp("paper-report") / "r"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(figures, "FORMATS", ("png",))
        argv = ["report", str(out), "--controllers", "paper,baseline", "--geometry", "paper"]
        assert main(argv) == 0
    return out


def test_report_in_the_paper_geometry(paper_geometry_report):
    out = paper_geometry_report
    table = json.loads((out / "table4.json").read_text())
    assert table["geometries"] == ["paper"]
    assert len(table["rows"]) == 6
    assert all(r["geometry"] == "paper" for r in table["rows"])
    markdown = (out / "table4.md").read_text()
    assert "## paper geometry" in markdown and "husky" not in markdown.split("## paper")[1]
    assert not (out / "figures" / "husky").exists() and not (out / "rrd" / "husky").exists()
    for r in table["rows"]:
        assert (out / "rrd" / "paper" / f"{r['scenario']}_{r['controller']}.rrd").exists()


def test_report_table_is_beside_the_papers_numbers(paper_geometry_report):
    """The paper controller's rows carry results.toml's numbers, baseline's [19]'s, and
    the difference in per cent is computed from the two."""
    import tomllib

    from fuzzynav.app.experiments.compare import PAPER_TABLE4, TABLE4_ROWS
    from fuzzynav.resources import asset_path

    with open(asset_path("paper", "results.toml"), "rb") as fh:
        published = tomllib.load(fh)["table4"]
    table = json.loads((paper_geometry_report / "table4.json").read_text())
    markdown = (paper_geometry_report / "table4.md").read_text()
    for row in table["rows"]:
        s = row["scenario"]
        if row["controller"] == "paper":
            expected = {k: published[s][k] for k in TABLE4_ROWS}
        else:
            expected = {k: PAPER_TABLE4["baseline"][k][int(s[1]) - 1] for k in TABLE4_ROWS}
        assert row["paper"] == expected
        for k in TABLE4_ROWS:
            ours, theirs = row[k], expected[k]
            assert row["difference_percent"][k] == pytest.approx((ours - theirs) / theirs * 100)
            assert f"{ours:.3f} ({theirs:.4g}; {(ours - theirs) / theirs * 100:+.1f} %)" in markdown
    events = [e for r in table["rows"] if r["controller"] == "paper" for e in r["events"]]
    assert len(events) == 7  # s1: three passes; s2 and s3: two each
    for e in events:
        if e["paper_time_s"] is not None and e["time_s"] is not None:
            want = (e["time_s"] - e["paper_time_s"]) / e["paper_time_s"] * 100
            assert e["time_difference_percent"] == pytest.approx(want)


def test_report_figures_are_named_by_the_papers_numbers(paper_geometry_report):
    from fuzzynav.app.figures.numbering import RUN_FIGURES

    rows = assert_index_is_complete(paper_geometry_report / "figures")
    assert {r["geometry"] for r in rows} == {"paper"}
    first = {"s1": 12, "s2": 17, "s3": 22}
    run_rows = [r for r in rows if r["scenario"] in first]
    assert len(run_rows) == 3 * 2 * len(RUN_FIGURES)
    for r in run_rows:
        number = int(r["figure"].removeprefix("Fig. "))
        kind = RUN_FIGURES[number - first[r["scenario"]]]
        (png,) = r["files"]
        assert png == f"paper/fig{number}_{r['scenario']}_{kind}_{r['controller']}.png"
    # the paper controller's membership functions are Figs. 6-11
    membership = [r for r in rows if "membership" in r["what"] and r["controller"] == "paper"]
    assert [r["figure"] for r in membership] == [f"Fig. {n}" for n in range(6, 12)]
    assert [r["what"].split()[-1] for r in membership] == [
        "d_t",
        "phi_t",
        "d_o",
        "phi_o",
        "left",
        "right",
    ]
    # other controllers' membership functions have no number in the paper
    assert all(
        r["figure"] == "—" for r in rows if "membership" in r["what"] and r["controller"] != "paper"
    )
    (fig27,) = [r for r in rows if r["figure"] == "Fig. 27"]
    assert fig27["controller"] == "baseline, paper" and fig27["scenario"] == "s1, s2, s3"
    assert fig27["files"] == ["paper/fig27_comparison.png"]
    assert not [r for r in rows if r["figure"] == "Fig. 27b"]  # no other controller


def test_report_refuses_the_paper_geometry_with_sensors(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["report", str(out), "--perception", "ultrasonic"]) == 2
    assert "--geometry" in capsys.readouterr().err
    assert not out.exists()
    assert main(["report", str(out), "--geometry", "nope"]) == 2


def test_report_draws_the_paper_membership_overview(tmp_path, capsys, monkeypatch):
    from PIL import Image

    from fuzzynav.app.figures import style as figures

    monkeypatch.setattr(figures, "FORMATS", ("png",))  # the overview is what is tested

    images = tmp_path / "img"
    assert (
        main(
            [
                "report",
                str(tmp_path / "r"),
                "--controllers",
                "paper",
                "--geometry",
                "husky",
                "--readme-images",
                str(images),
            ]
        )
        == 0
    )
    with Image.open(images / "paper_membership.png") as im:
        im.load()
        assert im.size[0] > 500 and im.size[1] > 500
        assert len(np.unique(np.asarray(im.convert("L")))) > 10  # not blank


def test_report_refuses_an_unknown_controller(tmp_path, capsys):
    assert main(["report", str(tmp_path / "r"), "--controllers", "nope"]) == 2
    assert "nope" in capsys.readouterr().err


def test_make_report_figure_scripts_run(tmp_path, monkeypatch):
    """`make report` also runs the fuzzynav figure scripts: they write their PNGs."""
    import sys
    from pathlib import Path

    from load_file import load_file

    root = Path(__file__).resolve().parents[1]
    for name, argv in (
        ("fuzzynav_figure", [str(tmp_path / "design.png")]),
        ("crossing_figure", None),
    ):
        module = load_file(root / "scripts" / f"{name}.py")
        if argv is not None:
            monkeypatch.setattr(sys, "argv", ["x"] + argv)
            module.main()
        else:
            module.main(tmp_path / "crossing.png")
    module = load_file(root / "scripts" / "jitter_figure.py")
    module.main(tmp_path / "jitter.png", n_per_scenario=1)
    for png in ("design.png", "crossing.png", "jitter.png"):
        data = (tmp_path / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
