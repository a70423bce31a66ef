"""`fuzzynav report`: recordings, figures and Table 4 for s1-s3 in one go."""

import json

import numpy as np

from fuzzynav.app.cli import main


def test_report_writes_everything(tmp_path, capsys):
    out = tmp_path / "report"
    images = tmp_path / "img"
    assert main(["report", str(out), "--controllers", "p", "--readme-images", str(images)]) == 0
    table = json.loads((out / "table4.json").read_text())
    assert [r["scenario"] for r in table["rows"]] == ["s1", "s2", "s3"]
    assert all(r["controller"] == "p" and r["paper"] is None for r in table["rows"])
    markdown = (out / "table4.md").read_text()
    assert markdown.count("\n| s") == 3 and "path_length_m" in markdown
    for scenario in ("s1", "s2", "s3"):
        assert (out / "rrd" / f"{scenario}_p.rrd").stat().st_size > 10_000
        assert (out / "figures" / f"{scenario}_p_trajectory.png").exists()
        assert (images / f"{scenario}_p_trajectory.png").exists()
    assert (out / "figures" / "comparison.png").stat().st_size > 10_000
    assert (tmp_path / "table4.md").read_text() == markdown  # the README's copy, beside img/
    assert not (images / "paper_membership.png").exists()  # only when paper is reported


def test_report_draws_the_paper_membership_overview(tmp_path, capsys):
    from PIL import Image

    images = tmp_path / "img"
    assert (
        main(
            [
                "report",
                str(tmp_path / "r"),
                "--controllers",
                "paper",
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
    import importlib.util
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    for name, argv in (
        ("fuzzynav_figure", [str(tmp_path / "design.png")]),
        ("crossing_figure", None),
    ):
        spec = importlib.util.spec_from_file_location(name, root / "scripts" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        if argv is not None:
            monkeypatch.setattr(sys, "argv", ["x"] + argv)
            module.main()
        else:
            module.main(tmp_path / "crossing.png")
    spec = importlib.util.spec_from_file_location(
        "jitter_figure", root / "scripts" / "jitter_figure.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(tmp_path / "jitter.png", n_per_scenario=1)
    for png in ("design.png", "crossing.png", "jitter.png"):
        data = (tmp_path / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
