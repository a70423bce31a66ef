"""Draw docs/img/doubted_inputs.png: fuzzynav on s3 (ideal perception) with and without
its check of the target readings, and the target bearing it was given, the true one and
the one it steered by while the disturbance (sin(2 t) on every input, 25-35 s) was on.

    .venv/bin/python scripts/doubt_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fuzzynav.controller.navigator.controller import fuzzynav_controller
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]

CASES = (
    ("check on (shipped)", {}, "tab:blue"),
    ("check off (target_gate_m = 0)", {"target_gate_m": 0.0}, "tab:orange"),
)


def run(params):
    """The run, and per step the target bearing the controller steered by (rad)."""
    controller = fuzzynav_controller()
    controller.params.update(params)
    controller.reset()
    sim = Simulation(load_scenario("s3"), controller, perception="ideal", seed=0)
    steered, doubted = [], []
    while not sim.done:
        sim.step()
        steered.append(controller.last["block_inputs"][0] - controller.plan_offset)
        doubted.append(controller.target_doubted)
    return sim.result(), np.array(steered), np.array(doubted)


def main(out: Path) -> None:
    scenario = load_scenario("s3")
    window = (scenario.disturbance.start_s, scenario.disturbance.stop_s)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5.2), gridspec_kw={"width_ratios": [1, 1.3]})
    shipped = None
    for label, params, colour in CASES:
        result, steered, doubted = run(params)
        log = result.log
        t = log.time_s
        inside = (t >= window[0]) & (t <= window[1])
        m = result.metrics
        ax.plot(
            log.pose[:, 0],
            log.pose[:, 1],
            color=colour,
            lw=1.0,
            label=f"{label}: path {m['path_length_m']:.2f} m, "
            f"clearance {m['min_clearance_m']:.2f} m",
        )
        ax.plot(log.pose[inside, 0], log.pose[inside, 1], color=colour, lw=3.0, alpha=0.6)
        if shipped is None:
            shipped = (result, steered, doubted)
    for j, o in enumerate(scenario.obstacles):
        if o.is_static:
            ax.add_patch(plt.Circle(o.position, o.radius_m, color="0.35"))
        else:
            for k in range(0, len(log.time_s), 250):
                ax.add_patch(
                    plt.Circle(
                        log.obstacle_xy[k, j], o.radius_m, fill=False, color="firebrick", alpha=0.5
                    )
                )
    ax.plot(*scenario.target, "g*", ms=12)
    ax.plot(*scenario.start, "ko", ms=4)
    ax.set_aspect("equal")
    ax.set_xlim(-0.5, 10.0)
    ax.set_ylim(-0.5, 10.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(
        "s3, ideal perception: paths (thick: while disturbed; red: the moving obstacle every 5 s)",
        fontsize=8,
    )

    result, steered, doubted = shipped
    log = result.log
    t = log.time_s[: len(steered)]
    read = log.inputs[: len(steered), 2]
    true = read - log.disturbance[: len(steered)]
    lo, hi = window[0] - 3.0, window[1] + 3.0
    keep = (t >= lo) & (t <= hi)
    bx.plot(t[keep], read[keep], color="0.6", lw=1.0, label="phi_t as read (with the disturbance)")
    bx.plot(t[keep], true[keep], "k--", lw=1.0, label="phi_t, true")
    bx.plot(t[keep], steered[keep], color="tab:blue", lw=1.5, label="phi_t steered by (check on)")
    ymin, ymax = bx.get_ylim()
    bx.fill_between(
        t[keep],
        ymin,
        ymax,
        where=doubted[keep],
        color="tab:blue",
        alpha=0.08,
        step="mid",
        label="reading doubted",
    )
    bx.set_ylim(ymin, ymax)
    bx.axvspan(*window, color="orange", alpha=0.06)
    share = 100.0 * doubted[(t >= window[0]) & (t <= window[1])].mean()
    bx.set_title(
        f"target bearing, rad: doubted {share:.0f} % of the disturbed 10 s, never outside it",
        fontsize=8,
    )
    bx.set_xlabel("t, s")
    bx.legend(fontsize=7, loc="lower left")
    bx.grid(alpha=0.3)
    outside = doubted[(t < window[0]) | (t > window[1])]
    assert not outside.any(), "a reading outside the disturbance was doubted"
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img" / "doubted_inputs.png")
