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
from collections.abc import Iterable, Sequence
from typing import Any, TypeAlias

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from fuzzynav.world.batch_world import BatchWorld
from fuzzynav.world.kernels import law_centre, obstacle_law
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M
from fuzzynav.world.scenario import Scenario, load_scenario

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
#: Reward on arriving at the target, and on touching an obstacle.
REACH_REWARD = 10.0
COLLISION_REWARD = -10.0
_OBS_LOW = np.array([-np.inf, -np.inf, -np.inf, -np.inf, 0.0, -np.inf, -np.inf])
_OBS_HIGH = np.array([np.inf, np.inf, np.inf, np.inf, 1.0, np.inf, np.inf])


@functools.lru_cache(maxsize=8192)
def _layout(family: str, seed: int, index: int) -> Scenario:
    return generate_layout(family, seed, index)


class _Setup:
    """What both forms share: the settings, the engine, the scenario drawn at a reset,
    the observation and the reward."""

    def __init__(
        self,
        family: str,
        layout_seed: int,
        layouts: tuple[int, int],
        scenarios: Sequence[Scenario | str] | None,
        perception: str,
        geometry: str,
        control_period_s: float,
        max_duration_s: float | None,
    ):
        self.scenarios: list[Scenario] | None = None
        if scenarios is not None:
            self.scenarios = [load_scenario(sc) if isinstance(sc, str) else sc for sc in scenarios]
            if not self.scenarios:
                raise ValueError("scenarios: the list is empty")
        else:
            low, high = (int(v) for v in layouts)
            if not 0 <= low < high:
                raise ValueError(f"layouts = {layouts!r}: must be (first, stop) with first < stop")
            generate_layout(family, layout_seed, low)  # a bad family fails here
        self.family, self.layout_seed, self.layouts = family, int(layout_seed), layouts
        self.world = BatchWorld(
            perception=perception,
            geometry=geometry,
            control_period_s=control_period_s,
            max_duration_s=max_duration_s,
        )
        self.limit = self.world.limit

    def draw(self, rng: np.random.Generator) -> tuple[Scenario, int]:
        """A reset's scenario and sonar seed, from the environment's generator."""
        if self.scenarios is not None:
            scenario = self.scenarios[int(rng.integers(len(self.scenarios)))]
        else:
            index = int(rng.integers(self.layouts[0], self.layouts[1]))
            scenario = _layout(self.family, self.layout_seed, index)
        return scenario, int(rng.integers(2**31))

    def observations(self) -> np.ndarray:
        """(n, 7) observations of the world's runs now (its ``observe`` stage)."""
        inputs, _ = self.world.observe()
        seen = np.isfinite(inputs[:, 1])
        lg = self.world.lg_state
        return np.stack(
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

    def distances(self) -> FloatArray:
        """The true distance of each run's centre to its target, m (n,)."""
        s = self.world.s
        distance: FloatArray = np.hypot(s.target[:, 0] - s.x, s.target[:, 1] - s.y)
        return distance

    def voltages(self, actions: npt.ArrayLike) -> FloatArray:
        return np.asarray(actions, dtype=float) * self.limit

    @staticmethod
    def rewards(before: FloatArray, after: FloatArray, codes: npt.NDArray[np.int_]) -> FloatArray:
        reward = before - after
        reward = np.where(codes == 0, reward + REACH_REWARD, reward)
        rewarded: FloatArray = np.where(codes == 1, reward + COLLISION_REWARD, reward)
        return rewarded


def _spaces() -> tuple[spaces.Box[np.float64], spaces.Box[np.float64]]:
    observation = spaces.Box(_OBS_LOW, _OBS_HIGH, dtype=np.float64)
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

    ``Box((7,), float64)``, the controller's inputs as the robot senses them (the
    scenario's disturbance added, as the paper's controller sees them) and its speeds:

    | Num | Observation | Unit | Min | Max |
    |-----|-------------|------|-----|-----|
    | 0 | ``d_t``: distance to the target | m | -inf | inf |
    | 1 | ``d_o``: clearance to the nearest sensed obstacle; the cutoff (``OBSTACLE_CUTOFF_M``) if none | m | -inf | inf |
    | 2 | ``phi_t``: bearing of the target from the heading, (-pi, pi] | rad | -inf | inf |
    | 3 | ``phi_o``: bearing of that obstacle (ideal) or its sonar's angle; 0 if none | rad | -inf | inf |
    | 4 | ``obstacle_seen``: 1 when an obstacle is sensed within the cutoff, else 0 | - | 0 | 1 |
    | 5 | ``v``: forward speed of the hull (LG state v_MH) | m/s | -inf | inf |
    | 6 | ``w``: yaw rate (LG state w_JH) | rad/s | -inf | inf |

    The bounds are infinite because the disturbance is added to entries 0-3.

    ## Rewards

    Each step: the decrease of the centre's distance to the target over the step (m),
    plus 10 on arriving and -10 on touching an obstacle.

    ## Starting State

    The scenario's start pose at rest (LG state zero), time 0.

    ## Episode End

    1. Termination: the centre within the scenario's tolerance of the target (reached).
    2. Termination: a contact with an obstacle (collided; checked at the step's end and
       swept between the ends, as the pymunk engine does).
    3. Truncation: the scenario's duration (or ``max_duration_s``) has passed (timeout).

    ``info["outcome"]`` on the last step: 0 reached, 1 collided, 2 timeout (an index
    into :data:`world.run_limits.OUTCOMES`).

    ## Arguments

    Parameters
    ----------
    family : str
        The layout family scenarios are drawn from (:data:`world.layouts.FAMILIES`).
    layout_seed : int
        The family's seed.
    layouts : tuple of int
        ``(first, stop)``: the layout indices a reset draws from (keep a range apart
        for held-out tests).
    scenarios : sequence of Scenario or str, optional
        Draw from these instead (scenario objects or names such as ``"s1"``).
    perception : {"ideal", "ultrasonic"}
        How obstacles are sensed.
    geometry : {"husky", "paper"}
        The Husky's footprint or the paper's point robot (ideal only).
    control_period_s : float
        The step, s (the paper's 20 ms by default).
    max_duration_s : float, optional
        Truncate every episode at this time at the latest, s.
    render_mode : {"rgb_array"}, optional
        :meth:`render` returns an (H, W, 3) uint8 picture of the scene.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        family: str = "standard",
        layout_seed: int = 0,
        layouts: tuple[int, int] = (0, 1000),
        scenarios: Sequence[Scenario | str] | None = None,
        perception: str = "ideal",
        geometry: str = "husky",
        control_period_s: float = 0.02,
        max_duration_s: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: must be None or 'rgb_array'")
        self._setup = _Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
        )  # fmt: skip
        self.observation_space, self.action_space = _spaces()
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": round(1.0 / control_period_s)}
        self.scenario: Scenario | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[FloatArray, dict[str, Any]]:
        """Start an episode on a newly drawn scenario (see the class docstring).

        Parameters
        ----------
        seed : int, optional
            Seeds the environment's generator (the scenario and the sonar noise).
        options : dict, optional
            ``{"scenario": Scenario}`` runs that scenario instead of drawing one.

        Returns
        -------
        tuple
            The observation (7,) and an empty info dict.
        """
        super().reset(seed=seed)
        scenario, sonar_seed = self._setup.draw(self.np_random)
        if options and options.get("scenario") is not None:
            scenario = options["scenario"]
        self.scenario = scenario
        self._setup.world.reset([scenario], [sonar_seed])
        self._distance = self._setup.distances()
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
        setup = self._setup
        code = setup.world.step(setup.voltages(action).reshape(1, 2))
        distance = setup.distances()
        reward = setup.rewards(self._distance, distance, code)
        self._distance = distance
        observation = setup.observations()[0]
        k = int(code[0])
        info = {"outcome": k} if k >= 0 else {}
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
        Sub-environments.
    family, layout_seed, layouts, scenarios, perception, geometry, control_period_s, max_duration_s
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
        scenarios: Sequence[Scenario | str] | None = None,
        perception: str = "ideal",
        geometry: str = "husky",
        control_period_s: float = 0.02,
        max_duration_s: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r}: must be at least 1")
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r}: the vector form draws nothing")
        self._setup = _Setup(
            family, layout_seed, layouts, scenarios, perception, geometry,
            control_period_s, max_duration_s,
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
        volts = setup.voltages(actions).reshape(self.num_envs, 2)
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
