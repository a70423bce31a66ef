"""Draw docs/img/fuzzynav_design.png: the block diagram and the membership functions.

.venv/bin/python scripts/fuzzynav_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

from fuzzynav.controller.rulebase import read_toml

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import FancyBboxPatch

from fuzzynav.controller.navigator.params import AVOID_PATH, GOAL_PATH, load_params
from fuzzynav.controller.navigator.planner import blocked_cones, free_bearing
from fuzzynav.controller.navigator.robot import _HX, _HY

ROOT = Path(__file__).resolve().parents[1]


def box(ax, x, y, w, h, text, colour):
    ax.add_patch(FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.02", fc=colour, ec="k"))
    ax.text(x + w / 2, y + h / 2, text, ha="center", va="center", fontsize=8)


def arrow(ax, x0, y0, x1, y1):
    ax.annotate("", (x1, y1), (x0, y0), arrowprops=dict(arrowstyle="->", lw=1))


def diagram(ax, p):
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 4)
    ax.axis("off")
    box(
        ax,
        0.1,
        2.6,
        1.8,
        1.0,
        "ultrasonic ranges\nleft / front / right\n(+ d_o, phi_o if ideal)",
        "#eee",
    )
    box(ax, 0.1, 0.4, 1.8, 0.9, "target radar\nd_t, phi_t", "#eee")
    box(
        ax,
        2.4,
        2.6,
        1.9,
        1.0,
        f"echo memory\n(dead reckoning,\n{p['memory_s']:.1f} s) -> L, F, R",
        "#ffe9b3",
    )
    box(ax, 2.4, 1.45, 1.9, 0.85, "side chooser\n(latched) +\nstall -> follow", "#ffe9b3")
    box(
        ax,
        2.4,
        0.3,
        1.9,
        0.85,
        f"bearing planner\nphi = free bearing past\nechoes (+{p['plan_margin_m']:.2f} m)",
        "#ffe9b3",
    )
    box(ax, 4.9, 2.6, 1.9, 1.0, "AVOID block\n13 Mamdani rules\n(L, F, R, side)", "#cfe3ff")
    box(ax, 4.9, 0.4, 1.9, 0.9, "GOAL block\n8 Mamdani rules\n(phi, d_t)", "#cfe3ff")
    box(ax, 7.3, 1.45, 1.3, 1.0, "blend\nalpha*avoid +\n(1-alpha)*goal", "#d8f5d0")
    box(ax, 8.9, 1.3, 1.0, 1.3, "mix\nL = s - t\nR = s + t\n(deadlock:\nspin)", "#d8f5d0")
    arrow(ax, 1.9, 3.1, 2.4, 3.1)
    arrow(ax, 4.3, 3.1, 4.9, 3.1)
    arrow(ax, 1.9, 0.75, 2.4, 0.75)
    arrow(ax, 4.3, 0.75, 4.9, 0.85)
    arrow(ax, 3.35, 2.6, 3.35, 2.3)
    arrow(ax, 2.3, 2.7, 2.3, 1.15)
    arrow(ax, 4.3, 1.9, 4.9, 2.8)
    arrow(ax, 4.3, 1.2, 4.3, 1.45)
    arrow(ax, 6.8, 3.1, 7.3, 2.2)
    arrow(ax, 6.8, 0.85, 7.3, 1.7)
    arrow(ax, 8.6, 1.95, 8.9, 1.95)
    box(
        ax,
        7.15,
        2.85,
        1.75,
        1.0,
        f"moving obstacle (ideal):\ntrack d_o, phi_o; closest\n"
        f"approach < {p['dodge_safe_m']:.1f} m in {p['dodge_horizon_s']:.0f} s:\nstop or full speed",
        "#f6d5f7",
    )
    arrow(ax, 8.75, 2.85, 8.75, 2.0)
    ax.text(6.85, 2.55, "alpha = near(L, F, R)", fontsize=7, style="italic")
    ax.set_title(
        "fuzzynav: goal seeking (on a planned bearing) and avoidance, arbitrated by the "
        "strength of 'near'",
        fontsize=10,
    )


def planner_sketch(ax, p):
    """The bearing planner on a hand-made case: remembered echo points on an obstacle's
    near side, each inflated to the flank + margin; the target's bearing is blocked, the
    goal block is fed the nearest free bearing on the latched side."""
    radius = _HY + p["plan_margin_m"]
    centre, r_obs = np.array([2.4, 0.25]), 0.3
    angles = np.radians(np.linspace(120, 240, 7))
    pts = [tuple(centre + r_obs * np.array([np.cos(a), np.sin(a)])) for a in angles]
    phi_t = np.arctan2(0.6, 5.0)
    cones = blocked_cones(pts, radius, p["plan_horizon_m"], 5.0, p["plan_nearest_m"])
    psi, _ = free_bearing(cones, phi_t, 0.0)
    ax.add_patch(plt.Circle(centre, r_obs, color="#d62728", alpha=0.6))
    for x, y in pts:
        ax.add_patch(plt.Circle((x, y), radius, fill=False, ec="#999", lw=0.5))
    ax.plot(*zip(*pts), "k.", ms=4, label="remembered echoes")
    ax.add_patch(plt.Rectangle((-_HX, -_HY), 2 * _HX, 2 * _HY, fill=False, ec="C0"))
    ax.plot(5.0, 0.6, "g*", ms=12, label="target")
    ax.plot(
        [0, 5.2 * np.cos(phi_t)], [0, 5.2 * np.sin(phi_t)], "r--", lw=1, label="phi_t (blocked)"
    )
    ax.plot(
        [0, 5.2 * np.cos(psi)],
        [0, 5.2 * np.sin(psi)],
        "g-",
        lw=1.5,
        label=f"phi fed to GOAL ({np.degrees(psi - phi_t):+.0f} deg)",
    )
    ax.set_aspect("equal")
    ax.set_xlim(-0.7, 5.5)
    ax.set_ylim(-1.5, 2.6)
    ax.set_title(
        f"bearing planner: echoes inflated by flank + {p['plan_margin_m']:.2f} m", fontsize=9
    )
    ax.legend(fontsize=6, loc="upper left")
    ax.tick_params(labelsize=7)


def mfs(ax, variable, title):
    lo, hi = variable.range
    x = np.linspace(lo, hi, 400)
    for t in variable.terms:
        ax.plot(x, t(x), label=t.name)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6, loc="center right")
    ax.set_ylim(-0.05, 1.05)
    ax.tick_params(labelsize=7)


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img" / "fuzzynav_design.png"
    goal, avoid = read_toml(GOAL_PATH), read_toml(AVOID_PATH)
    p = load_params()
    fig = plt.figure(figsize=(15, 7.5))
    gs = fig.add_gridspec(3, 4, height_ratios=[1.4, 1, 1])
    diagram(fig.add_subplot(gs[0, :]), p)
    mfs(fig.add_subplot(gs[1, 0]), goal.inputs[0], "goal: phi (rad, > 0 on the left)")
    mfs(fig.add_subplot(gs[1, 1]), goal.inputs[1], "goal: d_t (m)")
    mfs(fig.add_subplot(gs[1, 2]), avoid.inputs[1], "avoid: front (left/right alike) (m)")
    planner_sketch(fig.add_subplot(gs[1:, 3]), p)
    mfs(fig.add_subplot(gs[2, 0]), goal.outputs[0], "both: speed (V, common mode)")
    mfs(fig.add_subplot(gs[2, 1]), goal.outputs[1], "both: turn (V, (right-left)/2)")
    ax = fig.add_subplot(gs[2, 2])
    d = np.linspace(0, 3.5, 300)
    lin = lambda x, a, b: np.clip((b - x) / (b - a), 0, 1)  # noqa: E731
    ax.plot(d, lin(d, p["alpha_front_lo_m"], p["alpha_front_hi_m"]), label="alpha from front")
    ax.plot(
        d,
        p["alpha_side_max"] * lin(d, p["alpha_side_lo_m"], p["alpha_side_hi_m"]),
        label="alpha from left/right",
    )
    ax.set_title("arbitration: weight of the avoid block (m)", fontsize=9)
    ax.legend(fontsize=6)
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    print("wrote", out)


if __name__ == "__main__":
    main()
