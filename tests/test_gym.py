"""fuzzynav.gym: the single environment passes gymnasium's checker, the native vector
environment is N single ones step for step (autoresets included), seeded resets repeat,
and the batch engine's stepping form restarts runs in place as fresh runs (issue 40
item 2, issue 36 item 3)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import fuzzynav.gym as fgym  # noqa: E402
from fuzzynav.world.batch import run_batch  # noqa: E402
from fuzzynav.world.batch_world import BatchWorld  # noqa: E402
from fuzzynav.world.layouts import generate_layout  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: Short episodes, so that a few hundred steps hold several autoresets.
FAST = {"control_period_s": 0.1, "max_duration_s": 6.0}


def test_importing_fuzzynav_does_not_import_gymnasium():
    code = "import sys, fuzzynav, fuzzynav.api; print('gymnasium' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("perception", ["ideal", "ultrasonic"])
def test_check_env_passes(perception):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(fgym.ENV_ID, perception=perception, render_mode="rgb_array", **FAST)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not one warning from gymnasium's checker
        check_env(env.unwrapped)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (320, 320, 3) and frame.dtype == np.uint8  # as docs/gym.md says
    # the robot (blue) and the target (green) are drawn
    assert ((frame == (40, 90, 200)).all(axis=2)).any()
    assert ((frame == (40, 170, 60)).all(axis=2)).any()


def test_seeded_reset_repeats_and_different_seeds_differ():
    env = gym.make(fgym.ENV_ID, **FAST)
    first, _ = env.reset(seed=11)
    steps = [env.step(np.array([0.6, 0.4]))[0] for _ in range(20)]
    again, _ = env.reset(seed=11)
    assert np.array_equal(first, again)
    assert np.array_equal(steps, [env.step(np.array([0.6, 0.4]))[0] for _ in range(20)])
    others = {tuple(env.reset(seed=s)[0]) for s in range(12, 20)}
    assert len(others) > 1  # the seed picks the layout


@pytest.mark.parametrize("perception", ["ideal", "ultrasonic"])
def test_vector_entry_point_equals_sync_step_for_step(perception):
    n, steps = 6, 300
    kwargs = {"perception": perception, "family": "clutter", **FAST}
    native = gym.make_vec(
        fgym.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs
    )
    sync = gym.make_vec(fgym.ENV_ID, num_envs=n, vectorization_mode="sync", **kwargs)
    assert isinstance(native, fgym.HuskyVectorEnv)
    assert native.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    a_obs, _ = native.reset(seed=5)
    b_obs, _ = sync.reset(seed=5)
    assert np.abs(a_obs - b_obs).max() <= 1e-12
    rng = np.random.default_rng(0)
    ends = set()
    for k in range(steps):
        # towards the target, with noise: runs end every way
        turn = 0.4 * a_obs[:, 2:3] * np.array([-1.0, 1.0])
        actions = 0.6 + turn + rng.normal(0.0, 0.3, (n, 2))
        a = native.step(actions)
        b = sync.step(actions)
        assert np.abs(a[0] - b[0]).max() <= 1e-12, k
        a_obs = a[0]
        assert np.abs(a[1] - b[1]).max() <= 1e-12, k
        assert np.array_equal(a[2], b[2]) and np.array_equal(a[3], b[3]), k
        assert a[4].keys() == b[4].keys(), k
        for key in a[4]:
            assert np.array_equal(a[4][key], b[4][key]), (k, key)
        if "outcome" in a[4]:
            ends.update(a[4]["outcome"][a[4]["_outcome"]].tolist())
    # the run went through endings of more than one kind, and so through autoresets
    assert len(ends) >= 2, ends
    native.close()
    sync.close()


def test_vector_reset_mask_and_seeds():
    envs = fgym.HuskyVectorEnv(num_envs=3, **FAST)
    obs, _ = envs.reset(seed=[7, 8, 9])
    single = fgym.HuskyEnv(**FAST)
    for i, s in enumerate([7, 8, 9]):
        assert np.array_equal(single.reset(seed=s)[0], obs[i])
    envs.step(np.full((3, 2), 0.8))
    mask = np.array([False, True, False])
    again, _ = envs.reset(seed=[None, 8, None], options={"reset_mask": mask})
    assert np.array_equal(again[1], obs[1])
    assert not np.array_equal(again[0], obs[0])  # the others went on
    with pytest.raises(ValueError, match="seed has 2 entries"):
        envs.reset(seed=[1, 2])


def test_a_run_restarted_in_place_is_the_run_alone():
    """BatchWorld.restart: a run that starts at another run's step 37 is the run it
    would be alone (its own clock, sonars and noise)."""
    scs = [generate_layout("two_moving", 3, i).replace(duration_s=8.0) for i in range(3)]
    kwargs = {"perception": "ultrasonic", "control_period_s": 0.05}

    def drive(world, k):
        inputs, ranges = world.observe()
        return np.column_stack([6.0 - 3.0 * inputs[:, 2], 6.0 + 3.0 * inputs[:, 2]])

    alone = BatchWorld(**kwargs)
    alone.reset([scs[2]], seeds=[4])
    seen_alone = []
    for k in range(60):
        seen_alone.append(alone.observe()[0][0].copy())
        alone.step(drive(alone, k))
    together = BatchWorld(**kwargs)
    together.reset(scs[:2], seeds=[1, 2])
    for k in range(37):
        together.step(drive(together, k))
    together.restart([1], [scs[2]], seeds=[4])
    seen = []
    for k in range(60):
        seen.append(together.observe()[0][1].copy())
        together.step(drive(together, k))
    assert np.allclose(seen, seen_alone, rtol=0, atol=1e-12, equal_nan=True)
    assert np.array_equal(np.isnan(seen), np.isnan(seen_alone))


def test_run_batch_is_a_loop_over_the_stepping_form():
    scs = [generate_layout("clutter", 2, i) for i in range(5)]

    class Ahead:
        def decide(self, inputs, runs, ranges_m):
            return np.column_stack([8.0 - 4.0 * inputs[:, 2], 8.0 + 4.0 * inputs[:, 2]])

    result = run_batch(scs, Ahead(), control_period_s=0.05)
    world = BatchWorld(control_period_s=0.05)
    world.reset(scs)
    while world.runs.size:
        inputs, ranges = world.observe()
        world.step(Ahead().decide(inputs, world.runs, ranges))
        world.drop_ended()
    mine = world.result()
    assert np.array_equal(mine.outcome, result.outcome)
    assert np.array_equal(mine.path_length_m, result.path_length_m)
    assert np.array_equal(mine.steps, result.steps)


def test_the_paper_controller_through_the_vector_env_is_run_batch():
    """Driving the paper controller through observations (controller_inputs) gives the
    batch engine's own runs: the same endings after the same number of steps."""
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller

    n, settings = 6, {"control_period_s": 0.1, "max_duration_s": 20.0, "family": "clutter"}
    envs = fgym.HuskyVectorEnv(num_envs=n, **settings)
    obs, _ = envs.reset(seed=3)
    scenarios = list(envs._setup.world.scenarios)
    controller = batch_controller(make_controller("paper"))
    runs, ranges = np.arange(n), np.full((n, 3), np.inf)
    outcome, steps = np.full(n, -1), np.zeros(n, dtype=int)
    while (outcome < 0).any():
        volts = controller.decide(fgym.controller_inputs(obs), runs, ranges)
        obs, _, terminated, truncated, info = envs.step(volts / 12.0)
        going = outcome < 0
        steps += going
        ended = going & (terminated | truncated)
        if ended.any():
            outcome[ended] = info["outcome"][ended]
    reference = run_batch(
        scenarios,
        batch_controller(make_controller("paper")),
        control_period_s=0.1,
        max_duration_s=20.0,
    )
    assert np.array_equal(outcome, reference.outcome)
    assert np.array_equal(steps, reference.steps)
    assert len(set(outcome.tolist())) >= 2  # not all the same ending


def test_controller_inputs_round_trip_the_observation():
    env = fgym.HuskyEnv(family="clutter", **FAST)
    obs, _ = env.reset(seed=2)
    inputs = fgym.controller_inputs(obs)
    world_inputs, _ = env._setup.world.observe()
    assert np.array_equal(np.isnan(inputs), np.isnan(world_inputs))
    assert np.allclose(inputs, world_inputs, equal_nan=True, rtol=0, atol=0)


def test_bad_settings_are_refused_by_name():
    with pytest.raises(ValueError, match="render_mode = 'human'"):
        fgym.HuskyEnv(render_mode="human")
    with pytest.raises(ValueError, match="layouts = "):
        fgym.HuskyEnv(layouts=(5, 5))
    with pytest.raises(ValueError, match="num_envs = 0"):
        fgym.HuskyVectorEnv(num_envs=0)


def test_the_docs_numbers_are_the_examples():
    """docs/gym.md states what docs/examples/gym_random_search.py wrote."""
    from load_file import load_file

    module = load_file(ROOT / "examples" / "gym_random_search.py")
    data = json.loads((ROOT / "docs" / "data" / "gym_random_search.json").read_text())
    text = (ROOT / "docs" / "gym.md").read_text()
    for row in data["rows"]:
        assert module.table_row(row, data["held_out"]) in text.splitlines(), row["policy"]
    args, settings, search = data["args"], data["settings"], data["search"]
    assert settings == module.SETTINGS
    stated = [
        f"{args['population']}\ncandidates",
        f"{args['layouts']} training layouts",
        f"{args['population'] * args['layouts']}\nsub-environments",
        f"runs {args['generations']} generations",
        f"{data['held_out']} held-out layouts",
        f"a {settings['control_period_s']:g} s step",
        f"training episodes of at most {settings['train_max_duration_s']:g} s",
        f"{settings['held_out_budget_factor']:g} times its layout's time budget",
        f"took {search['cpu_s']:.0f} s of CPU time",
    ]
    flat = re.sub(r"\s+", " ", text)
    for phrase in stated:
        assert re.sub(r"\s+", " ", phrase) in flat, phrase


def test_the_docs_rows_are_todays_controllers():
    """The stored rows are what the stored linear policy and today's shipped paper
    controller (the Husky twin) do on the held-out layouts now: a rule base refitted
    since makes the file stale (rerun the example with --write)."""
    from load_file import load_file

    module = load_file(ROOT / "examples" / "gym_random_search.py")
    data = json.loads((ROOT / "docs" / "data" / "gym_random_search.json").read_text())
    n, seed = data["held_out"], data["args"]["seed"] + 1
    weights = np.asarray(data["weights"])[None]
    all_round, paper_field = (
        module.held_out_layouts(),
        module.held_out_layouts(module.PAPER_FIELD_OF_VIEW_DEG),
    )
    policies = {
        "linear (CEM)": (
            lambda k: module.linear_policy(weights, np.zeros(k, dtype=int)),
            all_round,
        ),
        "paper (fuzzy)": (module.paper_policy, all_round),
        f"paper (fuzzy), its {module.PAPER_FIELD_OF_VIEW_DEG:g}-degree field": (
            module.paper_policy,
            paper_field,
        ),
    }
    assert [row["policy"] for row in data["rows"]] == list(policies)
    for row in data["rows"]:
        policy, layouts = policies[row["policy"]]
        now = module.held_out(policy, n, seed, layouts)
        assert now["mean_return"] == pytest.approx(row["mean_return"], rel=1e-9, abs=1e-12), row[
            "policy"
        ]
        keys = ("reached", "collided", "timeout", "median_time_to_target_s")
        assert {k: now[k] for k in keys} == {k: row[k] for k in keys}, row["policy"]


def test_the_example_runs_small(capsys):
    from load_file import load_file

    module = load_file(ROOT / "examples" / "gym_random_search.py")
    assert module.main(
        ["--generations", "1", "--population", "3", "--elite", "2", "--layouts", "2",
         "--held-out", "4"]
    ) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "4 held-out layouts" in out
    assert "| linear (CEM) |" in out and "| paper (fuzzy) |" in out
    assert "| paper (fuzzy), its 60-degree field |" in out


def test_an_obstacle_not_sensed_reads_as_the_cutoff():
    from fuzzynav.world.perception import OBSTACLE_CUTOFF_M
    from fuzzynav.world.scenario import load_scenario

    bare = load_scenario("s1").replace(obstacles=())
    env = fgym.HuskyEnv(scenarios=[bare], **FAST)
    obs, _ = env.reset(seed=0)
    assert obs[4] == 0.0 and obs[1] == OBSTACLE_CUTOFF_M and obs[3] == 0.0


def test_step_follows_gymnasiums_contract():
    """No step before the first reset, none after an episode ended: ResetNeeded, not an
    AttributeError and not a robot driven on through the obstacle it hit."""
    env = fgym.HuskyEnv(scenarios=["s1"], **FAST)
    with pytest.raises(gym.error.ResetNeeded, match="before reset"):
        env.step(np.zeros(2))
    env.reset(seed=0)
    for _ in range(200):
        *_, terminated, truncated, info = env.step(np.array([1.0, 1.0]))
        if terminated or truncated:
            break
    assert terminated or truncated
    with pytest.raises(gym.error.ResetNeeded, match="episode ended"):
        env.step(np.array([1.0, 1.0]))
    env.reset(seed=0)
    env.step(np.array([1.0, 1.0]))  # a reset starts another
    vector = fgym.HuskyVectorEnv(num_envs=2, **FAST)
    with pytest.raises(gym.error.ResetNeeded):
        vector.step(np.zeros((2, 2)))


def _scenario_with(**changes):
    from fuzzynav.world.scenario import load_scenario

    return load_scenario("s1").replace(**changes)


def test_a_reset_scenario_is_checked_as_simulate_checks_it():
    import fuzzynav
    from fuzzynav.world.scenario import ObstacleSpec

    env = fgym.HuskyEnv(**FAST)
    nan_target = _scenario_with(target=(float("nan"), 1.0))
    s1 = _scenario_with()
    on_robot = s1.replace(obstacles=(ObstacleSpec(position=s1.start, radius_m=0.3),))
    for bad in (nan_target, on_robot):
        with pytest.raises(ValueError) as simulate_error:
            fuzzynav.simulate(bad)
        with pytest.raises(ValueError) as reset_error:
            env.reset(seed=0, options={"scenario": bad})
        assert str(reset_error.value) == str(simulate_error.value)
        with pytest.raises(ValueError):
            fgym.HuskyEnv(scenarios=[bad], **FAST)
    with pytest.raises(ValueError, match="is not a scenario"):
        env.reset(options={"scenario": 42})
    obs, _ = env.reset(seed=0, options={"scenario": "s1"})  # a name, as simulate takes
    assert env.scenario == s1 and obs[0] == pytest.approx(math.dist(s1.start, s1.target))


def test_settings_out_of_reason_are_refused_by_name():
    for bad in (float("nan"), 0, -1, float("inf"), "6"):
        with pytest.raises(ValueError, match="max_duration_s = "):
            fgym.HuskyEnv(max_duration_s=bad)
    for bad in ((1.5, 3.7), (0, 2.0), (True, 5), "ab", (1, 2, 3), (-1, 4)):
        with pytest.raises(ValueError, match="layouts = "):
            fgym.HuskyEnv(layouts=bad)
    with pytest.raises(ValueError, match="layout_seed = "):
        fgym.HuskyEnv(layout_seed=1.5)
    for bad in (10**9, 2.0, True):
        with pytest.raises(ValueError, match="num_envs = "):
            fgym.HuskyVectorEnv(num_envs=bad)
    with pytest.raises(ValueError, match="reach_reward = "):
        fgym.HuskyEnv(reach_reward=float("nan"))
    text = (ROOT / "docs" / "gym.md").read_text()
    assert f"`num_envs` is 1 to {fgym.MAX_NUM_ENVS:,}" in text  # as the doc says


def test_one_scenario_name_is_one_scenario_not_its_characters():
    env = fgym.HuskyEnv(scenarios="s1", **FAST)
    assert env._setup.scenarios == [_scenario_with()]
    assert env.reset(seed=3)[0][0] > 0 and env.scenario == _scenario_with()


def test_actions_of_another_shape_or_kind_are_refused():
    env = fgym.HuskyEnv(**FAST)
    env.reset(seed=0)
    for bad, says in (
        (np.zeros((2, 1)), "shape"),
        (np.zeros(3), "shape"),
        (np.array(["6", "6"]), "real numbers"),
        (np.array([np.nan, 0.0]), "finite"),
    ):
        with pytest.raises(ValueError, match=says):
            env.step(bad)
    env.step([0.5, 0.5])  # a list of two numbers is an action
    vector = fgym.HuskyVectorEnv(num_envs=2, **FAST)
    vector.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        vector.step(np.zeros(4))
    with pytest.raises(ValueError, match="shape"):
        vector.step(np.zeros((2, 2, 1)))


def test_the_reward_is_configurable_and_observations_stay_in_bounds():
    plain = fgym.HuskyEnv(scenarios=["s1"], **FAST)
    scaled = fgym.HuskyEnv(
        scenarios=["s1"], progress_reward_per_m=2.0, reach_reward=0.0, collision_reward=-1.0,
        **FAST,
    )  # fmt: skip
    plain.reset(seed=0)
    scaled.reset(seed=0)
    for _ in range(20):
        obs, reward, *_ = plain.step(np.array([0.8, 0.7]))
        assert plain.observation_space.contains(obs)
        _, scaled_reward, *_ = scaled.step(np.array([0.8, 0.7]))
        assert scaled_reward == pytest.approx(2.0 * reward, rel=1e-12)
    space = plain.observation_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()


def test_float32_observations_pass_the_checker_and_round_the_float64_ones():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(fgym.ENV_ID, observation_dtype="float32", **FAST).unwrapped
    assert env.observation_space.dtype == np.float32
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)
    exact = fgym.HuskyEnv(**FAST)
    obs32, _ = env.reset(seed=4)
    obs64, _ = exact.reset(seed=4)
    assert obs32.dtype == np.float32 and obs64.dtype == np.float64
    assert np.array_equal(obs32, obs64.astype(np.float32))
    vector = fgym.HuskyVectorEnv(num_envs=3, observation_dtype=np.float32, **FAST)
    assert vector.reset(seed=1)[0].dtype == np.float32
    assert vector.observation_space.contains(vector.step(np.zeros((3, 2)))[0])
    with pytest.raises(ValueError, match="observation_dtype = "):
        fgym.HuskyEnv(observation_dtype="float16")


def test_reset_settings_of_the_wrong_kind_are_refused_by_name():
    """A reset's seed and options are checked by name: a negative or NaN seed was
    gymnasium's own error (not a ValueError), a misspelt option key was ignored (the
    scenario drawn instead of the one asked for), options that were no dict raised
    AttributeError, and a reset mask of strings or of another length was taken or
    reshaped."""
    env = fgym.HuskyEnv()
    for seed, name in ((-1, "seed = -1"), (math.nan, "seed = nan"), ("3", "seed = '3'")):
        with pytest.raises(ValueError, match=re.escape(name)):
            env.reset(seed=seed)
    with pytest.raises(ValueError, match="unknown key.*scenaro"):
        env.reset(seed=0, options={"scenaro": "s1"})
    with pytest.raises(ValueError, match="options = \\['scenario'\\]"):
        env.reset(seed=0, options=["scenario"])
    env.reset(seed=np.int64(3), options={"scenario": "s1"})  # a numpy seed is a seed
    assert env.scenario is not None and env.scenario.name.startswith("Scenario 1")
    envs = fgym.HuskyVectorEnv(num_envs=2)
    for seed, name in (([0, -5], "seed[1] = -5"), ([0, math.nan], "seed[1] = nan"), ("ab", "'ab'")):
        with pytest.raises(ValueError, match=re.escape(name)):
            envs.reset(seed=seed)
    envs.reset(seed=0)
    for mask in (["no", "no"], [0.5, 2.0], [True, False, True]):
        with pytest.raises(ValueError, match="reset_mask"):
            envs.reset(options={"reset_mask": mask})
    with pytest.raises(ValueError, match="unknown key.*scenario"):
        envs.reset(options={"scenario": "s1"})  # the vector form draws its own


def test_scenarios_and_layouts_of_the_wrong_kind_are_refused_by_name():
    """``scenarios=5`` raised TypeError ('int' object is not iterable), a dict ran its
    keys as scenario names, a layout range past int64 failed at the first reset, and a
    control period given as text raised numpy's TypeError without its name."""
    for bad in (5, {"s1": 1}, b"s1"):
        with pytest.raises(ValueError, match="scenarios = "):
            fgym.HuskyEnv(scenarios=bad)
    with pytest.raises(ValueError, match="layouts = .*stop must be at most"):
        fgym.HuskyEnv(layouts=(0, 10**30))
    with pytest.raises(ValueError, match="control_period_s = '0.02'"):
        fgym.HuskyEnv(control_period_s="0.02")
