"""What both forms of :mod:`fuzzynav.gym` share: their settings, checked by name; the
engine; the scenario a reset draws; the observation (its bounds) and the reward.

A part of :mod:`fuzzynav.gym` (which re-exports the public names); it needs no gymnasium.
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fuzzynav.app.args import integer_value
from fuzzynav.world.batch_world import BatchWorld
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M
from fuzzynav.world.scenario import (
    DEFAULT_FOOTPRINT_M,
    Scenario,
    check_scenario,
    load_scenario,
)
from fuzzynav.world.scenario_format import MAX_DISTURBANCE, MAX_DURATION_S

__all__ = [
    "OBSERVATION_NAMES",
    "OBSERVATION_LOW",
    "OBSERVATION_HIGH",
    "PROGRESS_REWARD_PER_M",
    "REACH_REWARD",
    "COLLISION_REWARD",
    "MAX_NUM_ENVS",
    "OBSERVATION_DTYPES",
    "Setup",
    "checked_action",
]

#: Observations, actions, rewards and wheel voltages: float64 arrays (``step`` takes any
#: array_like action).
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: Observations: float64 (the default: the engine's own numbers, exactly) or float32
#: (``observation_dtype="float32"``, as many learning libraries want them).
ObservationArray: TypeAlias = npt.NDArray[np.floating[Any]]
#: The observation dtypes an environment offers.
OBSERVATION_DTYPES = ("float64", "float32")
#: Terminations and truncations: bool arrays.
BoolArray: TypeAlias = npt.NDArray[np.bool_]
#: The observation's entries, in order (units in :class:`fuzzynav.gym.HuskyEnv`'s docstring).
OBSERVATION_NAMES = ("d_t", "d_o", "phi_t", "phi_o", "obstacle_seen", "v", "w")
#: The default rewards: per metre of progress to the target, on arriving at the target,
#: and on touching an obstacle (``progress_reward_per_m``, ``reach_reward``,
#: ``collision_reward`` change them).
PROGRESS_REWARD_PER_M = 1.0
REACH_REWARD = 10.0
COLLISION_REWARD = -10.0
#: Bounds of the observation: distances (m) beyond any scenario's coordinates (10 km)
#: and disturbance; angles (rad) a bearing plus the largest disturbance; the speeds
#: (m/s, rad/s) several times what the Husky reaches at 12 V. Observations are clipped
#: to them.
DISTANCE_BOUND_M = 1.0e5
ANGLE_BOUND_RAD = float(np.float32(math.pi + MAX_DISTURBANCE))
SPEED_BOUND_MPS = 10.0
YAW_RATE_BOUND_RADPS = 20.0
#: Maximum ``num_envs`` of :class:`fuzzynav.gym.HuskyVectorEnv` (a sweep's largest ``n``).
MAX_NUM_ENVS = 100_000
#: The largest layout index a reset may draw (``layouts``' stop is at most this + 1):
#: numpy's generator draws int64 indices.
MAX_LAYOUT_INDEX = 2**63 - 2
OBSERVATION_HIGH = np.array(
    [
        DISTANCE_BOUND_M,
        DISTANCE_BOUND_M,
        ANGLE_BOUND_RAD,
        ANGLE_BOUND_RAD,
        1.0,
        SPEED_BOUND_MPS,
        YAW_RATE_BOUND_RADPS,
    ]
)
OBSERVATION_LOW = -OBSERVATION_HIGH
OBSERVATION_LOW[4] = 0.0


@functools.lru_cache(maxsize=8192)
def _layout(family: str, seed: int, index: int) -> Scenario:
    return generate_layout(family, seed, index)


def _positive_seconds(value: object, name: str) -> float:
    """``value`` as a float of seconds in (0, :data:`MAX_DURATION_S`]; ValueError naming
    ``name`` otherwise (NaN, inf, 0, a negative time, a bool, a string)."""
    if not isinstance(value, bool) and isinstance(value, numbers.Real):
        seconds = float(value)
        if math.isfinite(seconds) and 0.0 < seconds <= MAX_DURATION_S:
            return seconds
    raise ValueError(
        f"{name} = {value!r}: must be a number of seconds > 0 and at most {MAX_DURATION_S:g}"
    )


def _finite(value: object, name: str) -> float:
    if not isinstance(value, bool) and isinstance(value, numbers.Real):
        number = float(value)
        if math.isfinite(number):
            return number
    raise ValueError(f"{name} = {value!r}: must be a finite number")


def _layout_range(layouts: object) -> tuple[int, int]:
    """``(first, stop)`` of layout indices, both integers, ``0 <= first < stop``."""
    rule = "must be (first, stop): two integers with 0 <= first < stop"
    if isinstance(layouts, str | bytes) or not isinstance(layouts, Sequence) or len(layouts) != 2:
        raise ValueError(f"layouts = {layouts!r}: {rule}")
    pair = []
    for value in layouts:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise ValueError(f"layouts = {layouts!r}: {rule} ({value!r} is not an integer)")
        pair.append(int(value))
    low, high = pair
    if not 0 <= low < high:
        raise ValueError(f"layouts = {layouts!r}: {rule}")
    if high > MAX_LAYOUT_INDEX + 1:
        raise ValueError(f"layouts = {layouts!r}: stop must be at most {MAX_LAYOUT_INDEX + 1}")
    return low, high


def checked_seed(value: object, name: str = "seed") -> int | None:
    """A reset's seed: None, or an integer >= 0 (a numpy integer too) as a Python int;
    ValueError naming it otherwise (NaN, -1, a string), as the command line's ``--seed``."""
    return None if value is None else integer_value(value, name, 0)


def checked_options(options: object, known: tuple[str, ...]) -> dict[str, Any]:
    """A reset's ``options``: None or a dict of the ``known`` keys; ValueError naming an
    unknown key (a misspelt ``"scenaro"`` was ignored) or anything else given."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(
            f"options = {options!r}: must be None or a dict (keys: {', '.join(known)})"
        )
    unknown = sorted(str(k) for k in options if k not in known)
    if unknown:
        raise ValueError(
            f"options: unknown key(s) {', '.join(unknown)} (known: {', '.join(known)})"
        )
    return options


def _observation_dtype(value: object) -> np.dtype[Any]:
    """``value`` as one of :data:`OBSERVATION_DTYPES` (a name, a numpy type or dtype)."""
    for name in OBSERVATION_DTYPES:
        dtype = np.dtype(name)
        if isinstance(value, str | type | np.dtype) and (
            value == name or value is dtype.type or value == dtype
        ):
            return dtype
    raise ValueError(
        f"observation_dtype = {value!r}: must be one of {', '.join(OBSERVATION_DTYPES)}"
    )


def checked_action(action: npt.ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    """An action (or a vector env's actions) as floats, of exactly ``shape`` and finite;
    ValueError naming what is wrong (a string, a (2, 1) array, NaN)."""
    raw = np.asarray(action)
    if raw.dtype.kind not in "biuf":
        raise ValueError(f"action = {raw.tolist()!r}: must be real numbers, not {raw.dtype}")
    if raw.shape != shape:
        raise ValueError(f"action of shape {raw.shape}: must be of shape {shape}")
    values: FloatArray = raw.astype(float)
    if not np.isfinite(values).all():
        raise ValueError(f"action = {values.tolist()}: must be finite")
    return values


class Setup:
    """What both forms share: the settings, the engine, the scenario drawn at a reset,
    the observation and the reward."""

    def __init__(
        self,
        family: str,
        layout_seed: int,
        layouts: tuple[int, int],
        scenarios: Sequence[Scenario | str | Path] | Scenario | str | Path | None,
        perception: str,
        geometry: str,
        control_period_s: float,
        max_duration_s: float | None,
        rewards: tuple[float, float, float],
        observation_dtype: object = "float64",
    ):
        self.observation_dtype = _observation_dtype(observation_dtype)
        # a start is checked against the robot that drives, as simulate checks it
        self.footprint_m = (0.0, 0.0) if geometry == "paper" else DEFAULT_FOOTPRINT_M
        if max_duration_s is not None:
            max_duration_s = _positive_seconds(max_duration_s, "max_duration_s")
        self.progress_reward, self.reach_reward, self.collision_reward = (
            _finite(value, name)
            for value, name in zip(
                rewards, ("progress_reward_per_m", "reach_reward", "collision_reward")
            )
        )
        self.scenarios: list[Scenario] | None = None
        if scenarios is not None:
            if isinstance(scenarios, Scenario | str | Path):
                scenarios = [scenarios]  # one scenario, not a string read per character
            if isinstance(scenarios, bytes) or not isinstance(scenarios, Sequence):
                raise ValueError(
                    f"scenarios = {scenarios!r}: a Scenario, a shipped name, a scenario file "
                    "or a sequence (list, tuple) of them"
                )
            self.scenarios = [self.scenario(sc, "scenarios") for sc in scenarios]
            if not self.scenarios:
                raise ValueError("scenarios: the list is empty")
        else:
            layouts = _layout_range(layouts)
            layout_seed = integer_value(layout_seed, "layout_seed", 0)
            generate_layout(family, layout_seed, layouts[0])  # a bad family fails here
        self.family, self.layout_seed, self.layouts = family, int(layout_seed), layouts
        self.world = BatchWorld(
            perception=perception,
            geometry=geometry,
            control_period_s=control_period_s,
            max_duration_s=max_duration_s,
        )
        self.limit = self.world.limit

    def scenario(self, value: object, name: str) -> Scenario:
        """A scenario given by the user, checked as :func:`fuzzynav.simulate` checks it: a
        :class:`Scenario` as a file is (a NaN target, an obstacle on the robot's start are
        refused), a shipped name (``"s1"``) or a file read and checked."""
        if isinstance(value, Scenario):
            check_scenario(value, self.footprint_m)
            return value
        if isinstance(value, str | Path):
            return load_scenario(value, footprint_m=self.footprint_m)
        raise ValueError(
            f"{name}: {value!r} is not a scenario (give a Scenario, a shipped name such "
            "as 's1', or a scenario file's path)"
        )

    def draw(self, rng: np.random.Generator) -> tuple[Scenario, int]:
        """A reset's scenario and sonar seed, from the environment's generator."""
        if self.scenarios is not None:
            scenario = self.scenarios[int(rng.integers(len(self.scenarios)))]
        else:
            index = int(rng.integers(self.layouts[0], self.layouts[1]))
            scenario = _layout(self.family, self.layout_seed, index)
        return scenario, int(rng.integers(2**31))

    def observations(self) -> ObservationArray:
        """(n, 7) observations of the world's runs now (its ``observe`` stage), clipped
        to the observation space's bounds."""
        inputs, _ = self.world.observe()
        seen = np.isfinite(inputs[:, 1])
        lg = self.world.lg_state
        observed = np.stack(
            [
                inputs[:, 0],
                np.where(seen, inputs[:, 1], OBSTACLE_CUTOFF_M),
                inputs[:, 2],
                np.where(seen, inputs[:, 3], 0.0),
                seen.astype(float),
                lg[:, 2],
                lg[:, 3],
            ],
            axis=1,
        )
        clipped: ObservationArray = np.clip(observed, OBSERVATION_LOW, OBSERVATION_HIGH).astype(
            self.observation_dtype, copy=False
        )  # the bounds are float32 numbers: a clipped value stays within them when cast
        return clipped

    def distances(self) -> FloatArray:
        """The true distance of each run's centre to its target, m (n,)."""
        s = self.world.s
        distance: FloatArray = np.hypot(s.target[:, 0] - s.x, s.target[:, 1] - s.y)
        return distance

    def voltages(self, actions: FloatArray) -> FloatArray:
        volts: FloatArray = actions * self.limit
        return volts

    def rewards(
        self, before: FloatArray, after: FloatArray, codes: npt.NDArray[np.int_]
    ) -> FloatArray:
        reward = self.progress_reward * (before - after)
        reward = np.where(codes == 0, reward + self.reach_reward, reward)
        rewarded: FloatArray = np.where(codes == 1, reward + self.collision_reward, reward)
        return rewarded
