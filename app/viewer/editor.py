"""Edit the paper controller's membership functions while it drives.

The sliders move the numbers of a layout that can rebuild the shipped rule base: the
design layout of :mod:`fuzzynav.controller.paper_design` (the shipped ``rules/paper.toml``
of issue 25: every slider position keeps the design rules), or, for rule bases written
by older fits and tunes, the partition layout of
:mod:`fuzzynav.controller.paper_partition` or the 27-number layout of
:class:`fuzzynav.controller.paper.PaperTunable`. All build their shapes from positive
widths, so that however a slider is moved, every shape stays valid and the terms stay in
their order. The design and partition layouts leave no input uncovered; in the
27-number one a slider can open a hole (its Z and P terms may stop overlapping), and the
rule panel then says that no rule fires and the fallback applies. The editor starts from the shipped rule base's own numbers when its
file records them (``# tuned vector:``, written by ``fuzzynav tune``) and they rebuild
that system; else from the tuner's starting point, and it says so. Reset drives with the
shipped controller itself, exactly as ``paper`` is built.

Beside the shapes, the inference choices (issue 27): AND min or product, implication min
or product, aggregation max, sum or probabilistic OR, defuzzification centroid,
bisector, mean / smallest / largest of maximum, with MATLAB's meanings
(:mod:`fuzzynav.controller.inference`). A choice rebuilds the controller as a slider
does, and the downloaded .fis carries it.
"""

from __future__ import annotations

import math
import re

import numpy as np

VECTOR_LINE = re.compile(r"^#\s*tuned vector:\s*(.+)$", re.MULTILINE)


def shipped_vector(tunable, shipped_fis, path) -> tuple[np.ndarray, bool]:
    """(vector, exact): the parametrisation of the shipped system if its file records
    it and it rebuilds that system (to 1e-4), else the tuner's starting vector."""
    names = tunable.parameter_names()
    from fuzzynav.resources import read_user_text

    try:  # the one safe reader (regular file, size cap), as for every file read
        text = read_user_text(path, "rule base file")
    except ValueError:  # InputError: missing, unreadable, not a regular file
        text = ""
    match = VECTOR_LINE.search(text)
    if match:
        values = dict(
            (k.strip(), float(v))
            for k, v in (item.split("=") for item in match.group(1).split(","))
        )
        if set(names) <= set(values):  # a fitted file also names its initial heading
            vector = np.array([values[n] for n in names])
            try:
                rebuilt = tunable.system(vector)
            except ValueError:
                rebuilt = None
            if rebuilt is not None and np.allclose(
                rebuilt.parameter_vector(), shipped_fis.parameter_vector(), atol=1e-4
            ):
                return vector, True
    return tunable.initial_vector(), False


class SystemEditor:
    """An edited fuzzy system: a layout's parameter vector, its inference choices and
    its rules, and the controller they build. :class:`PaperEditor` edits the paper
    controller, :class:`StarterEditor` the starter; ``label`` names the shipped system
    in the Controller dropdown, ``edited_label`` the edited one."""

    label = "paper"
    edited_label = "paper (edited)"
    file_stem = "paper_edited"

    def _start_from(self, shipped, tunable, start, exact: bool) -> None:
        self.shipped = shipped
        self.tunable = tunable
        self.start, self.exact = start, exact
        self.names = self.tunable.parameter_names()
        self.bounds = dict(zip(self.names, self.tunable.bounds()))
        self.vector = self.start.copy()
        self.edited = False
        self._controller = self.shipped
        self.inference = self.shipped.fis.inference
        self.rules = None  # the rules as edited; None: the shipped ones
        self._rule_undo: list = []  # the rules before each rule edit

    def _fresh_shipped(self):
        """The shipped controller, built anew (a reset drives with it)."""
        raise NotImplementedError

    def choice(self, field: str) -> str:
        """The current value of an inference choice (an Inference field name)."""
        return getattr(self.inference, field)

    def set_choice(self, field: str, value):
        """Set one inference choice (``defuzz_method="mom"``, ...); returns the controller
        of the edited system."""
        from fuzzynav.controller.fis_controller import FisController

        try:
            inference = self.inference.replace(**{field: value})
        except (TypeError, ValueError) as exc:
            raise ValueError(str(exc)) from None
        fis = self._controller.fis.replace(inference=inference)
        controller = FisController(fis, name=self.edited_label)
        self.inference, self._controller, self.edited = inference, controller, True
        return controller

    def value(self, name: str) -> float:
        return float(self.vector[self.names.index(name)])

    def set(self, name: str, value):
        """Set one parameter; returns the controller of the edited system."""
        if name not in self.names:
            raise ValueError(
                f"membership parameter {name!r}: unknown (have {', '.join(self.names)})"
            )
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {value!r}: must be a number") from None
        lo, hi = self.bounds[name]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise ValueError(f"{name} = {value!r}: must be between {lo} and {hi}")
        vector = self.vector.copy()
        vector[self.names.index(name)] = value
        controller = self._build(vector)
        self.vector, self._controller, self.edited = vector, controller, True
        return controller

    def _build(self, vector):
        """The shipped system (its rules, ranges, names) with the shapes of ``vector``;
        the tuner's own template when the shipped file's layout differs."""
        from fuzzynav.controller.fis_controller import FisController

        shaped = self.tunable.system(vector)  # raises ValueError on an invalid shape
        try:
            fis = self.shipped.fis.with_parameter_vector(shaped.parameter_vector())
            if [t.shape for v in fis.inputs + fis.outputs for t in v.terms] != [
                t.shape for v in shaped.inputs + shaped.outputs for t in v.terms
            ]:
                fis = shaped
        except ValueError:
            fis = shaped
        fis = fis.replace(inference=self.inference)
        if self.rules is not None:
            fis = fis.replace(rules=self.rules)
        return FisController(fis, name=self.edited_label)

    # -- the rules (issue 38: add, change, remove, undo; validated; exported) --------

    def rule_text(self, number: int) -> str:
        """Rule ``number`` (from 1) as a sentence the editor reads back."""
        from fuzzynav.controller.rulebase import format_rule

        fis = self._controller.fis
        if not 1 <= int(number) <= len(fis.rules):
            raise ValueError(f"rule {number}: there are rules 1 to {len(fis.rules)}")
        return format_rule(fis, fis.rules[int(number) - 1])

    def _with_rules(self, rules):
        from fuzzynav.controller.fis_controller import FisController

        fis = self._controller.fis.replace(rules=tuple(rules))  # checks the structure
        controller = FisController(fis, name=self.edited_label)
        self._rule_undo.append(self._controller.fis.rules)
        self.rules, self._controller, self.edited = tuple(rules), controller, True
        return controller

    def _parse(self, text: str):
        from fuzzynav.controller.rulebase import parse_rule

        fis = self._controller.fis
        try:
            return parse_rule(str(text), list(fis.inputs), list(fis.outputs))
        except ValueError as exc:
            raise ValueError(f"rule {text!r}: {exc}") from None

    def set_rule(self, number: int, text: str):
        """Rule ``number`` (from 1) becomes ``text`` ("if d_t is L and phi_t is Z then
        left is M and right is M", optionally "weight 0.5"); returns the controller."""
        rules = list(self._controller.fis.rules)
        if not 1 <= int(number) <= len(rules):
            raise ValueError(f"rule {number}: there are rules 1 to {len(rules)}")
        rules[int(number) - 1] = self._parse(text)
        return self._with_rules(rules)

    def add_rule(self, text: str):
        """A new rule at the end; returns the controller."""
        return self._with_rules(list(self._controller.fis.rules) + [self._parse(text)])

    def remove_rule(self, number: int):
        rules = list(self._controller.fis.rules)
        if not 1 <= int(number) <= len(rules):
            raise ValueError(f"rule {number}: there are rules 1 to {len(rules)}")
        if len(rules) == 1:
            raise ValueError("the last rule cannot be removed")
        del rules[int(number) - 1]
        return self._with_rules(rules)

    def undo_rule_edit(self):
        """The rules as they were before the last rule edit; returns the controller."""
        from fuzzynav.controller.fis_controller import FisController

        if not self._rule_undo:
            raise ValueError("no rule edit to undo")
        rules = self._rule_undo.pop()
        fis = self._controller.fis.replace(rules=rules)
        self.rules, self._controller = rules, FisController(fis, name=self.edited_label)
        self.edited = True
        return self._controller

    def adopt(self, fis):
        """Drive with ``fis``, an edit of this system saved in a lesson: its rules and
        inference choices are the editor's again (the sliders keep their numbers: a
        system's shapes do not give back the layout's numbers); returns the controller."""
        from fuzzynav.controller.fis_controller import FisController

        self._controller = FisController(fis, name=self.edited_label)
        self.rules, self.inference, self.edited = tuple(fis.rules), fis.inference, True
        self._rule_undo = []
        return self._controller

    def toml_text(self) -> str:
        """The edited system as a TOML rule base (``fuzzynav`` reads it back)."""
        from fuzzynav.controller.rulebase import dumps_toml

        fis = self._controller.fis
        return dumps_toml(fis.replace(name=self.file_stem if self.edited else fis.name))

    def reset(self):
        """Back to the shipped system."""
        self.rules = None
        self._rule_undo = []
        self.vector = self.start.copy()
        self.edited = False
        self._controller = self._fresh_shipped()
        self.inference = self._controller.fis.inference
        return self._controller

    def controller(self):
        return self._controller

    def fis_text(self) -> str:
        from fuzzynav.controller.fis import dumps_fis

        fis = self._controller.fis
        return dumps_fis(fis.replace(name=self.file_stem if self.edited else fis.name))


class PaperEditor(SystemEditor):
    """The edited paper system (the Husky's or the paper geometry's rule base)."""

    def __init__(self, geometry: str = "husky"):
        from fuzzynav.controller.paper import RULES_BY_GEOMETRY, PaperTunable, paper_controller
        from fuzzynav.controller.paper_design import PaperDesignTunable
        from fuzzynav.controller.paper_partition import PaperPartitionTunable

        self.geometry = geometry
        shipped = paper_controller(geometry=geometry)
        path = RULES_BY_GEOMETRY[geometry]
        # The layout the shipped file was made in: the design layout for the shipped
        # paper controller; the partition one (no holes) and the earlier 27-number one
        # for rule bases written by older fits and tunes.
        for candidate in (PaperDesignTunable(), PaperPartitionTunable(), PaperTunable()):
            start, exact = shipped_vector(candidate, shipped.fis, path)
            if exact:
                break
        self._start_from(shipped, candidate, start, exact)

    def _fresh_shipped(self):
        from fuzzynav.controller.paper import paper_controller

        return paper_controller(geometry=self.geometry)


class StarterEditor(SystemEditor):
    """The edited starter system (:mod:`.starter`): its six layout numbers, its
    inference choices and its six rules."""

    def __init__(self, geometry: str = "husky"):
        from fuzzynav.app.viewer.starter import (
            STARTER_EDITED_LABEL,
            STARTER_LABEL,
            StarterLayout,
            starter_controller,
        )

        self.label, self.edited_label, self.file_stem = (
            STARTER_LABEL,
            STARTER_EDITED_LABEL,
            "starter_edited",
        )
        self.geometry = geometry
        layout = StarterLayout()
        self._start_from(starter_controller(), layout, layout.initial_vector(), True)

    def _fresh_shipped(self):
        from fuzzynav.app.viewer.starter import starter_controller

        return starter_controller()
