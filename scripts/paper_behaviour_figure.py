"""How the shipped paper controller drives, at a glance, against what the paper tells.

Top row: s1-s3's paths in the paper's geometry (``fuzzynav run sN --geometry paper``),
each obstacle where the robot passed it, a dashed circle at the pass distance the text
gives (s1: 46, 29 cm and Table 4's 26 cm; s2: 38 and 72 cm; s3: 63 and 73 cm) and a
solid one at ours; s3's disturbance window (25-35 s) drawn thick on its path. Bottom
row: the robot's speed and its distance to the target over time, the time of each pass
marked (dashed: the paper's, where it gives one).

    .venv/bin/python scripts/paper_behaviour_figure.py [--rules PATH] [--out PNG]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fuzzynav.app.experiments.paper_fit import measure  # noqa: E402
from fuzzynav.app.published import SCENARIOS, paper_results  # noqa: E402
from fuzzynav.app.runs import run_scenario  # noqa: E402
from fuzzynav.world.kernels import law_centre, obstacle_law  # noqa: E402

OURS, PAPERS = "tab:blue", "tab:red"


def obstacle_centre(obstacle, t: float) -> np.ndarray:
    """Where ``obstacle`` is at ``t`` s (its law, Eqs. 13-14)."""
    return np.array(law_centre(obstacle_law(obstacle), t))


def draw(rules: str, out: Path) -> None:
    paper = paper_results()
    fig, axes = plt.subplots(2, 3, figsize=(15, 9.2), height_ratios=(1.25, 1))
    for k, name in enumerate(SCENARIOS):
        result = run_scenario(name, rules, perception="ideal", geometry="paper")
        m, log, sc = measure(result), result.log, result.scenario
        xy, t = log.pose[:, :2], log.time_s
        ax = axes[0, k]
        ax.plot(
            *np.array([sc.start, sc.target]).T, color="0.6", lw=1, ls=":", label="start-target line"
        )
        ax.plot(*xy.T, color=OURS, lw=1.6, label="path (ours)")
        if sc.disturbance is not None:
            inside = (t >= sc.disturbance.start_s) & (t <= sc.disturbance.stop_s)
            ax.plot(*xy[inside].T, color="tab:orange", lw=4, alpha=0.6, label="disturbance 25-35 s")
        events = {e["obstacle"]: e for e in paper["events"].get(name, [])}
        for j, obstacle in enumerate(sc.obstacles):
            when, ours = m["passes"][j]
            centre = obstacle_centre(obstacle, when)
            ax.add_patch(plt.Circle(centre, 0.12, color="0.3"))
            ax.add_patch(plt.Circle(centre, ours, fill=False, color=OURS, lw=1.2))
            if j in events:
                told = events[j]["distance_m"]
                ax.add_patch(plt.Circle(centre, told, fill=False, color=PAPERS, ls="--", lw=1.2))
            robot = np.interp(when, t, xy[:, 0]), np.interp(when, t, xy[:, 1])
            ax.plot(*robot, "o", color=OURS, ms=4)
            label = f"{ours:.2f} m" + (
                f" (paper {events[j]['distance_m']:.2f})" if j in events else ""
            )
            ax.annotate(label, centre, xytext=(6, -14), textcoords="offset points", fontsize=9)
        ax.plot(*sc.target, "*", color="k", ms=12)
        ax.set_aspect("equal")
        ax.set_xlim(-0.5, 9)
        ax.set_ylim(-1.5, 9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{name}: path, passes (solid ours, dashed the paper's)", fontsize=11)
        if k == 0:
            ax.legend(loc="upper left", fontsize=8)
        step = np.hypot(*np.diff(xy, axis=0).T) / np.diff(t)
        ax = axes[1, k]
        ax.plot(t[1:], step, color=OURS, lw=1.2, label="speed (m/s)")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("speed (m/s)", color=OURS)
        ax.set_ylim(0, max(0.7, float(step.max()) * 1.1))
        twin = ax.twinx()
        to_target = np.hypot(*(xy - np.asarray(sc.target)).T)
        twin.plot(t, to_target, color="k", lw=1.2, label="d_t (m)")
        twin.axhline(2.0, color="0.5", lw=0.8, ls=":")
        twin.set_ylabel("distance to the target d_t (m)")
        for j, (when, _) in enumerate(m["passes"]):
            ax.axvline(when, color=OURS, lw=0.8)
            if "time_s" in events.get(j, {}):
                ax.axvline(events[j]["time_s"], color=PAPERS, lw=0.8, ls="--")
        if sc.disturbance is not None:
            ax.axvspan(
                sc.disturbance.start_s, sc.disturbance.stop_s, color="tab:orange", alpha=0.15
            )
        ax.set_title(
            f"{name}: arrives at {m['time_to_target_s']:.0f} s; last 2 m at "
            f"{m['approach_speed_ratio']:.2f} x the median speed",
            fontsize=11,
        )
    fig.suptitle(
        "The paper's controller (rules/paper.toml) in the paper's geometry: "
        "where and how it drives",
        fontsize=13,
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print("wrote", out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rules", default="paper")
    parser.add_argument("--out", type=Path, default=Path("docs/img/paper_behaviour.png"))
    args = parser.parse_args()
    draw(args.rules, args.out)


if __name__ == "__main__":
    main()
