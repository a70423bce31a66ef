"""What a controller is: the interface the world drives, and the optional capabilities.

A **controller** turns the four inputs of the paper into two wheel voltages, once a
control period:

==========  =====  ==========================================================
input       unit   meaning
==========  =====  ==========================================================
``d_t``     m      distance from the robot to the target
``d_o``     m      clearance to the nearest sensed obstacle; NaN: none sensed
``phi_t``   rad    bearing of the target from the heading, in (-pi, pi]
``phi_o``   rad    bearing of that obstacle from the heading; NaN: none sensed
==========  =====  ==========================================================

and returns ``(v_s1, v_s2)``, the left and right wheel voltages in V (the world clips
them to +-12 V, the paper's saturation block). ``reset()`` is called before every run.
That is the whole contract (:class:`Controller`); everything else is optional and
declared by the attributes below, never guessed:

- :class:`RangeController`: ``needs_ranges = True`` and the call takes
  ``ranges_m=`` (the three sonar readings, m, inf = nothing in range);
- :class:`ContextController`: ``needs_context = True`` and the call takes ``context=``,
  a :class:`~fuzzynav.world.perception.ControlContext` (time, period, pose, target,
  every obstacle, the readings): the world as the simulation knows it;
- :class:`MountAwareController`: ``needs_sensor_mounts = True`` and
  ``set_sensor_mounts(mounts)``, called before each run with the robot's sonars;
- :class:`RobotAwareController`: ``needs_robot = True`` and ``set_robot(robot)``, called
  before each run with the whole :class:`~fuzzynav.world.robot.RobotDescription`
  (its footprint, mounts, voltage limit);
- :class:`RuleBlocksController`: ``rule_blocks()``, its fuzzy systems by name (what
  ``fuzzynav fis export`` writes and the viewer shows);
- :class:`PartsController`: ``parts_off`` and ``set_parts_off(names)`` (``--off``);
- :class:`FuzzyController`: one fuzzy system, ``fis`` (the paper's, a ``.fis`` file's);
- :class:`ParamsController`: crisp parameters besides its rules, ``params_toml()``;
- :class:`WrappedController`: a wrapper (the viewer's observer) around ``inner``;
- :class:`BatchController`: ``decide(inputs (n, 4), runs (n,), ranges_m (n, 3))``,
  the form the lockstep batch engine (:mod:`world.batch`) drives; a controller class
  that can make one declares ``batched(controllers, run_sets)`` (:class:`Batchable`).

:func:`controller.checker.check_controller` checks any object against this interface
(as gymnasium's ``env_checker`` checks an environment); the registry
(:mod:`controller.registry`) runs it on every controller it offers, in the tests.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar, Protocol, TypeAlias, runtime_checkable

import numpy as np

__all__ = [
    "INPUT_NAMES",
    "SAMPLE_INPUTS",
    "SAMPLE_RANGES_M",
    "Controller",
    "ControllerFunction",
    "RangeController",
    "ContextController",
    "MountAwareController",
    "RobotAwareController",
    "RuleBlocksController",
    "PartsController",
    "FuzzyController",
    "ParamsController",
    "WrappedController",
    "BatchController",
    "Batchable",
    "capabilities",
    "unwrapped",
]

#: The inputs, in the order of the array a controller receives.
INPUT_NAMES = ("d_t", "d_o", "phi_t", "phi_o")

_NAN = math.nan
#: Inputs ``[d_t, d_o, phi_t, phi_o]`` a check decides on: obstacle ahead, beside,
#: none sensed, the target behind, at the target, far away.
SAMPLE_INPUTS = np.array(
    [
        [5.0, 1.0, 0.0, 0.0],
        [5.0, 0.3, 0.5, -0.8],
        [5.0, 0.05, -0.5, 1.2],
        [3.0, _NAN, 0.2, _NAN],
        [3.0, _NAN, math.pi, _NAN],
        [0.0, _NAN, 0.0, _NAN],
        [40.0, 2.0, -3.0, 3.0],
    ]
)
#: Sonar readings (left, front, right; m, inf = nothing) that go with them.
SAMPLE_RANGES_M = np.array(
    [
        [math.inf, 1.0, math.inf],
        [0.3, math.inf, math.inf],
        [math.inf, math.inf, 0.05],
        [math.inf, math.inf, math.inf],
        [math.inf, math.inf, math.inf],
        [math.inf, math.inf, math.inf],
        [2.0, 2.5, math.inf],
    ]
)


@runtime_checkable
class Controller(Protocol):
    """Four inputs in, two wheel voltages out (module docstring)."""

    def reset(self) -> None:
        """Forget everything of the previous run (called before each)."""

    def __call__(self, inputs: np.ndarray) -> Sequence[float] | np.ndarray:
        """``(v_s1, v_s2)`` in V for ``inputs = [d_t, d_o, phi_t, phi_o]``."""


#: A controller as one plain function, no class: ``f(inputs (4,)) -> (left, right)`` V,
#: or vectorised, ``f(inputs (n, 4)) -> voltages (n, 2)`` (:mod:`controller.function`).
ControllerFunction: TypeAlias = Callable[[np.ndarray], Any]


@runtime_checkable
class RangeController(Protocol):
    """Reads the raw sonar ranges too: called as ``controller(inputs, ranges_m=r)``."""

    needs_ranges: bool

    def __call__(self, inputs: np.ndarray, ranges_m: Sequence[float] | None = None) -> Any:
        """The voltages, given the inputs and the three readings (m; inf: none)."""


@runtime_checkable
class ContextController(Protocol):
    """Asks for the world's context: called as ``controller(inputs, context=c)``."""

    needs_context: bool

    def __call__(self, inputs: np.ndarray, context: Any = None) -> Any:
        """The voltages, given the inputs and a ``ControlContext``."""


@runtime_checkable
class MountAwareController(Protocol):
    """Knows where its sonars point: given the robot's mounts before each run."""

    needs_sensor_mounts: bool

    def set_sensor_mounts(self, sensor_mounts: Sequence[Any]) -> None:
        """Take the robot's :class:`~fuzzynav.world.sensors.SensorMount` s."""


@runtime_checkable
class RobotAwareController(Protocol):
    """Knows the robot it drives: given its description before each run."""

    needs_robot: bool

    def set_robot(self, robot: Any) -> None:
        """Take the robot's :class:`~fuzzynav.world.robot.RobotDescription`."""


@runtime_checkable
class RuleBlocksController(Protocol):
    """Made of fuzzy systems that can be shown and exported."""

    def rule_blocks(self) -> Mapping[str, Any]:
        """Block name -> :class:`~fuzzynav.controller.fuzzy.FuzzySystem`."""


@runtime_checkable
class PartsController(Protocol):
    """Has named parts that can be switched off (an ablation)."""

    parts_off: tuple[str, ...]

    def set_parts_off(self, names: Sequence[str] = ()) -> None:
        """Switch off ``names`` (and on every other part); an unknown name is refused."""


@runtime_checkable
class FuzzyController(Protocol):
    """Drives with one fuzzy system (4 inputs, 2 outputs)."""

    fis: Any  # a controller.fuzzy.FuzzySystem


@runtime_checkable
class ParamsController(Protocol):
    """Has crisp parameters besides its rules (fuzzynav's navigator)."""

    def params_toml(self) -> str:
        """Its parameters as the TOML it is built from."""


@runtime_checkable
class WrappedController(Protocol):
    """Wraps another controller (the viewer observes its calls)."""

    inner: Any


def unwrapped(controller: Any) -> Any:
    """The controller inside any wrappers (:class:`WrappedController`).

    Parameters
    ----------
    controller : object
        A controller, wrapped or not.
    """
    while isinstance(controller, WrappedController):
        controller = controller.inner
    return controller


@runtime_checkable
class BatchController(Protocol):
    """Decides for many runs at once (the batch engine's form)."""

    def decide(
        self, inputs: np.ndarray, runs: np.ndarray, ranges_m: np.ndarray | None = None
    ) -> np.ndarray:
        """Voltages (n, 2) for ``inputs`` (n, 4) of the runs ``runs`` (n,)."""


@runtime_checkable
class Batchable(Protocol):
    """A controller class that can make its batch form."""

    batched: ClassVar[Any]


def capabilities(controller: object) -> frozenset[str]:
    """The optional capabilities ``controller`` declares, by name: ``ranges``,
    ``sensor_mounts``, ``rule_blocks``, ``parts``, ``batch``.

    Parameters
    ----------
    controller : object
        A controller (anything :class:`Controller` describes).

    Returns
    -------
    frozenset of str
        The names whose protocol the object meets and whose flag (if any) is set.
    """
    found = set()
    if isinstance(controller, RangeController) and controller.needs_ranges:
        found.add("ranges")
    if isinstance(controller, ContextController) and controller.needs_context:
        found.add("context")
    if isinstance(controller, MountAwareController) and controller.needs_sensor_mounts:
        found.add("sensor_mounts")
    if isinstance(controller, RobotAwareController) and controller.needs_robot:
        found.add("robot")
    if isinstance(controller, RuleBlocksController):
        found.add("rule_blocks")
    if isinstance(controller, PartsController):
        found.add("parts")
    if callable(getattr(type(controller), "batched", None)):
        found.add("batch")
    return frozenset(found)
