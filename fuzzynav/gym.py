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

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from fuzzynav.app.args import integer_value
from fuzzynav.gym_setup import (
    COLLISION_REWARD,
    MAX_NUM_ENVS,
    OBSERVATION_HIGH,
    OBSERVATION_LOW,
    OBSERVATION_NAMES,
    PROGRESS_REWARD_PER_M,
    REACH_REWARD,
    BoolArray,
    FloatArray,
    ObservationArray,
    Setup,
    checked_action,
    checked_options,
    checked_seed,
)
from fuzzynav.world.kernels import law_centre, obstacle_law
from fuzzynav.world.scenario import Scenario

__all__ = [
    "ENV_ID",
    "HuskyEnv",
    "HuskyVectorEnv",
    "MAX_NUM_ENVS",
    "OBSERVATION_HIGH",
    "OBSERVATION_LOW",
    "OBSERVATION_NAMES",
    "PROGRESS_REWARD_PER_M",
    "REACH_REWARD",
    "COLLISION_REWARD",
    "controller_inputs",
    "render_rgb",
]

ENV_ID = "fuzzynav/Husky-v0"


def _spaces(dtype: np.dtype[Any]) -> tuple[spaces.Box[Any], spaces.Box[np.float64]]:
    observation = spaces.Box(
        OBSERVATION_LOW.astype(dtype), OBSERVATION_HIGH.astype(dtype), dtype=dtype.type
    )
    action = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float64)
    return observation, action


class HuskyEnv(gym.Env[ObservationArray, FloatArray]):
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

    ``Box((7,), float64)`` (or float32: ``observation_dtype``) with finite bounds, the controller's inputs as the robot
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
    observation_dtype : {"float64", "float32"}
        The observations' dtype: float64, the engine's numbers exactly (what
        :func:`controller_inputs` needs to drive a fuzzynav controller as the engine
        does), or float32 (the same numbers rounded), as many learning libraries want.
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
        observation_dtype: str = "float64",
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: must be None or 'rgb_array'")
        self._setup = Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
            (progress_reward_per_m, reach_reward, collision_reward), observation_dtype,
        )  # fmt: skip
        self.observation_space, self.action_space = _spaces(self._setup.observation_dtype)
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._setup.world.dt)}
        self.scenario: Scenario | None = None
        self._episode_over = True  # no episode yet: reset() starts one

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObservationArray, dict[str, Any]]:
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
        options = checked_options(options, ("scenario",))
        super().reset(seed=checked_seed(seed))
        scenario, sonar_seed = self._setup.draw(self.np_random)
        if options.get("scenario") is not None:
            scenario = self._setup.scenario(options["scenario"], 'options["scenario"]')
        self.scenario = scenario
        self._setup.world.reset([scenario], [sonar_seed])
        self._distance = self._setup.distances()
        self._episode_over = False
        return self._setup.observations()[0], {}

    def step(
        self, action: npt.ArrayLike
    ) -> tuple[ObservationArray, float, bool, bool, dict[str, int]]:
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
        code = setup.world.step(setup.voltages(checked_action(action, (2,))).reshape(1, 2))
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


class HuskyVectorEnv(VectorEnv[ObservationArray, FloatArray, FloatArray | BoolArray]):
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
    progress_reward_per_m, reach_reward, collision_reward, observation_dtype
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
        observation_dtype: str = "float64",
    ) -> None:
        num_envs = integer_value(num_envs, "num_envs", 1, MAX_NUM_ENVS)
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r}: the vector form draws nothing")
        self._setup = Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
            (progress_reward_per_m, reach_reward, collision_reward), observation_dtype,
        )  # fmt: skip
        self.num_envs = num_envs
        self.single_observation_space, self.single_action_space = _spaces(
            self._setup.observation_dtype
        )
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
    ) -> tuple[ObservationArray, dict[str, Any]]:
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
        options = checked_options(options, ("reset_mask",))
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            first = integer_value(seed, "seed", 0)
            seeds = [first + i for i in range(n)]
        elif isinstance(seed, Sequence) and not isinstance(seed, str | bytes):
            seeds = [checked_seed(s, f"seed[{i}]") for i, s in enumerate(seed)]
            if len(seeds) != n:
                raise ValueError(f"seed has {len(seeds)} entries for {n} environments")
        else:
            raise ValueError(f"seed = {seed!r}: None, an integer >= 0 or one per environment")
        mask = np.ones(n, dtype=bool)
        if options.get("reset_mask") is not None:
            mask = np.asarray(options["reset_mask"])
            if mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(
                    f"options['reset_mask'] of {mask.dtype} and shape {mask.shape}: must be "
                    f"booleans of shape ({n},)"
                )
            mask = mask.copy()
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
    ) -> tuple[ObservationArray, FloatArray, BoolArray, BoolArray, dict[str, Any]]:
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
        volts = setup.voltages(checked_action(actions, (self.num_envs, 2)))
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
