"""The paper's controller: Table 1's 40 rules with our membership functions.

The rules, ranges, term names and shape kinds are the paper's; the membership
parameters are ours (the paper's figures are missing) and live in
``assets/rules/paper.toml``, produced by ``fuzzynav tune``.
"""

from __future__ import annotations

from pathlib import Path

from controller.fis_controller import FisController

PAPER_RULES = Path(__file__).resolve().parents[1] / "assets" / "rules" / "paper.toml"


def paper_controller(path: str | Path = PAPER_RULES) -> FisController:
    return FisController.from_toml(path, name="paper")
