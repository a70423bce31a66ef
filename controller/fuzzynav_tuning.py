"""fuzzynav's tuning protocol (``controller.tuning``): the crisp parameters in
``CRISP_BOUNDS`` and, optionally, the membership parameters of both blocks, as one vector
a tuner searches; :func:`tunable` is what ``fuzzynav tune --controller fuzzynav`` asks for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzynav.controller.fuzzynav import FuzzyNavController
from fuzzynav.controller.fuzzynav_params import (
    AVOID_PATH,
    CRISP_BOUNDS,
    CRISP_DEFAULTS,
    GOAL_PATH,
    PARAMS_PATH,
    write_params,
)
from fuzzynav.controller.rulebase import read_toml, write_toml


class FuzzyNavTunable:
    """The tuning protocol of ``controller.tuning`` (duck-typed): a vector of the crisp
    parameters in CRISP_BOUNDS followed by the membership parameters of both blocks.
    Picklable (holds only plain data and FuzzySystems, which pickle)."""

    name = "fuzzynav"

    def __init__(
        self,
        goal_path=GOAL_PATH,
        avoid_path=AVOID_PATH,
        params_path=PARAMS_PATH,
        tune_memberships: bool = False,
    ):
        self.goal = read_toml(goal_path)
        self.avoid = read_toml(avoid_path)
        # The search starts from the hand design in this file (CRISP_DEFAULTS), never
        # from the shipped file (which a tuning run overwrites), so that the tuning
        # command is reproducible.
        self.params = dict(CRISP_DEFAULTS)
        self.control_period_s = self.params["control_period_s"]
        # tuning stops a run that makes no progress; not before the escape had its chance
        self.stall_cutoff_s = self.params["stall_s"] + 20.0
        self.params_path = Path(params_path)
        self.goal_path, self.avoid_path = Path(goal_path), Path(avoid_path)
        self.tune_memberships = tune_memberships
        self._crisp = list(CRISP_BOUNDS)

    def _mf_names(self) -> list[str]:
        if not self.tune_memberships:
            return []
        return [f"goal.{n}" for n in self.goal.parameter_names()] + [
            f"avoid.{n}" for n in self.avoid.parameter_names()
        ]

    def parameter_names(self) -> list[str]:
        return [f"crisp.{k}" for k in self._crisp] + self._mf_names()

    def initial_vector(self) -> np.ndarray:
        v = [self.params[k] for k in self._crisp]
        if self.tune_memberships:
            v += self.goal.parameter_vector().tolist() + self.avoid.parameter_vector().tolist()
        return np.array(v, dtype=float)

    def bounds(self) -> list[tuple[float, float]]:
        b = [CRISP_BOUNDS[k] for k in self._crisp]
        if self.tune_memberships:
            for value in np.concatenate(
                [self.goal.parameter_vector(), self.avoid.parameter_vector()]
            ):
                span = max(0.3, 0.3 * abs(value))
                b.append((value - span, value + span))
        return b

    def _split(self, vector):
        vector = np.asarray(vector, dtype=float).ravel()
        n = len(self._crisp)
        params = dict(self.params)
        params.update({k: float(x) for k, x in zip(self._crisp, vector[:n])})
        goal, avoid = self.goal, self.avoid
        if self.tune_memberships:
            ng = len(goal.parameter_vector())
            goal = goal.with_parameter_vector(vector[n : n + ng])
            avoid = avoid.with_parameter_vector(vector[n + ng :])
        return goal, avoid, params

    def build(self, vector) -> FuzzyNavController:
        goal, avoid, params = self._split(vector)
        return FuzzyNavController(goal, avoid, params)

    def save(self, vector, path, overwrite: bool = False) -> list[Path]:
        """Write the tuned parameters to ``path`` (and, when memberships are tuned, the two
        rule bases beside it, ``fuzzynav_goal.toml`` and ``fuzzynav_avoid.toml``: an
        existing file of those names is refused, ValueError before anything is written,
        unless ``overwrite``); never into the installed package unless asked to."""
        from fuzzynav.safe_files import OutputScope

        goal, avoid, params = self._split(vector)
        params_path = Path(path)
        beside = [params_path.parent / f"fuzzynav_{n}.toml" for n in ("goal", "avoid")]
        if self.tune_memberships:
            remedy = "pass overwrite=True to replace it, or another folder"
            OutputScope("save: beside path", overwrite=overwrite, remedy=remedy).check(beside)
        written = [write_params(params, params_path)]
        if self.tune_memberships:
            write_toml(goal, beside[0])
            write_toml(avoid, beside[1])
            written += beside
        return written


def tunable(**kwargs) -> FuzzyNavTunable:
    return FuzzyNavTunable(**kwargs)
