"""Table 1's NONE read as the paper's text has it (``FuzzySystem(unsensed_none=...)``).

A rule with NONE for an input named in ``unsensed_none`` holds only while that input
sensed nothing (NaN). Evaluated exactly by splitting: each row is decided by the system
of the rules its sensed gated inputs allow (a rule with NONE for a sensed gated input
left out); the rules left out fire at 0. :class:`~fuzzynav.controller.fuzzy.FuzzySystem`
takes these methods from :class:`UnsensedNone`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


class UnsensedNone:
    """The splitting by sensed gated inputs (module doc); mixed into ``FuzzySystem``,
    which sets ``_gated`` (the gated inputs' columns) and ``_gated_systems`` (a cache)."""

    rules: tuple
    _gated: list[int]
    replace: Any  # FuzzySystem.replace
    _gated_systems: dict

    def gated_system(self, sensed: Sequence[bool]) -> tuple[Any, list[int]]:
        """With ``unsensed_none``: the system that decides where each gated input is
        sensed (True) or not, and the indices of its rules in this one. A rule with NONE
        for a sensed gated input is left out; None if no rule is left (nothing fires)."""
        key = tuple(bool(b) for b in sensed)
        if key not in self._gated_systems:
            kept = [
                k
                for k, rule in enumerate(self.rules)
                if all(rule.antecedent[i] is not None for i, on in zip(self._gated, key) if on)
            ]
            system = (
                self.replace(rules=[self.rules[k] for k in kept], unsensed_none=())
                if kept
                else None
            )
            self._gated_systems[key] = (system, kept)
        return self._gated_systems[key]

    def _gated_groups(self, X: np.ndarray):
        """Rows of X by which gated inputs they sensed: (rows, system, its rule indices)."""
        sensed = ~np.isnan(X[:, self._gated])
        patterns, which = np.unique(sensed, axis=0, return_inverse=True)
        for k, pattern in enumerate(patterns):
            system, kept = self.gated_system(pattern.tolist())
            yield np.flatnonzero(which.reshape(-1) == k), system, kept

    def _gated_one(self, x) -> Any:
        row = np.asarray(x, dtype=float)
        return self.gated_system((~np.isnan(row[self._gated])).tolist())[0]
