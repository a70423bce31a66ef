"""Edit the paper controller's membership functions while it drives.

The sliders move the numbers of a layout that can rebuild the shipped rule base: the
partition layout of :mod:`fuzzynav.controller.paper_partition` or the 27-number layout of
:class:`fuzzynav.controller.paper.PaperTunable` (the shipped ``rules/paper.toml`` of issue
25 is drawn from the 12 numbers of :mod:`fuzzynav.controller.paper_design`, which this
editor does not offer yet, so it starts from the tuner's starting point and says so).
Both build their shapes from positive widths, so that however a slider is moved, every
shape stays valid and the terms stay in their order. The partition layout leaves no
input uncovered; in the 27-number one a slider can open a hole (its Z and P terms may
stop overlapping), and the rule panel then says that no rule fires and the fallback
applies. The editor starts from the shipped rule base's own numbers when its
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


class PaperEditor:
    """The edited paper system: a parameter vector, and the controller it builds."""

    def __init__(self, geometry: str = "husky"):
        from fuzzynav.controller.paper import RULES_BY_GEOMETRY, PaperTunable, paper_controller
        from fuzzynav.controller.paper_partition import PaperPartitionTunable

        self.geometry = geometry
        self.shipped = paper_controller(geometry=geometry)
        path = RULES_BY_GEOMETRY[geometry]
        # The layout the shipped file was made in: the partition one (no holes) for the
        # rule base fitted to Table 4, the earlier 27-number one for the Husky's.
        for candidate in (PaperPartitionTunable(), PaperTunable()):
            self.tunable = candidate
            self.start, self.exact = shipped_vector(candidate, self.shipped.fis, path)
            if self.exact:
                break
        self.names = self.tunable.parameter_names()
        self.bounds = dict(zip(self.names, self.tunable.bounds()))
        self.vector = self.start.copy()
        self.edited = False
        self._controller = self.shipped
        self.inference = self.shipped.fis.inference

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
        controller = FisController(fis, name="paper (edited)")
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
        return FisController(fis.replace(inference=self.inference), name="paper (edited)")

    def reset(self):
        """Back to the shipped controller."""
        from fuzzynav.controller.paper import paper_controller

        self.vector = self.start.copy()
        self.edited = False
        self._controller = paper_controller(geometry=self.geometry)
        self.inference = self._controller.fis.inference
        return self._controller

    def controller(self):
        return self._controller

    def fis_text(self) -> str:
        from fuzzynav.controller.fis import dumps_fis

        fis = self._controller.fis
        return dumps_fis(fis.replace(name="paper_edited" if self.edited else fis.name))
