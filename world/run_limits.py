"""How a run of the closed loop is bounded and how it ends.

The outcomes a run may have (:data:`OUTCOMES`) and how a step ends a run
(:func:`run_ending`, :func:`run_endings`), the checks of the control period and the
voltage limit (:func:`check_loop_settings`), the slack of the timeout test
(:func:`timeout_slack_s`) and the bounds on a run's steps and its log's memory
(:func:`check_run_size`, :func:`log_bytes`). Both engines use them: the pymunk loop
(:mod:`world.simulation`) and the batch engine (:mod:`world.batch`), so the two agree on
what a run may be and when it is over.
"""

from __future__ import annotations

import math
import numbers
from typing import Literal, get_args

import numpy as np

#: How a run ends: at the target, against an obstacle, or out of time.
Outcome = Literal["reached", "collided", "timeout"]
OUTCOMES: tuple[Outcome, ...] = get_args(Outcome)
#: The control period's bounds: below a millisecond the log of an ordinary run grows to
#: gigabytes (1e-5 s asked for 4.3 GB) for nothing the exact ZOH plant needs; above a
#: second the sensors (25 Hz) and the collision sub-steps lose their meaning.
MIN_CONTROL_PERIOD_S = 1e-3
MAX_CONTROL_PERIOD_S = 1.0
#: The most steps :meth:`Simulation.run` takes (duration / period): the log holds 24
#: floats a step plus 4 per obstacle, so 2 million steps of a run with a few obstacles
#: write under 0.6 GB to the log's spool (an hour at 2 ms; 1e-5 s asked 4.3 GB).
MAX_STEPS = 2_000_000
#: The size one run's log may reach: a legal scenario of 1000 obstacles and
#: 3600 s reached 9.7 GB of memory. Checked before the first step with
#: :func:`log_bytes`; beyond :data:`LOG_BLOCK_BYTES` the log is on the disk.
MEMORY_BUDGET_BYTES = 2 * 1024**3
#: Floats the log keeps a step, besides those of the obstacles.
LOG_FLOATS_PER_STEP = 24
#: Floats the log keeps per obstacle and step: x, y, centre distance, clearance.
LOG_FLOATS_PER_OBSTACLE = 4
#: The log's peak over its final size when it was all in memory (its arrays grew by
#: doubling, and the result took a copy): kept as the bound's margin.
LOG_PEAK_FACTOR = 3


def check_loop_settings(control_period_s: float, voltage_limit_v: float) -> None:
    """ValueError naming the value when the control period is outside
    [:data:`MIN_CONTROL_PERIOD_S`, :data:`MAX_CONTROL_PERIOD_S`] or the voltage limit
    is not a positive number (both engines' check)."""
    if not (
        isinstance(control_period_s, numbers.Real)
        and not isinstance(control_period_s, bool)
        and math.isfinite(control_period_s)
        and MIN_CONTROL_PERIOD_S <= control_period_s <= MAX_CONTROL_PERIOD_S
    ):
        raise ValueError(
            f"control_period_s = {control_period_s!r}: must be from "
            f"{MIN_CONTROL_PERIOD_S:g} to {MAX_CONTROL_PERIOD_S:g} s"
        )
    if not (
        isinstance(voltage_limit_v, numbers.Real)
        and not isinstance(voltage_limit_v, bool)
        and math.isfinite(voltage_limit_v)
        and voltage_limit_v > 0
    ):
        raise ValueError(f"voltage_limit_v = {voltage_limit_v!r}: must be positive")


def run_ending(
    to_target_m: float, tolerance_m: float, touched: bool, time_s: float, timeout_at_s: float
) -> int:
    """How a run ends after a step, on one run's floats: an index into :data:`OUTCOMES`
    (the target first, then a contact, then the time), -1 while it goes on. The pymunk
    engine's stop rules; :func:`run_endings` is the batch engine's, beside it.

    Parameters
    ----------
    to_target_m : float
        The robot's centre to the target, m.
    tolerance_m : float
        The target's tolerance, m.
    touched : bool
        A contact began in the step (and ends the run).
    time_s, timeout_at_s : float
        The time after the step, and when the run times out (its duration less
        :func:`timeout_slack_s`), s.
    """
    if to_target_m <= tolerance_m:
        return 0
    if touched:
        return 1
    return 2 if time_s >= timeout_at_s else -1


def run_endings(to_target_m, tolerance_m, touched, time_s, timeout_at_s) -> np.ndarray:
    """:func:`run_ending` on arrays, one entry per run (the batch engine's stop rules).

    Parameters
    ----------
    to_target_m, tolerance_m, time_s, timeout_at_s : numpy.ndarray, (n,)
        As :func:`run_ending`.
    touched : numpy.ndarray, (n,) bool
        As :func:`run_ending`.

    Returns
    -------
    numpy.ndarray, (n,) int
    """
    timeout = np.where(time_s >= timeout_at_s, 2, -1)
    return np.where(to_target_m <= tolerance_m, 0, np.where(touched, 1, timeout))


#: The smallest slack of the timeout test (s): a run ends as ``timeout`` at the first
#: step whose accumulated time reaches its duration less the slack.
TIMEOUT_SLACK_S = 1e-9


def timeout_slack_s(duration_s, control_period_s):
    """How far short of ``duration_s`` the accumulated time may end and still be the
    duration [s]: :data:`TIMEOUT_SLACK_S`, or the rounding that adding the period
    ``duration_s / control_period_s`` times can gather (each sum rounds by at most half
    an ulp of ``duration_s``) when that is larger. 1 ns alone let a 2,000 s run at 1 ms
    fall 2e-9 s short and take one step past :data:`MAX_STEPS`; an ordinary run's slack
    stays 1 ns (150 s at 20 ms gather at most 5e-10 s). Works on arrays too."""
    rounding = 2.0 * np.finfo(float).eps * duration_s * (duration_s / control_period_s)
    return np.maximum(TIMEOUT_SLACK_S, rounding)


def log_bytes(steps: float, n_obstacles: int) -> float:
    """The peak memory [bytes] of the log of a run of ``steps`` steps among
    ``n_obstacles`` obstacles (float64 columns, growth by doubling and the result's
    copy included)."""
    floats = LOG_FLOATS_PER_STEP + LOG_FLOATS_PER_OBSTACLE * n_obstacles
    return LOG_PEAK_FACTOR * 8.0 * floats * steps


def check_run_size(duration_s: float, control_period_s: float, n_obstacles: int) -> float:
    """The steps of a run, or ValueError with the numbers when it would take more than
    :data:`MAX_STEPS` steps or its log more than :data:`MEMORY_BUDGET_BYTES`."""
    steps = duration_s / control_period_s
    if steps > MAX_STEPS:
        raise ValueError(
            f"control_period_s = {control_period_s!r} with duration_s = "
            f"{duration_s!r}: {steps:.3g} steps, more than one run may "
            f"take ({MAX_STEPS}); use a longer period or a shorter scenario"
        )
    need = log_bytes(steps, n_obstacles)
    if need > MEMORY_BUDGET_BYTES:
        raise ValueError(
            f"{steps:.0f} steps ({duration_s:g} s at {control_period_s:g} s) x {n_obstacles} "
            f"obstacles: the run's log would take about {need / 1024**3:.1f} GiB, more than "
            f"the {MEMORY_BUDGET_BYTES / 1024**3:g} GiB one run may use; use a shorter "
            "duration, a longer period or fewer obstacles"
        )
    return steps


def controller_label(controller: object) -> str:
    """What an error message calls a controller: its ``name``, else its class's name."""
    name = getattr(controller, "name", None)
    return name if isinstance(name, str) and name else type(controller).__name__


def wheel_voltages(raw: object, controller: object) -> tuple[float, float]:
    """A controller's returned voltages as two floats: exactly two real numbers
    (a sequence or a (2,) array; not strings, not three values), else ValueError naming
    the controller and what it returned. Finiteness is the caller's check (it names the
    inputs and the time)."""
    values = np.asarray(raw)  # object rows: a list holding a string, None, ...
    if values.dtype.kind not in "iuf" or values.shape != (2,):
        from fuzzynav.resources import shown

        what = f"{values.dtype} values" if values.dtype.kind not in "iuf" else "shape"
        raise ValueError(
            f"controller {controller_label(controller)!r} returned {shown(raw)} "
            f"(shape {values.shape}, {what}): it must return two real numbers, "
            "the left and right wheel voltages in V"
        )
    left, right = values.astype(float).tolist()
    return left, right
