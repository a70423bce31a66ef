"""Plot fuzzynav's trajectories on s1-s3 (both perception modes) or on chosen layouts.

.venv/bin/python scripts/fuzzynav_plot.py OUT.png [family:seed:index ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fuzzynav.controller.navigator.controller import fuzzynav_controller
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]


def scenario(spec):
    if spec in ("s1", "s2", "s3"):
        return load_scenario(spec)
    family, seed, index = spec.split(":")
    return generate_layout(family, int(seed), int(index))


def main():
    out = sys.argv[1]
    specs = sys.argv[2:] or ["s1", "s2", "s3"]
    fig, axes = plt.subplots(1, len(specs), figsize=(5 * len(specs), 5), squeeze=False)
    for ax, spec in zip(axes[0], specs):
        sc = scenario(spec)
        for mode, colour in (("ideal", "tab:blue"), ("ultrasonic", "tab:orange")):
            r = Simulation(sc, fuzzynav_controller(), perception=mode, seed=0).run()
            log = r.log
            ax.plot(
                log.pose[:, 0],
                log.pose[:, 1],
                color=colour,
                label=f"{mode}: {r.outcome}, {r.metrics['path_length_m']:.2f} m, "
                f"clear {r.metrics['min_clearance_m']:.2f}",
            )
            for j, rad in enumerate(log.obstacle_radii_m):
                xy = log.obstacle_xy[:, j]
                ok = np.isfinite(xy[:, 0])
                if not ok.any():
                    continue
                if np.ptp(xy[ok], axis=0).max() > 0.01:
                    ax.plot(xy[ok, 0], xy[ok, 1], ":", color="grey")
                    last = xy[ok][-1]
                    ax.add_patch(plt.Circle(last, rad, fill=False, color=colour, lw=0.8))
                ax.add_patch(plt.Circle(xy[ok][0], rad, color="k", alpha=0.4))
        ax.plot(*sc.start, "go")
        ax.plot(*sc.target, "r*", ms=12)
        ax.set_aspect("equal")
        ax.set_title(spec)
        ax.legend(fontsize=7, loc="upper left")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main()
