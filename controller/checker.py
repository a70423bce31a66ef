"""Does an object meet the controller interface? (as gymnasium's ``env_checker``).

:func:`check_controller` drives a controller through what the world and the batch
engine will ask of it (``reset``, calls on inputs with and without an obstacle sensed,
the optional capabilities it declares) and says, in one message, everything that is
wrong. :func:`check_registered` does the same for a registry entry and checks that the
entry's flags say what its controllers do. The tests run both on every registered
controller.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from fuzzynav.controller.interface import (
    SAMPLE_INPUTS,
    SAMPLE_RANGES_M,
    BatchController,
    PartsController,
    RuleBlocksController,
    capabilities,
)
from fuzzynav.world.run_limits import wheel_voltages

__all__ = ["ControllerCheckError", "check_controller", "check_registered", "SAMPLE_INPUTS"]


class ControllerCheckError(ValueError):
    """A controller does not meet the interface (the message lists every problem)."""


def _sample_context(inputs, ranges):
    """A :class:`~fuzzynav.world.perception.ControlContext` that agrees with ``inputs``:
    the robot at the origin facing +x, the target at (d_t, phi_t), one obstacle where
    (d_o, phi_o) puts it (none when nothing is sensed)."""
    from fuzzynav.world.perception import ControlContext

    d_t, d_o, phi_t, phi_o = (float(v) for v in inputs)
    obstacles = ()
    if not math.isnan(d_o):
        reach = d_o + 0.8  # the Husky's half-length and a 0.3 m radius
        obstacles = ((reach * math.cos(phi_o), reach * math.sin(phi_o), 0.3),)
    return ControlContext(
        time_s=1.0,
        period_s=0.02,
        pose=(0.0, 0.0, 0.0),
        target=(d_t * math.cos(phi_t), d_t * math.sin(phi_t)),
        obstacles=obstacles,
        ranges_m=tuple(float(r) for r in ranges),
    )


def _decisions(controller, caps) -> np.ndarray:
    out = []
    for inputs, ranges in zip(SAMPLE_INPUTS, SAMPLE_RANGES_M):
        if "context" in caps:
            voltages = controller(inputs.copy(), context=_sample_context(inputs, ranges))
        elif "ranges" in caps:
            voltages = controller(inputs.copy(), ranges_m=ranges.copy())
        else:
            voltages = controller(inputs.copy())
        out.append(wheel_voltages(voltages, controller))  # two real numbers, or ValueError
    return np.array(out)


def check_controller(controller: Any) -> frozenset[str]:
    """Check ``controller`` against :mod:`controller.interface`; its capabilities.

    Parameters
    ----------
    controller : object
        What would drive the robot.

    Returns
    -------
    frozenset of str
        The capabilities it declares (:func:`controller.interface.capabilities`).

    Raises
    ------
    ControllerCheckError
        Each problem found, one per line: no ``reset()``, not callable, a decision that
        is not two finite numbers, decisions that differ after ``reset()`` (state not
        reset), a declared capability that fails, a batch form that decides otherwise.
    """
    label = getattr(controller, "name", None) or type(controller).__name__
    problems = []
    if not callable(getattr(controller, "reset", None)):
        problems.append("has no reset() method (called before every run)")
    if not callable(controller):
        problems.append("is not callable as controller(inputs) -> (left, right) volts")
    if problems:
        raise ControllerCheckError(f"controller {label!r}: " + "; ".join(problems))
    caps = capabilities(controller)
    if "robot" in caps or "sensor_mounts" in caps:
        from fuzzynav.world.robot import HUSKY, brief

        try:
            brief(controller, HUSKY)  # as the simulation tells it before each start
        except Exception as exc:  # noqa: BLE001 - reported, with its type
            problems.append(f"set_robot/set_sensor_mounts (the Husky) raised {exc!r}")
    first = second = None
    try:
        controller.reset()
        first = _decisions(controller, caps)
        controller.reset()
        second = _decisions(controller, caps)
    except Exception as exc:  # noqa: BLE001 - reported, with its type
        problems.append(f"deciding on the sample inputs raised {exc!r}")
    if first is not None and second is not None:
        if not np.isfinite(first).all():
            rows = sorted({int(i) for i in np.argwhere(~np.isfinite(first))[:, 0]})
            problems.append(f"non-finite voltages for sample inputs {SAMPLE_INPUTS[rows].tolist()}")
        elif not np.array_equal(first, second):
            problems.append("decides otherwise after reset(): reset() must forget the run")
    problems += _capability_problems(controller, caps, first)
    if problems:
        raise ControllerCheckError(f"controller {label!r}: " + "; ".join(problems))
    return caps


def _capability_problems(controller, caps, decisions) -> list[str]:
    problems = []
    if isinstance(controller, RuleBlocksController):
        from fuzzynav.controller.fuzzy import FuzzySystem

        blocks = controller.rule_blocks()
        if not isinstance(blocks, Mapping) or not blocks:
            problems.append("rule_blocks() is not a non-empty mapping")
        elif not all(isinstance(b, FuzzySystem) for b in blocks.values()):
            problems.append("rule_blocks() holds something that is not a FuzzySystem")
    if isinstance(controller, PartsController):
        try:
            controller.set_parts_off([])
            controller.set_parts_off(["no such part"])
        except ValueError:
            pass
        else:
            problems.append("set_parts_off accepted an unknown part name")
        controller.set_parts_off([])
    if "batch" in caps and decisions is not None and np.isfinite(decisions).all():
        batch = type(controller).batched([controller], None)  # as documented: two arguments
        if not isinstance(batch, BatchController):
            problems.append("batched() made no object with decide(inputs, runs, ranges_m)")
        else:
            runs = np.arange(len(SAMPLE_INPUTS))
            raw = np.asarray(batch.decide(SAMPLE_INPUTS.copy(), runs, SAMPLE_RANGES_M.copy()))
            if raw.dtype.kind not in "iuf":
                problems.append(f"its batch form returned {raw.dtype} values, not voltages")
            elif raw.shape != decisions.shape or not np.allclose(
                raw.astype(float), decisions, rtol=0, atol=1e-9
            ):
                problems.append("its batch form decides otherwise than the controller")
    return problems


def check_registered(name: str, geometry: str = "husky") -> frozenset[str]:
    """Check the registered controller ``name`` and that its entry's flags hold.

    Parameters
    ----------
    name : str
        A registered name.
    geometry : str
        The design to build (geometry-aware controllers).

    Returns
    -------
    frozenset of str
        Its controllers' capabilities.

    Raises
    ------
    ControllerCheckError
        The controller fails :func:`check_controller`, or the entry says ``batchable``
        or ``fis_export`` where the controller does not (or the other way round), or
        its tunable does not build a controller that passes.
    """
    from fuzzynav.controller.registry import controller_entry, import_factory
    from fuzzynav.controller.tuning import Tunable

    entry = controller_entry(name)
    controller = entry.build(geometry)
    caps = check_controller(controller)
    problems = []
    if entry.batchable != ("batch" in caps):
        problems.append(f"the entry says batchable={entry.batchable}, its class says otherwise")
    exportable = "rule_blocks" in caps or hasattr(controller, "fis")
    if entry.fis_export != exportable:
        problems.append(f"the entry says fis_export={entry.fis_export}, the controller otherwise")
    if entry.tunable is not None:
        tunable = import_factory(entry.tunable)()
        if not isinstance(tunable, Tunable):
            problems.append(f"{entry.tunable} made no Tunable")
        else:
            check_controller(tunable.build(tunable.initial_vector()))
    if problems:
        raise ControllerCheckError(f"controller {name!r}: " + "; ".join(problems))
    return caps
