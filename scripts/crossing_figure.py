"""Draw docs/img/crossing.png: fuzzynav on the crossing scenario, yielding to the
moving obstacle (ideal perception), without the yield rule, and with the sonars alone.

    .venv/bin/python scripts/crossing_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fuzzynav.controller.navigator.controller import fuzzynav_controller
from fuzzynav.controller.navigator.robot import _HX, _HY
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]

CASES = (
    ("ideal perception: yield, then go", "ideal", {}),
    ("ideal, yield rule off (dodge_horizon_s = 0)", "ideal", {"dodge_horizon_s": 0.0}),
    ("ultrasonic: the obstacle is seen too late", "ultrasonic", {}),
)


def footprint(pose):
    x, y, th = pose
    corners = np.array([[_HX, _HY], [_HX, -_HY], [-_HX, -_HY], [-_HX, _HY], [_HX, _HY]])
    rot = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    return corners @ rot.T + (x, y)


def draw(ax, title, result, scenario):
    log = result.log
    moving = [j for j, o in enumerate(scenario.obstacles) if not o.is_static][0]
    radius = scenario.obstacles[moving].radius_m
    ax.plot(log.pose[:, 0], log.pose[:, 1], "b-", lw=1.2)
    every = max(1, int(round(2.0 / (log.time_s[1] - log.time_s[0]))))  # every 2 s
    for k in list(range(0, len(log.time_s), every)) + [len(log.time_s) - 1]:
        t = log.time_s[k]
        shade = 0.25 + 0.75 * k / max(1, len(log.time_s) - 1)
        ax.plot(*footprint(log.pose[k]).T, color=(0.2, 0.5, 0.8, shade), lw=0.6)
        ox, oy = log.obstacle_xy[k, moving]
        ax.add_patch(plt.Circle((ox, oy), radius, fill=False, color=(0.85, 0.2, 0.2, shade)))
        if k % (2 * every) == 0 or k == len(log.time_s) - 1:
            ax.annotate(f"{t:.0f}", (ox + radius, oy), fontsize=6, color="firebrick")
            ax.annotate(
                f"{t:.0f}", log.pose[k, :2] + (0, 0.45), fontsize=6, color="navy", ha="center"
            )
    ax.plot(*scenario.target, "g*", ms=12)
    ax.plot(*scenario.start, "ko", ms=4)
    m = result.metrics
    ax.set_title(
        f"{title}\n{result.outcome}, path {m['path_length_m']:.2f} m, "
        f"clearance {max(m['min_clearance_m'], 0.0):.2f} m",
        fontsize=8,
    )
    ax.set_xlim(-0.8, 10.8)
    # Room for the whole path: without the yield rule the robot may flee up the lane.
    ax.set_ylim(-4.0, max(3.0, float(np.nanmax(log.pose[:, 1])) + 0.8))
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)


def main(out: Path) -> None:
    scenario = load_scenario("crossing")
    fig, axes = plt.subplots(3, 1, figsize=(7, 9.5))
    for ax, (title, perception, params) in zip(axes, CASES):
        controller = fuzzynav_controller()
        controller.params.update(params)
        controller.reset()
        result = Simulation(scenario, controller, perception=perception, seed=0).run()
        draw(ax, title, result, scenario)
    fig.suptitle("fuzzynav on `crossing`: times in s (robot blue, obstacle red)", fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img" / "crossing.png")
