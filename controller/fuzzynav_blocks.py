"""fuzzynav's two fuzzy blocks, as one system and as MATLAB files.

The goal and avoidance blocks (items 3 and 4 of docs/fuzzynav.md's
design) live in ``assets/rules/fuzzynav_goal.toml`` and ``fuzzynav_avoid.toml``. For
speed the controller evaluates them as one merged system (:func:`merge_blocks`: same
rules, disjoint variables, exactly the same outputs); :func:`export_fis` writes each
block as a ``.fis`` file.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from fuzzynav.controller.fis import write_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule
from fuzzynav.controller.fuzzynav_params import AVOID_PATH, GOAL_PATH
from fuzzynav.controller.rulebase import read_toml


def merge_blocks(goal: FuzzySystem, avoid: FuzzySystem) -> FuzzySystem:
    """One system evaluating both blocks: inputs goal's then avoid's, outputs
    goal_speed, goal_turn, avoid_speed, avoid_turn. Each rule keeps its own block's
    variables, so every output is exactly what its block alone would give."""
    gi, go = len(goal.inputs), len(goal.outputs)
    ai, ao = len(avoid.inputs), len(avoid.outputs)
    inputs = list(goal.inputs) + list(avoid.inputs)
    outputs = [dataclasses.replace(v, name=f"goal_{v.name}") for v in goal.outputs] + [
        dataclasses.replace(v, name=f"avoid_{v.name}") for v in avoid.outputs
    ]
    rules = [
        Rule(r.antecedent + (None,) * ai, r.consequent + (None,) * ao, r.weight) for r in goal.rules
    ]
    rules += [
        Rule((None,) * gi + r.antecedent, (None,) * go + r.consequent, r.weight)
        for r in avoid.rules
    ]
    return FuzzySystem(
        inputs, outputs, rules, name="fuzzynav-merged", n_points=max(goal.n_points, avoid.n_points)
    )


#: The two blocks' names and shipped rule bases.
BLOCK_FILES = (("goal", GOAL_PATH), ("avoid", AVOID_PATH))


def export_fis(directory: str | Path, overwrite: bool = False) -> list[Path]:
    """Write the two blocks as MATLAB .fis files (one per block) into ``directory``;
    an existing file of the same name is refused (ValueError, before either is
    written) unless ``overwrite``."""
    from fuzzynav.safe_files import OutputScope

    directory = Path(directory)
    blocks = {directory / f"fuzzynav_{name}.fis": path for name, path in BLOCK_FILES}
    remedy = "pass overwrite=True to replace it, or another folder"
    with OutputScope("export_fis: directory", overwrite=overwrite, remedy=remedy) as outputs:
        outputs.check(blocks)
        directory.mkdir(parents=True, exist_ok=True)
        for out, path in blocks.items():
            write_fis(read_toml(path), out)
    return list(blocks)
