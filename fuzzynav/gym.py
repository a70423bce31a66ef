"""gymnasium environments on fuzzynav's plant and sensors (an optional extra:
``pip install fuzzynav[gym]``).

Importing this module registers ``fuzzynav/Husky-v0``::

    import gymnasium
    import fuzzynav.gym  # noqa: F401  (registers the environment)

    env = gymnasium.make("fuzzynav/Husky-v0", perception="ultrasonic")
    envs = gymnasium.make_vec("fuzzynav/Husky-v0", num_envs=1000)  # HuskyVectorEnv

:class:`HuskyEnv` is one robot; :class:`HuskyVectorEnv`, the environment's vector entry
point, is N of them on the lockstep batch engine's stepping form
(:class:`world.batch_world.BatchWorld`): fixed N, ended runs started again on the next
step (gymnasium's next-step autoreset), equal step for step to N single environments
(``make_vec(..., vectorization_mode="sync")``). The single environment is the same
engine with N = 1, so the two forms give the same numbers. docs/gym.md has the
details and an example.
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TypeAlias

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from fuzzynav.app.args import integer_value
from fuzzynav.world.batch_world import BatchWorld
from fuzzynav.world.kernels import law_centre, obstacle_law
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
    "ENV_ID",
    "HuskyEnv",
    "HuskyVectorEnv",
    "OBSERVATION_NAMES",
    "controller_inputs",
    "render_rgb",
]

ENV_ID = "fuzzynav/Husky-v0"
#: Observations, actions, rewards and wheel voltages: float64 arrays (``step`` takes any
#: array_like action).
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: Terminations and truncations: bool arrays.
BoolArray: TypeAlias = npt.NDArray[np.bool_]
#: The observation's entries, in order (units in :class:`HuskyEnv`'s docstring).
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
#: Maximum ``num_envs`` of :class:`HuskyVectorEnv` (a sweep's largest ``n``).
MAX_NUM_ENVS = 100_000
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
    return low, high


def _action(action: npt.ArrayLike, shape: tuple[int, ...]) -> FloatArray:
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


class _Setup:
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
    ):
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

    def observations(self) -> FloatArray:
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
        clipped: FloatArray = np.clip(observed, OBSERVATION_LOW, OBSERVATION_HIGH)
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


def _spaces() -> tuple[spaces.Box[np.float64], spaces.Box[np.float64]]:
    observation = spaces.Box(OBSERVATION_LOW, OBSERVATION_HIGH, dtype=np.float64)
    action = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float64)
    return observation, action


class HuskyEnv(gym.Env[FloatArray, FloatArray]):
    """The LG Husky of the paper among circular obstacles, driven by its wheel voltages.

    ## Description

    One run of :class:`world.simulation.Simulation`'s loop on the batch engine
    (:class:`world.batch_world.BatchWorld` with one run): the LG plant stepped exactly
    over each control period, the Husky's 0.99 x 0.67 m footprint (or the paper's point
    robot), ideal perception (Eqs. 7-12) or the three US-100 sonars, the scenario's
    disturbance and moving obstacles. Each reset draws a scenario: a layout of
    ``family`` (:func:`world.layouts.generate_layout`, index uniform in ``layouts``) or
    one of ``scenarios``.

    ## Action Space

    ``Box(-1, 1, (2,), float64)``: the left and right wheel voltages as fractions of the
    voltage limit (12 V): the voltages applied are ``12 * action`` V, held for one
    control period, saturated at +-12 V.

    ## Observation Space

    ``Box((7,), float64)`` with finite bounds, the controller's inputs as the robot
    senses them (the scenario's disturbance added, as the paper's controller sees them)
    and its speeds, clipped to the bounds (:data:`OBSERVATION_LOW`,
    :data:`OBSERVATION_HIGH`; no run of a valid scenario reaches them):

    | Num | Observation | Unit | Min | Max |
    |-----|-------------|------|-----|-----|
    | 0 | ``d_t``: distance to the target | m | -1e5 | 1e5 |
    | 1 | ``d_o``: clearance to the nearest sensed obstacle; the cutoff (``OBSTACLE_CUTOFF_M``) if none | m | -1e5 | 1e5 |
    | 2 | ``phi_t``: bearing of the target from the heading, (-pi, pi] | rad | -(pi + 1000) | pi + 1000 |
    | 3 | ``phi_o``: bearing of that obstacle (ideal) or its sonar's angle; 0 if none | rad | -(pi + 1000) | pi + 1000 |
    | 4 | ``obstacle_seen``: 1 when an obstacle is sensed within the cutoff, else 0 | - | 0 | 1 |
    | 5 | ``v``: forward speed of the hull (LG state v_MH) | m/s | -10 | 10 |
    | 6 | ``w``: yaw rate (LG state w_JH) | rad/s | -20 | 20 |

    Entries 0-3 are signed because a scenario's disturbance (up to 1000 in amplitude)
    is added to them.

    ## Rewards

    Each step: ``progress_reward_per_m`` (default 1) times the decrease of the centre's
    distance to the target over the step (m), plus ``reach_reward`` (10) on arriving
    and ``collision_reward`` (-10) on touching an obstacle.

    ## Starting State

    The scenario's start pose at rest (LG state zero), time 0.

    ## Episode End

    1. Termination: the centre within the scenario's tolerance of the target (reached).
    2. Termination: a contact with an obstacle (collided; checked at the step's end and
       swept between the ends, as the pymunk engine does).
    3. Truncation: the scenario's duration (or ``max_duration_s``) has passed (timeout).

    ``info["outcome"]`` on the last step: 0 reached, 1 collided, 2 timeout (an index
    into :data:`world.run_limits.OUTCOMES`). A ``step`` after the last one, or before
    the first ``reset``, raises ``gymnasium.error.ResetNeeded``: call ``reset``.

    ## Arguments

    Parameters
    ----------
    family : str
        The layout family scenarios are drawn from (:data:`world.layouts.FAMILIES`).
    layout_seed : int
        The family's seed.
    layouts : tuple of int
        ``(first, stop)``: the layout indices a reset draws from (keep a range apart
        for held-out tests); two integers, ``0 <= first < stop``.
    scenarios : Scenario, str, Path or a sequence of them, optional
        Draw from these instead (scenario objects, names such as ``"s1"`` or scenario
        files), each checked as :func:`fuzzynav.simulate` checks a scenario.
    perception : {"ideal", "ultrasonic"}
        How obstacles are sensed.
    geometry : {"husky", "paper"}
        The Husky's footprint or the paper's point robot (ideal only).
    control_period_s : float
        The step, s (the paper's 20 ms by default).
    max_duration_s : float, optional
        Truncate every episode at this time at the latest, s (> 0, at most an hour).
    render_mode : {"rgb_array"}, optional
        :meth:`render` returns an (H, W, 3) uint8 picture of the scene.
    progress_reward_per_m, reach_reward, collision_reward : float
        The reward's terms (see Rewards).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        family: str = "standard",
        layout_seed: int = 0,
        layouts: tuple[int, int] = (0, 1000),
        scenarios: Sequence[Scenario | str | Path] | Scenario | str | Path | None = None,
        perception: str = "ideal",
        geometry: str = "husky",
        control_period_s: float = 0.02,
        max_duration_s: float | None = None,
        render_mode: str | None = None,
        progress_reward_per_m: float = PROGRESS_REWARD_PER_M,
        reach_reward: float = REACH_REWARD,
        collision_reward: float = COLLISION_REWARD,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: must be None or 'rgb_array'")
        self._setup = _Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
            (progress_reward_per_m, reach_reward, collision_reward),
        )  # fmt: skip
        self.observation_space, self.action_space = _spaces()
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._setup.world.dt)}
        self.scenario: Scenario | None = None
        self._episode_over = True  # no episode yet: reset() starts one

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[FloatArray, dict[str, Any]]:
        """Start an episode on a newly drawn scenario (see the class docstring).

        Parameters
        ----------
        seed : int, optional
            Seeds the environment's generator (the scenario and the sonar noise).
        options : dict, optional
            ``{"scenario": S}`` runs ``S`` instead of drawing one: a Scenario, a
            shipped name (``"s1"``) or a scenario file, checked as
            :func:`fuzzynav.simulate` checks it (ValueError).

        Returns
        -------
        tuple
            The observation (7,) and an empty info dict.
        """
        super().reset(seed=seed)
        scenario, sonar_seed = self._setup.draw(self.np_random)
        if options and options.get("scenario") is not None:
            scenario = self._setup.scenario(options["scenario"], 'options["scenario"]')
        self.scenario = scenario
        self._setup.world.reset([scenario], [sonar_seed])
        self._distance = self._setup.distances()
        self._episode_over = False
        return self._setup.observations()[0], {}

    def step(self, action: npt.ArrayLike) -> tuple[FloatArray, float, bool, bool, dict[str, int]]:
        """One control period with the wheel voltages ``12 * action`` V.

        Parameters
        ----------
        action : array_like, (2,)
            Left and right, fractions of the voltage limit.

        Returns
        -------
        tuple
            observation, reward, terminated, truncated, info.
        """
        if self._episode_over:
            raise gym.error.ResetNeeded(
                "step() before reset(): call reset() to start an episode"
                if self.scenario is None
                else "step() after the episode ended (terminated or truncated): "
                "call reset() to start another"
            )
        setup = self._setup
        code = setup.world.step(setup.voltages(_action(action, (2,))).reshape(1, 2))
        distance = setup.distances()
        reward = setup.rewards(self._distance, distance, code)
        self._distance = distance
        observation = setup.observations()[0]
        k = int(code[0])
        info = {"outcome": k} if k >= 0 else {}
        self._episode_over = k >= 0
        return observation, float(reward[0]), k in (0, 1), k == 2, info

    def render(self) -> npt.NDArray[np.uint8] | None:
        """The scene now as an (H, W, 3) uint8 array (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array" or self.scenario is None:
            return None
        world = self._setup.world
        return render_rgb(
            self.scenario, world.pose[0], world.half_length, world.half_width, world.time_s[0]
        )


class HuskyVectorEnv(VectorEnv[FloatArray, FloatArray, FloatArray | BoolArray]):
    """``num_envs`` :class:`HuskyEnv` s stepped together on the batch engine.

    Fixed ``num_envs``; a sub-environment whose episode ended (terminated or truncated)
    is reset at the next :meth:`step`, which ignores its action and returns its first
    observation with reward 0 (gymnasium's next-step autoreset,
    ``metadata["autoreset_mode"]``). Sub-environment ``i`` draws its scenarios from its
    own generator, seeded as ``SyncVectorEnv`` seeds its ``i``-th environment, so the
    two give the same numbers step for step.

    Parameters
    ----------
    num_envs : int
        Sub-environments, 1 to :data:`MAX_NUM_ENVS`.
    family, layout_seed, layouts, scenarios, perception, geometry, control_period_s, max_duration_s
        As :class:`HuskyEnv`.
    progress_reward_per_m, reach_reward, collision_reward : float
        As :class:`HuskyEnv`.
    render_mode : None
        Not drawn (render a :class:`HuskyEnv`).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        family: str = "standard",
        layout_seed: int = 0,
        layouts: tuple[int, int] = (0, 1000),
        scenarios: Sequence[Scenario | str | Path] | Scenario | str | Path | None = None,
        perception: str = "ideal",
        geometry: str = "husky",
        control_period_s: float = 0.02,
        max_duration_s: float | None = None,
        render_mode: str | None = None,
        progress_reward_per_m: float = PROGRESS_REWARD_PER_M,
        reach_reward: float = REACH_REWARD,
        collision_reward: float = COLLISION_REWARD,
    ) -> None:
        num_envs = integer_value(num_envs, "num_envs", 1, MAX_NUM_ENVS)
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r}: the vector form draws nothing")
        self._setup = _Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
            (progress_reward_per_m, reach_reward, collision_reward),
        )  # fmt: skip
        self.num_envs = num_envs
        self.single_observation_space, self.single_action_space = _spaces()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._rngs: list[np.random.Generator | None] = [None] * num_envs
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._started = False

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[FloatArray, dict[str, Any]]:
        """Start every sub-environment's episode (or those of ``options["reset_mask"]``).

        Parameters
        ----------
        seed : int, sequence of int or None, optional
            One int: sub-environment ``i`` gets ``seed + i``; a list: one each.
        options : dict, optional
            ``{"reset_mask": bool array (num_envs,)}`` resets only those.

        Returns
        -------
        tuple
            The observations (num_envs, 7) and an empty info dict.
        """
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed has {len(seeds)} entries for {n} environments")
        mask = np.ones(n, dtype=bool)
        if options and options.get("reset_mask") is not None:
            mask = np.asarray(options["reset_mask"], dtype=bool).reshape(n)
        if not self._started:
            mask[:] = True
        for i in np.flatnonzero(mask).tolist():
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(seeds[i])
        self._restart(np.flatnonzero(mask))
        self._autoreset[mask] = False
        self._distance = self._setup.distances()
        return self._setup.observations(), {}

    def _restart(self, envs: npt.NDArray[np.intp]) -> None:
        drawn = [self._setup.draw(self._rngs[i]) for i in envs.tolist()]
        scenarios = [sc for sc, _ in drawn]
        sonar_seeds = [s for _, s in drawn]
        world = self._setup.world
        if not self._started:
            world.reset(scenarios, sonar_seeds)
            self._started = True
        else:
            world.restart(envs, scenarios, sonar_seeds)

    def step(
        self, actions: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray, BoolArray, BoolArray, dict[str, Any]]:
        """One control period of every sub-environment (module docstring: autoreset).

        Parameters
        ----------
        actions : array_like, (num_envs, 2)
            Each sub-environment's action (:class:`HuskyEnv`).

        Returns
        -------
        tuple
            observations (num_envs, 7), rewards, terminations, truncations, infos.
        """
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        setup = self._setup
        volts = setup.voltages(_action(actions, (self.num_envs, 2)))
        again = self._autoreset
        if again.any():
            volts = np.where(again[:, None], 0.0, volts)  # ignored: they start again
        code = setup.world.step(volts)
        distance = setup.distances()
        reward = setup.rewards(self._distance, distance, code)
        if again.any():
            self._restart(np.flatnonzero(again))
            distance = setup.distances()
            reward = np.where(again, 0.0, reward)
            code = np.where(again, -1, code)
        self._distance = distance
        terminated = (code == 0) | (code == 1)
        truncated = code == 2
        self._autoreset = terminated | truncated
        infos: dict[str, Any] = {}
        if self._autoreset.any():
            infos = {"outcome": np.where(self._autoreset, code, 0), "_outcome": self._autoreset}
        return setup.observations(), reward, terminated, truncated, infos


def controller_inputs(observations: npt.ArrayLike) -> FloatArray:
    """The paper controller's inputs ``(d_t, d_o, phi_t, phi_o)`` from observations
    (NaN where no obstacle is sensed), for driving a fuzzynav batch controller.

    Parameters
    ----------
    observations : array_like, (n, 7) or (7,)
        Observations of :class:`HuskyEnv` or :class:`HuskyVectorEnv`.

    Returns
    -------
    numpy.ndarray, (n, 4)
    """
    obs = np.atleast_2d(np.asarray(observations, dtype=float))
    seen = obs[:, 4] > 0.5
    return np.stack(
        [
            obs[:, 0],
            np.where(seen, obs[:, 1], np.nan),
            obs[:, 2],
            np.where(seen, obs[:, 3], np.nan),
        ],
        axis=1,
    )


def render_rgb(
    scenario: Scenario,
    pose: Iterable[float],
    half_length_m: float,
    half_width_m: float,
    time_s: float = 0.0,
    size: int = 320,
) -> npt.NDArray[np.uint8]:
    """A top view of a scenario as an RGB raster: obstacles grey, the target green, the
    robot's footprint blue with its heading.

    Parameters
    ----------
    scenario : Scenario
        What to draw (its obstacles at ``time_s`` by their laws).
    pose : array_like, (3,)
        The robot's x, y (m) and heading (rad).
    half_length_m, half_width_m : float
        Half the footprint (0 for a point robot: drawn as a small disc), m.
    time_s : float
        The time the obstacles are drawn at, s.
    size : int
        The picture's width and height, pixels.

    Returns
    -------
    numpy.ndarray, (size, size, 3) uint8
    """
    x, y, heading = (float(v) for v in pose)
    points = [scenario.start, scenario.target, (x, y)]
    centres = [law_centre(obstacle_law(o), time_s) for o in scenario.obstacles]
    points += centres
    xs, ys = zip(*points)
    centre_x, centre_y = 0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys))
    span = max(max(xs) - min(xs), max(ys) - min(ys)) + 3.0
    pixel = span / size
    u = centre_x + (np.arange(size) + 0.5 - size / 2) * pixel
    v = centre_y - (np.arange(size) + 0.5 - size / 2) * pixel
    gx, gy = np.meshgrid(u, v)
    image = np.full((size, size, 3), 255, dtype=np.uint8)
    for centre, o in zip(centres, scenario.obstacles):
        image[np.hypot(gx - centre[0], gy - centre[1]) <= o.radius_m] = (140, 140, 140)
    tx, ty = scenario.target
    image[np.hypot(gx - tx, gy - ty) <= max(scenario.tolerance_m, 2 * pixel)] = (40, 170, 60)
    c, s = math.cos(heading), math.sin(heading)
    along = c * (gx - x) + s * (gy - y)
    across = -s * (gx - x) + c * (gy - y)
    body = (np.abs(along) <= max(half_length_m, 2 * pixel)) & (
        np.abs(across) <= max(half_width_m, 2 * pixel)
    )
    image[body] = (40, 90, 200)
    nose = (along >= 0) & (along <= max(half_length_m, 2 * pixel) + 0.3) & (np.abs(across) <= pixel)
    image[nose] = (200, 40, 40)
    return image


def _register() -> None:
    if ENV_ID not in gym.registry:
        gym.register(
            id=ENV_ID,
            entry_point="fuzzynav.gym:HuskyEnv",
            vector_entry_point="fuzzynav.gym:HuskyVectorEnv",
        )


_register()
