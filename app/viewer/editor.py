"""Edit the paper controller's membership functions while it drives.

The sliders move the numbers of a layout that can rebuild the shipped rule base: the
design layout of :mod:`fuzzynav.controller.paper_design` (the shipped ``rules/paper.toml``:
every slider position keeps the design rules), or, for rule bases written
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

Beside the shapes, the inference choices: AND min or product, implication min
or product, aggregation max, sum or probabilistic OR, defuzzification centroid,
bisector, mean / smallest / largest of maximum, with MATLAB's meanings
(:mod:`fuzzynav.controller.inference`). A choice rebuilds the controller as a slider
does, and the downloaded .fis carries it.
"""

from __future__ import annotations

import math
import re
import threading

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
        self.rules = None  # the rules as edited (a tuple); None: the shipped ones
        self._rules = list(shipped.fis.rules)  # the rules as edited, built or not yet
        self._rule_undo: list = []  # how to undo each rule edit (one small step each)
        self._version = self._built = 0  # rule edits made; the last one built
        self._lock = threading.Lock()  # the rules, between the page and a build

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
        with self._lock:
            rules, version = tuple(self._rules), self._version
        fis = self._controller.fis.replace(inference=inference, rules=rules)
        controller = FisController(fis, name=self.edited_label)
        self.inference, self._controller, self.edited = inference, controller, True
        self._built = max(self._built, version)
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
        with self._lock:
            version = self._version
        controller = self._build(vector)
        with self._lock:
            if version != self._built:
                self.rules, self._built = controller.fis.rules, version
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
        with self._lock:
            rules = tuple(self._rules) if self._built != self._version else self.rules
        if rules is not None:
            fis = fis.replace(rules=rules)
        return FisController(fis, name=self.edited_label)

    # -- the rules (add, change, remove, undo; validated; exported) -------------------

    def rule_version(self) -> int:
        """How many rule edits (and resets) were made: it changes with the rules."""
        return self._version

    def rule_count(self) -> int:
        """How many rules the edited system has (built or not yet)."""
        return len(self._rules)

    def rule(self, number: int):
        """Rule ``number`` (from 1) as edited (a :class:`controller.fuzzy.Rule`)."""
        with self._lock:
            return self._rules[self._number(number)]

    def rule_text(self, number: int) -> str:
        """Rule ``number`` (from 1) as a sentence the editor reads back."""
        from fuzzynav.controller.rulebase import format_rule

        with self._lock:
            n = len(self._rules)
            if not 1 <= int(number) <= n:
                raise ValueError(f"rule {number}: there are rules 1 to {n}")
            rule = self._rules[int(number) - 1]
        return format_rule(self._controller.fis, rule)

    def _parse(self, text: str):
        from fuzzynav.controller.rulebase import parse_rule

        fis = self._controller.fis  # (its variables: a rule edit leaves them)
        try:
            return parse_rule(str(text), list(fis.inputs), list(fis.outputs))
        except ValueError as exc:
            raise ValueError(f"rule {text!r}: {exc}") from None

    def _edit(self, do, undo) -> None:
        """One rule edit on the list (``do(rules)``), and its undo; the system is built
        by :meth:`build` (an edit costs the same at any size: no copy, no build)."""
        with self._lock:
            do(self._rules)
            self._rule_undo.append(undo)
            self._version += 1
            self.edited = True

    def _number(self, number) -> int:
        n = len(self._rules)
        if not 1 <= int(number) <= n:
            raise ValueError(f"rule {number}: there are rules 1 to {n}")
        return int(number) - 1

    def set_rule(self, number: int, text: str, build: bool = True):
        """Rule ``number`` (from 1) becomes ``text`` ("if d_t is L and phi_t is Z then
        left is M and right is M", optionally "weight 0.5"); returns the controller
        (with ``build``; else None, and :meth:`build` makes it)."""
        k = self._number(number)
        rule, old = self._parse(text), self._rules[k]
        self._edit(lambda r: r.__setitem__(k, rule), lambda r: r.__setitem__(k, old))
        return self.build() if build else None

    def add_rule(self, text: str, build: bool = True):
        """A new rule at the end, up to :data:`controller.rulebase.MAX_RULES` (the most a
        rule base file holds: the TOML export and a lesson read it back); returns the
        controller (with ``build``)."""
        from fuzzynav.controller.rulebase import MAX_RULES

        rule = self._parse(text)
        if len(self._rules) >= MAX_RULES:
            raise ValueError(
                f"rule {text!r}: the system has {len(self._rules)} rules, the most a rule "
                f"base file holds ({MAX_RULES}): remove one first"
            )
        self._edit(lambda r: r.append(rule), lambda r: r.pop())
        return self.build() if build else None

    def remove_rule(self, number: int, build: bool = True):
        k = self._number(number)
        if len(self._rules) == 1:
            raise ValueError("the last rule cannot be removed")
        old = self._rules[k]
        self._edit(lambda r: r.pop(k), lambda r: r.insert(k, old))
        return self.build() if build else None

    def undo_rule_edit(self, build: bool = True):
        """The rules as they were before the last rule edit; returns the controller."""
        with self._lock:
            if not self._rule_undo:
                raise ValueError("no rule edit to undo")
            self._rule_undo.pop()(self._rules)
            self._version += 1
            self.edited = True
        return self.build() if build else None

    def build(self):
        """The controller of the rules as edited now (built once per edit made: a build
        of many rules may lag several quick edits, and takes them all at once)."""
        from fuzzynav.controller.fis_controller import FisController

        with self._lock:
            if self._built == self._version:
                return self._controller
            rules, version = tuple(self._rules), self._version
        fis = self._controller.fis.replace(rules=rules)  # checks the structure
        controller = FisController(fis, name=self.edited_label)
        with self._lock:
            if version > self._built:
                self._built, self._controller, self.rules = version, controller, rules
            return self._controller

    def numbers(self) -> dict[str, float]:
        """The layout's numbers the sliders show (name: value), as a lesson keeps them."""
        return {name: float(v) for name, v in zip(self.names, self.vector)}

    def vector_of(self, numbers) -> np.ndarray:
        """``numbers`` (name: value, every number of the layout, each within its bounds
        or at its starting value) as the layout's vector; ValueError naming the number."""
        if not isinstance(numbers, dict):
            raise ValueError(f"numbers = {numbers!r:.40}: not a table of numbers")
        missing = [n for n in self.names if n not in numbers]
        unknown = [str(n) for n in numbers if n not in self.names]
        if missing or unknown:
            raise ValueError(
                f"numbers: not the layout's numbers (missing: {', '.join(missing) or '-'}; "
                f"unknown: {', '.join(unknown[:5]) or '-'})"
            )
        vector = self.start.copy()
        for k, name in enumerate(self.names):
            value, (lo, hi) = numbers[name], self.bounds[name]
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (lo <= value <= hi or value == self.start[k])
            ):
                raise ValueError(
                    f"numbers: {name} = {value!r}: must be a number between {lo} and {hi}"
                )
            vector[k] = value
        return vector

    def restore(self, fis, numbers):
        """The editor as a lesson left it: driving ``fis``, its edit of this system (its
        rules, inference choices and shapes), with the sliders at the layout's
        ``numbers`` that made those shapes; returns the controller. ValueError (nothing
        changed) when the numbers are not the layout's or ``fis`` is not this system's
        (its variables and terms)."""
        vector = self.vector_of(numbers)
        shipped = self.shipped.fis

        def terms(system):
            return [(v.name, [t.name for t in v.terms]) for v in system.inputs + system.outputs]

        if terms(fis) != terms(shipped):
            raise ValueError(f"its variables and terms are not those of {self.label}")
        controller = self.adopt(fis)
        self.vector = vector
        return controller

    def adopt(self, fis):
        """Drive with ``fis``, an edit of this system: its rules and inference choices
        are the editor's again (its sliders' numbers are :meth:`restore`'s: a system's
        shapes do not give back the layout's numbers); returns the controller."""
        from fuzzynav.controller.fis_controller import FisController

        with self._lock:
            self._controller = FisController(fis, name=self.edited_label)
            self.rules, self.inference, self.edited = tuple(fis.rules), fis.inference, True
            self._rules, self._rule_undo = list(fis.rules), []
            self._version += 1
            self._built = self._version
        return self._controller

    def toml_text(self) -> str:
        """The edited system as a TOML rule base (``fuzzynav`` reads it back)."""
        from fuzzynav.controller.rulebase import dumps_toml

        fis = self.build().fis
        return dumps_toml(fis.replace(name=self.file_stem if self.edited else fis.name))

    def reset(self):
        """Back to the shipped system."""
        with self._lock:
            self.rules = None
            self._rules, self._rule_undo = list(self.shipped.fis.rules), []
            self._version += 1
            self._built = self._version
        self.vector = self.start.copy()
        self.edited = False
        self._controller = self._fresh_shipped()
        self.inference = self._controller.fis.inference
        return self._controller

    def controller(self):
        return self._controller

    def fis_text(self) -> str:
        from fuzzynav.controller.fis import dumps_fis

        fis = self.build().fis
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
