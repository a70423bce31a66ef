"""A linear policy searched by the cross-entropy method on fuzzynav's gymnasium vector
environment, then compared with the paper's fuzzy controller on held-out layouts.

    python examples/gym_random_search.py [--write]

Every candidate of a generation runs on the same training layouts at once in one
:class:`fuzzynav.gym.HuskyVectorEnv` (candidates x layouts sub-environments); a
candidate's score is the mean return of its first episodes (later episodes, after the
autoreset, are masked out) under the environment's default reward. The best policy and
the paper controller (its batch form, driven through the same environment) then run the
same held-out layouts (layout indices never used in training), each given four times its
layout's time budget, so that the paper controller's pace is no reason for it not to
arrive; the paper controller runs them once more sensing only the 60-degree field ahead
its rules were fitted with. No deep learning: the policy is a matrix on nine features of
the observation (:func:`features`), giving a forward and a turning command
(:func:`linear_policy`).
``--write`` stores the numbers in docs/data/gym_random_search.json, which docs/gym.md
quotes.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import fuzzynav
import fuzzynav.gym as fgym
from fuzzynav.controller.batch import batch_controller
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M

ROOT = Path(__file__).resolve().parents[1]
#: The environment: standard layouts, ideal perception, a 0.1 s step. Training episodes
#: end at ``train_max_duration_s`` (a policy at half the Husky's top speed covers the
#: farthest target in about as long; the search is paid per step); held-out episodes
#: at ``held_out_budget_factor`` times the layout's own time budget (30 s + distance /
#: 0.15 m/s), as scripts/paper_generalise.py gives the paper controller.
SETTINGS = {
    "family": "standard",
    "control_period_s": 0.1,
    "train_max_duration_s": 40.0,
    "held_out_budget_factor": 4.0,
}
TRAIN_LAYOUTS = (0, 1000)  # layout indices training draws from
HELD_OUT_LAYOUTS = (100_000, 101_000)  # and the held-out ones: never seen in training
LAYOUT_SEED = 0  # the family's seed (the environment's default)
#: The field of view the paper controller's rules were fitted with (s1-s3 carry it).
PAPER_FIELD_OF_VIEW_DEG = 60.0
N_FEATURES = 9


def features(obs: np.ndarray) -> np.ndarray:
    """(n, 9): the observation's target and obstacle terms scaled to about [-1, 1], the
    speeds, and a constant. An obstacle counts only when it is ahead (within 90 degrees
    of the heading), by its closeness (1 touching, 0 at the perception's cutoff) and by
    its side (+1 left, -1 right)."""
    closeness = obs[:, 4] * np.clip(1.0 - obs[:, 1] / OBSTACLE_CUTOFF_M, 0.0, 1.0)
    ahead = closeness * (np.abs(obs[:, 3]) < np.pi / 2)
    return np.column_stack(
        [
            np.minimum(obs[:, 0], 5.0) / 5.0,  # d_t, m
            np.minimum(obs[:, 0], 1.0),  # d_t near the target, m
            obs[:, 2] / np.pi,  # phi_t, rad
            np.cos(obs[:, 2]),  # the target ahead (1) or behind (-1)
            ahead,
            ahead * np.where(obs[:, 3] >= 0.0, 1.0, -1.0),
            obs[:, 5],  # forward speed, m/s
            obs[:, 6],  # yaw rate, rad/s
            np.ones(len(obs)),
        ]
    )


def episodes(envs, seeds, act) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every sub-environment's first episode: its return, its outcome (0 reached,
    1 collided, 2 timeout) and its number of steps. ``act(obs) -> actions``."""
    obs, _ = envs.reset(seed=[int(s) for s in seeds])
    n = envs.num_envs
    returns = np.zeros(n)
    outcome = np.full(n, -1)
    steps = np.zeros(n, dtype=int)
    while (outcome < 0).any():
        obs, reward, terminated, truncated, info = envs.step(act(obs))
        going = outcome < 0
        returns += np.where(going, reward, 0.0)
        steps += going
        ended = going & (terminated | truncated)
        if ended.any():
            outcome[ended] = info["outcome"][ended]
    return returns, outcome, steps


def linear_policy(weights: np.ndarray, candidate: np.ndarray):
    """``act`` for sub-environment i driven by ``weights[candidate[i]]`` (2 x 9 each):
    ``(forward, turn) = W f``, the wheels ``clip(forward -+ turn, -1, 1)`` (left, right;
    a positive turn is to the left, as ``phi_t``)."""

    def act(obs):
        w = weights[candidate]  # (n, 2, 9)
        forward, turn = np.einsum("nij,nj->in", w, features(obs))
        return np.clip(np.column_stack([forward - turn, forward + turn]), -1.0, 1.0)

    return act


def paper_policy(n: int, limit_v: float = 12.0):
    """``act`` driving the paper's fuzzy controller (its batch form) from observations."""
    controller = batch_controller(fuzzynav.make_controller("paper"))
    runs = np.arange(n)
    ranges = np.full((n, 3), np.inf)  # ideal perception: no sonar readings

    def act(obs):
        volts = controller.decide(fgym.controller_inputs(obs), runs, ranges)
        return np.clip(volts / limit_v, -1.0, 1.0)

    return act


def cem(generations: int, population: int, elite: int, layouts: int, seed: int):
    """The cross-entropy method on the 18 weights; the final mean and the history (the
    best score and its share of arrivals, each generation)."""
    rng = np.random.default_rng(seed)
    mean = np.zeros((2, N_FEATURES))
    mean[0, -1] = 0.5  # forward at half voltage, no turn
    std = np.full((2, N_FEATURES), 0.5)
    envs = gym.make_vec(
        fgym.ENV_ID,
        num_envs=population * layouts,
        vectorization_mode="vector_entry_point",
        family=SETTINGS["family"],
        layout_seed=LAYOUT_SEED,
        layouts=TRAIN_LAYOUTS,
        control_period_s=SETTINGS["control_period_s"],
        max_duration_s=SETTINGS["train_max_duration_s"],
    )
    candidate = np.repeat(np.arange(population), layouts)
    history = []
    for g in range(generations):
        weights = mean + std * rng.standard_normal((population, 2, N_FEATURES))
        weights[0] = mean  # the mean itself is always a candidate
        # every candidate on the same layouts: the layout of a seed is fixed
        layout_seeds = rng.integers(2**31, size=layouts)
        returns, outcome, _ = episodes(
            envs, np.tile(layout_seeds, population), linear_policy(weights, candidate)
        )
        score = returns.reshape(population, layouts).mean(axis=1)
        reached = (outcome == 0).reshape(population, layouts).mean(axis=1)
        best = np.argsort(score)[::-1][:elite]
        mean = weights[best].mean(axis=0)
        std = weights[best].std(axis=0) + 0.02
        history.append(
            {"best_mean_return": float(score[best[0]]), "reached": float(reached[best[0]])}
        )
        print(
            f"generation {g + 1}: best mean return {score[best[0]]:.2f}, "
            f"reached {reached[best[0]]:.0%} of the training layouts"
        )
    envs.close()
    return mean, history


def held_out_layouts(field_of_view_deg: float | None = None) -> list:
    """The held-out layouts, each with ``held_out_budget_factor`` times its time budget
    (the environment truncates at a layout's budget; ``scenarios=`` sets it), sensing
    all around as generated or within ``field_of_view_deg`` ahead."""
    factor = SETTINGS["held_out_budget_factor"]
    field = {} if field_of_view_deg is None else {"field_of_view_deg": field_of_view_deg}
    return [
        (s := generate_layout(SETTINGS["family"], LAYOUT_SEED, i)).replace(
            duration_s=factor * s.duration_s, **field
        )
        for i in range(*HELD_OUT_LAYOUTS)
    ]


def held_out(policy_of, n: int, seed: int, layouts: list | None = None) -> dict:
    """``policy_of(n)`` on ``n`` held-out episodes: the outcomes, the mean return and the
    median time to arrive (s; None if none arrives)."""
    envs = gym.make_vec(
        fgym.ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        scenarios=held_out_layouts() if layouts is None else layouts,
        control_period_s=SETTINGS["control_period_s"],
    )
    seeds = np.random.default_rng(seed).integers(2**31, size=n)
    returns, outcome, steps = episodes(envs, seeds, policy_of(n))
    envs.close()
    arrived = steps[outcome == 0] * SETTINGS["control_period_s"]
    return {
        "reached": int((outcome == 0).sum()),
        "collided": int((outcome == 1).sum()),
        "timeout": int((outcome == 2).sum()),
        "mean_return": float(returns.mean()),
        "median_time_to_target_s": float(np.median(arrived)) if len(arrived) else None,
    }


def table_row(row: dict, n: int) -> str:
    """A row of docs/gym.md's table."""
    median_s = row["median_time_to_target_s"]
    return (
        f"| {row['policy']} | {row['reached']}/{n} | {row['collided']}/{n} | "
        f"{row['timeout']}/{n} | {row['mean_return']:.2f} | "
        + ("none arrives" if median_s is None else f"{median_s:.1f} s")
        + " |"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generations", type=int, default=40)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--elite", type=int, default=6)
    ap.add_argument("--layouts", type=int, default=24, help="training layouts per candidate")
    ap.add_argument("--held-out", type=int, default=100, help="held-out layouts")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--write", action="store_true", help="write docs/data/gym_random_search.json")
    args = ap.parse_args(argv)
    started, started_cpu = time.perf_counter(), time.process_time()
    mean, history = cem(args.generations, args.population, args.elite, args.layouts, args.seed)
    search = {
        "wall_s": time.perf_counter() - started,
        "cpu_s": time.process_time() - started_cpu,
    }
    print(f"search: {search['wall_s']:.0f} s wall, {search['cpu_s']:.0f} s CPU")
    layouts = held_out_layouts()
    rows = [
        {"policy": "linear (CEM)", **held_out(lambda n: linear_policy(mean[None], np.zeros(n, dtype=int)), args.held_out, args.seed + 1, layouts)},
        {"policy": "paper (fuzzy)", **held_out(paper_policy, args.held_out, args.seed + 1, layouts)},
        {"policy": f"paper (fuzzy), its {PAPER_FIELD_OF_VIEW_DEG:g}-degree field", **held_out(paper_policy, args.held_out, args.seed + 1, held_out_layouts(PAPER_FIELD_OF_VIEW_DEG))},
    ]  # fmt: skip
    print(f"{args.held_out} held-out layouts:")
    print("| policy | reached | collided | timeout | mean return | median time to target |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(table_row(r, args.held_out))
    if args.write:
        data = {
            "settings": SETTINGS,
            "args": {k: v for k, v in vars(args).items() if k != "write"},
            "held_out": args.held_out,
            "search": search,
            "history": history,
            "weights": mean.tolist(),
            "rows": rows,
        }
        path = ROOT / "docs" / "data" / "gym_random_search.json"
        path.write_text(json.dumps(data, indent=1) + "\n")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
