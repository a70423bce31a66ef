"""scripts/paper_coordinate.py's ordering of moves (issue 35): bounds met first, then
either the fit's cost or, with ``--toward-missed``, how far the missed numeric bounds
lie beyond their bounds; ``--steps`` sets the moves tried."""

from __future__ import annotations

from pathlib import Path

import pytest
from load_file import load_file

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def coordinate():
    return load_file(ROOT / "scripts" / "paper_coordinate.py")


class _Fit:
    husky = False
    paper_geometry = True

    def combine(self, runs):
        return 100.0 + runs[0][0]["cost"]


def test_toward_missed_orders_by_the_missed_bounds_excess(coordinate, monkeypatch):
    checks = {
        "a": [  # 2 met; missed: 1.3 and 1.1 times their bounds, and a story bound
            {"name": "s1.path", "met": False, "scaled": 1.3},
            {"name": "s2.path", "met": False, "scaled": 1.1},
            {"name": "s1.mad_m", "met": True, "scaled": 0.5},
            {"name": "s1.reached", "met": True, "scaled": None},
            {"name": "s3.right_wheel_12V", "met": False, "scaled": None},
        ],
        "b": [  # 3 met
            {"name": "s1.path", "met": True, "scaled": 0.9},
            {"name": "s2.path", "met": False, "scaled": 2.0},
            {"name": "s1.mad_m", "met": True, "scaled": 0.5},
            {"name": "s1.reached", "met": True, "scaled": None},
            {"name": "s3.right_wheel_12V", "met": False, "scaled": None},
        ],
    }
    runs = {"a": [{"scenario": "a", "cost": 7.0}], "b": [{"scenario": "b", "cost": 3.0}]}
    monkeypatch.setattr(
        coordinate, "fit_measures", lambda fit, s, vectors, g, p: [runs[v] for v in vectors]
    )
    monkeypatch.setattr(coordinate, "bound_checks", lambda by: checks[next(iter(by))])
    plain = coordinate.judge(_Fit(), ["a", "b", "a"])
    assert plain == [(2, 107.0), (3, 103.0), (2, 107.0)]
    toward = coordinate.judge(_Fit(), ["a", "b"], toward_missed=True)
    assert toward == [(2, pytest.approx(0.4)), (3, pytest.approx(1.0))]


def test_steps_are_parsed_and_a_bad_one_is_refused(coordinate, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        coordinate.main(
            ["--rules", "x.toml", "--out", str(tmp_path / "o.toml"), "--steps", "0.1,x"]
        )
    assert exc.value.code == 2
    assert "--steps" in capsys.readouterr().err


def test_the_twins_excess_is_how_far_past_its_bounds_a_run_lies(coordinate):
    from fuzzynav.app.experiments.paper_fit import TWIN_MAD_FACTOR
    from fuzzynav.app.published import paper_results

    mad_bound = TWIN_MAD_FACTOR * paper_results()["table4"]["s1"]["mad_m"]
    run = {
        "scenario": "s1",
        "mad_m": 0.5 * mad_bound,
        "min_clearance_m": 0.4,
        "path_length_m": 12.0,
        "final_phi_t_rad": 0.1,
    }
    assert coordinate.twin_excess(run) == 0.0  # every bound met
    run.update(mad_m=1.5 * mad_bound, min_clearance_m=0.2)  # MAD 50 %, clearance 20 % short
    assert coordinate.twin_excess(run) == pytest.approx(0.5 + 0.2)
