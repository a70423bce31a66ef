"""The inference the teaching views show: the controller's rule base at the inputs
of the step shown (live, a recorded step, or inputs tried by hand in what-if mode). A
part of :class:`ViewerApp` (:mod:`.model`), whose state and lock it shares."""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.viewer.state import (
    ViewerError,
)


class Teaching:
    """See the module's docstring; ``app`` is the :class:`ViewerApp` it is part of."""

    def __init__(self, app):
        self.app = app

    def fuzzy_system(self):
        """The controller's FuzzySystem, or None when it has none (``p``); for fuzzynav,
        its two blocks as one system."""
        app = self.app
        inner = app.controller.inner
        fis = getattr(inner, "fis", None)
        if fis is None and self._blended(inner):
            return self._merged(inner)
        if fis is None and hasattr(inner, "teaching_view"):
            fis = getattr(inner, "merged", None)
        return fis

    def _merged(self, inner):
        """A blended controller's merged system, built once per controller (the views
        key their drawings by the system's identity)."""
        if getattr(self, "_merged_for", None) is not inner:
            self._merged_fis = inner.merged
            self._merged_for = inner
        return self._merged_fis

    def what_if_system(self):
        """The rule base what-if mode works on: a plain system over the four inputs
        (paper, an edited or uploaded one); None for fuzzynav (its blocks read sectors
        and a planned bearing) and for controllers without rules."""
        app = self.app
        inner = app.controller.inner
        fis = getattr(inner, "fis", None)
        if fis is None or hasattr(inner, "teaching_view") or fis.n_inputs != 4:
            return None
        return fis

    @staticmethod
    def read_inputs(fis) -> tuple[int, ...]:
        """The indices of ``fis``'s inputs that some rule reads (the starter reads d_t
        and phi_t only: What-if and the surface offer no others)."""
        if fis is None:
            return ()
        return tuple(
            i for i in range(fis.n_inputs) if any(r.antecedent[i] is not None for r in fis.rules)
        )

    def start_what_if(self) -> None:
        """Pause and try inputs by hand: the whole inference follows the inputs set
        with :meth:`set_what_if_input`; the robot does not move. :meth:`stop_what_if`
        (or Play, or Step) leaves it, and a run that was playing plays on."""
        app = self.app
        with app.lock:
            if self.what_if_system() is None:
                raise ViewerError(
                    f"what-if mode needs a rule base over the four inputs (paper, an edited "
                    f"or uploaded .fis); {app.controller_label} has none"
                )
            if app.what_if is not None:
                return
            if app.history_index is not None:
                app._end_mode_message_locked("history")
            app.history_index = None
            app._resume_after_what_if = app.playing
            app.playing = False
            x = app.controller.last_inputs.copy()
            if not np.isfinite(x[0]):
                x = np.asarray(app.sim.sense()[0], dtype=float)
            app.what_if = x
            app._bump()

    def set_what_if_input(self, index: int, value) -> None:
        """Set input ``index`` (0-3: d_t, d_o, phi_t, phi_o) in what-if mode; NaN is
        "not sensed" (d_o, phi_o)."""
        app = self.app
        with app.lock:
            if app.what_if is None:
                raise ViewerError("what-if mode is off: switch it on first")
            fis = self.what_if_system()
            if fis is None:
                raise ViewerError("this controller has no rule base over the four inputs")
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ViewerError(f"{value!r}: must be a number") from None
            name = fis.input_names[index]
            if math.isnan(value):
                if index in (0, 2):
                    raise ViewerError(f"{name} is always known: give a number")
            else:
                lo, hi = fis.inputs[index].range
                if not (math.isfinite(value) and lo <= value <= hi):
                    raise ViewerError(f"{name} = {value!r}: must be between {lo:g} and {hi:g}")
            app.what_if[index] = value
            app._bump()

    def stop_what_if(self) -> None:
        app = self.app
        with app.lock:
            if app.what_if is None:
                return
            app.what_if = None
            app._end_mode_message_locked("what-if")
            resume = app._resume_after_what_if
            app._bump()
        if resume:
            app.driver.play()

    def teaching(self) -> dict | None:
        """The rule base at the last controller inputs: firing strengths and aggregation.

        None when the controller has no fuzzy system or has not been called yet.
        """
        app = self.app
        with app.lock:
            shown = app._probe if app._probe is not None else app.controller.inner
        view = getattr(shown, "teaching_view", None)
        state = None
        with app.lock:
            inputs = app.controller.last_inputs.copy()
            k = app.history_index
            if k is not None and k < len(app._history):
                step = app._history[k]
                inputs = step.inputs.copy()
                if view is not None:
                    if step.block is None:
                        return None
                    x, state = step.block
                    return self._teaching_of(self.fuzzy_system(), x, state)
            if view is not None:
                # a controller whose blocks see more than the four inputs (fuzzynav)
                seen = view()
                if seen is None:
                    return None
                fis, x, state = seen
        if view is None and self._blended(shown):
            # a stateless controller of two blocks blended (baseline): its merged
            # system at the inputs its blocks read (listed as fuzzy, so the
            # Inference tab must show its rules)
            if not np.isfinite(inputs[0]):
                return None
            return self._blended_teaching(shown, inputs)
        if view is None:
            fis = self.fuzzy_system()
            what_if = app.what_if
            if what_if is not None and fis is not None:
                inputs = what_if.copy()
            if fis is None or not np.isfinite(inputs[0]):
                return None
            x = inputs[: len(fis.input_names)]
        return self._teaching_of(fis, x, state)

    @staticmethod
    def _blended(inner) -> bool:
        return (
            getattr(inner, "fis", None) is None
            and not hasattr(inner, "teaching_view")
            and hasattr(inner, "merged")
            and hasattr(inner, "sectors")
        )

    def _blended_teaching(self, inner, inputs) -> dict | None:
        d_t, d_o, phi_t, phi_o = (float(v) for v in inputs[:4])
        left, front, right = inner.sectors(d_o, phi_o)
        values = {
            "d_t": d_t,
            "phi_t": phi_t,
            "d_o": d_o,
            "phi_o": phi_o,
            "d_left": left,
            "d_front": front,
            "d_right": right,
        }
        fis = self._merged(inner)
        if any(name not in values for name in fis.input_names):
            return None
        x = np.array([values[name] for name in fis.input_names], dtype=float)
        avoid = getattr(inner, "avoid", None)
        weight = 0.0
        if avoid is not None and not all(math.isnan(v) for v in (left, front, right)):
            weight = float(np.max(avoid.firing_strengths(np.array([[left, front, right, phi_o]]))))
        state = {"avoidance weight alpha": f"{weight:.2f}"}
        return self._teaching_of(fis, x, state)

    @staticmethod
    def _teaching_of(fis, x, state) -> dict:
        strengths = np.asarray(fis.firing_strengths(np.asarray([x])))[0]
        grid, membership, centroids = fis.aggregated(x)
        return {
            "inputs": x,
            "input_names": list(fis.input_names),
            "output_names": list(fis.output_names),
            "strengths": strengths,
            "grid": np.asarray(grid),
            "membership": np.asarray(membership),
            "centroids": np.asarray(centroids),
            "fis": fis,
            "state": state,
        }
