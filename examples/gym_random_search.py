"""A linear policy searched by the cross-entropy method on fuzzynav's gymnasium vector
environment, then compared with the paper's fuzzy controller on held-out layouts.

    python examples/gym_random_search.py [--write]

Every candidate of a generation runs on the same training layouts at once in one
:class:`fuzzynav.gym.HuskyVectorEnv` (candidates x layouts sub-environments); a
candidate's score is the mean return of its first episodes (later episodes, after the
autoreset, are masked out). The best policy and the paper controller (its batch form,
driven through the same environment) then run the same held-out layouts (layout
indices never used in training). No deep learning: the policy is ``clip(W f, -1, 1)``
on eight features of the observation. ``--write`` stores the numbers in
docs/data/gym_random_search.json, which docs/gym.md quotes.
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

ROOT = Path(__file__).resolve().parents[1]
#: The environment: standard layouts, ideal perception, a 0.1 s step, 60 s at most.
SETTINGS = {"family": "standard", "control_period_s": 0.1, "max_duration_s": 60.0}
TRAIN_LAYOUTS = (0, 1000)  # layout indices training draws from
HELD_OUT_LAYOUTS = (100_000, 101_000)  # and the held-out ones: never seen in training
N_FEATURES = 8


def features(obs: np.ndarray) -> np.ndarray:
    """(n, 8): the observation scaled to about [-1, 1], and a constant."""
    return np.column_stack(
        [
            np.minimum(obs[:, 0], 5.0) / 5.0,  # d_t, m
            obs[:, 1] / 2.5,  # d_o, m
            obs[:, 2] / np.pi,  # phi_t, rad
            obs[:, 3] / np.pi,  # phi_o, rad
            obs[:, 4],  # obstacle seen
            obs[:, 5],  # forward speed, m/s
            obs[:, 6],  # yaw rate, rad/s
            np.ones(len(obs)),
        ]
    )


def episodes(envs, seeds, act) -> tuple[np.ndarray, np.ndarray]:
    """Every sub-environment's first episode: its return and its outcome (0 reached,
    1 collided, 2 timeout). ``act(obs) -> actions``."""
    obs, _ = envs.reset(seed=[int(s) for s in seeds])
    n = envs.num_envs
    returns = np.zeros(n)
    outcome = np.full(n, -1)
    while (outcome < 0).any():
        obs, reward, terminated, truncated, info = envs.step(act(obs))
        going = outcome < 0
        returns += np.where(going, reward, 0.0)
        ended = going & (terminated | truncated)
        if ended.any():
            outcome[ended] = info["outcome"][ended]
    return returns, outcome


def linear_policy(weights: np.ndarray, candidate: np.ndarray):
    """``act`` for sub-environment i driven by ``weights[candidate[i]]`` (2 x 8 each)."""

    def act(obs):
        w = weights[candidate]  # (n, 2, 8)
        return np.clip(np.einsum("nij,nj->ni", w, features(obs)), -1.0, 1.0)

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
    """The cross-entropy method on the 16 weights; the final mean and the history."""
    rng = np.random.default_rng(seed)
    mean = np.zeros((2, N_FEATURES))
    mean[:, -1] = 0.5  # forward at half voltage
    std = np.full((2, N_FEATURES), 0.5)
    envs = gym.make_vec(
        fgym.ENV_ID,
        num_envs=population * layouts,
        vectorization_mode="vector_entry_point",
        layouts=TRAIN_LAYOUTS,
        **SETTINGS,
    )
    candidate = np.repeat(np.arange(population), layouts)
    history = []
    for g in range(generations):
        weights = mean + std * rng.standard_normal((population, 2, N_FEATURES))
        weights[0] = mean  # the mean itself is always a candidate
        # every candidate on the same layouts: the layout of a seed is fixed
        layout_seeds = rng.integers(2**31, size=layouts)
        returns, _ = episodes(
            envs, np.tile(layout_seeds, population), linear_policy(weights, candidate)
        )
        score = returns.reshape(population, layouts).mean(axis=1)
        best = np.argsort(score)[::-1][:elite]
        mean = weights[best].mean(axis=0)
        std = weights[best].std(axis=0) + 0.02
        history.append(float(score[best[0]]))
        print(f"generation {g + 1}: best mean return {score[best[0]]:.2f}")
    envs.close()
    return mean, history


def held_out(policy_of, n: int, seed: int) -> dict:
    envs = gym.make_vec(
        fgym.ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        layouts=HELD_OUT_LAYOUTS,
        **SETTINGS,
    )
    seeds = np.random.default_rng(seed).integers(2**31, size=n)
    returns, outcome = episodes(envs, seeds, policy_of(n))
    envs.close()
    return {
        "reached": int((outcome == 0).sum()),
        "collided": int((outcome == 1).sum()),
        "timeout": int((outcome == 2).sum()),
        "mean_return": float(returns.mean()),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generations", type=int, default=10)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--elite", type=int, default=6)
    ap.add_argument("--layouts", type=int, default=16, help="training layouts per candidate")
    ap.add_argument("--held-out", type=int, default=100, help="held-out layouts")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--write", action="store_true", help="write docs/data/gym_random_search.json")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    mean, history = cem(args.generations, args.population, args.elite, args.layouts, args.seed)
    rows = [
        {"policy": "linear (CEM)", **held_out(lambda n: linear_policy(mean[None], np.zeros(n, dtype=int)), args.held_out, args.seed + 1)},
        {"policy": "paper (fuzzy)", **held_out(paper_policy, args.held_out, args.seed + 1)},
    ]  # fmt: skip
    print(f"{args.held_out} held-out layouts:")
    print("| policy | reached | collided | timeout | mean return |")
    print("|---|---|---|---|---|")
    for r in rows:
        n = args.held_out
        print(
            f"| {r['policy']} | {r['reached']}/{n} | {r['collided']}/{n} | "
            f"{r['timeout']}/{n} | {r['mean_return']:.2f} |"
        )
    wall = time.perf_counter() - started
    print(f"{wall:.0f} s")
    if args.write:
        data = {
            "settings": SETTINGS,
            "args": {k: v for k, v in vars(args).items() if k != "write"},
            "held_out": args.held_out,
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
