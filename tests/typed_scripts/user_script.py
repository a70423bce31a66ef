"""A user's script over the whole public API, type-checked by tests/test_typing.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt

import fuzzynav
from fuzzynav.controller.interface import Controller, FuzzyController


class Mine:
    name = "mine"

    def reset(self) -> None:
        pass

    def __call__(self, inputs: npt.NDArray[np.float64]) -> tuple[float, float]:
        d_t, d_o, phi_t, phi_o = inputs
        turn = 4.0 * phi_t if math.isnan(d_o) else 4.0 * (phi_t - phi_o)
        return 5.0 - turn, 5.0 + turn


def main(folder: Path) -> None:
    run = fuzzynav.simulate("s1", controller="paper", perception="ideal")
    outcome: fuzzynav.Outcome = run.outcome
    path: float = run.metrics["path_length_m"]
    xs = run.trace["x_m"]
    capabilities: frozenset[str] = fuzzynav.check_controller(Mine())
    fuzzynav.register_controller("mine", Mine, description="mine", replace=True)
    rows: list[fuzzynav.SweepRow] = fuzzynav.sweep("mine", n=2, seed=1, out=folder / "r.jsonl")
    first: fuzzynav.Outcome = rows[0]["outcome"]
    clearance: float | None = rows[0]["min_clearance_m"]
    scenario = fuzzynav.load_scenario("s2")
    paper: Controller = fuzzynav.make_controller("paper")
    assert isinstance(paper, FuzzyController)
    system = fuzzynav.read_fis(fuzzynav.write_fis(paper.fis, folder / "p.fis"))
    mine_run = fuzzynav.simulate("s1", Mine())
    print(outcome, path, xs[-1], capabilities, first, clearance, scenario.name, system.name)
    print(mine_run.outcome)
