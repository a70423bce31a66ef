"""A teaching walk-through: run s1 with the paper's controller, plot what the controller
saw and what it commanded, then swap one membership function and run again.

It shows the Python interface's core loop: :func:`fuzzynav.simulate` gives a run whose
``trace`` holds the four fuzzy inputs and the two wheel voltages, and
:func:`fuzzynav.make_controller` gives a controller whose fuzzy system (``.fis``) can be
changed term by term. Here the target bearing's "Z" (the robot faces the target) is
made twice as wide, so the robot accepts twice the heading error before it steers: the
figure puts both runs side by side, and the lesson is in how different they are.

Run it: ``python examples/teaching_walkthrough.py --out walkthrough/``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fuzzynav  # noqa: E402


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", type=Path, default=Path("walkthrough"), help="folder for the figure"
    )
    args = parser.parse_args(argv)

    # 1. The paper's controller on scenario s1, as `fuzzynav run s1` runs it.
    before = fuzzynav.simulate("s1", controller="paper")
    print("as shipped:     ", before)

    # 2. Swap one membership function: phi_t's "Z", twice as wide about zero.
    controller = fuzzynav.make_controller("paper")
    phi_t = next(v for v in controller.fis.inputs if v.name == "phi_t")
    zero = phi_t.terms[phi_t.term_index("Z")]
    if zero.shape == "gaussmf":  # [sigma, centre]: twice the spread
        wider = [2.0 * zero.params[0], zero.params[1]]
    else:  # trimf and the like: every corner twice as far from zero
        wider = [2.0 * p for p in zero.params]
    print(f"phi_t 'Z' was {zero.shape} {[round(p, 3) for p in zero.params]}")
    print(f"now            {zero.shape} {[round(p, 3) for p in wider]}")
    controller.fis = controller.fis.with_term_params("phi_t", "Z", wider)
    after = fuzzynav.simulate("s1", controller=controller)
    print("Z twice as wide:", after)
    for run in (before, after):
        print(f"  closest approach {run.metrics['min_clearance_m']:.3f} m")

    # 3. Plot both runs: the path, the inputs the controller saw, the voltages it chose.
    args.out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), layout="constrained")
    for run, label, style in ((before, "as shipped", "-"), (after, "Z twice as wide", "--")):
        tr = run.trace
        axes[0, 0].plot(tr["x_m"], tr["y_m"], style, label=label)
        axes[0, 1].plot(tr["time_s"], tr["d_o_m"], style, label=f"d_o, {label}")
        axes[1, 0].plot(tr["time_s"], tr["phi_t_rad"], style, label=f"phi_t, {label}")
        axes[1, 1].plot(tr["time_s"], tr["v_left_v"], style, label=f"left, {label}")
        axes[1, 1].plot(tr["time_s"], tr["v_right_v"], style, label=f"right, {label}")
    for ob in before.result.scenario.obstacles:
        axes[0, 0].add_patch(plt.Circle(ob.position, ob.radius_m, color="tab:red", alpha=0.4))
    axes[0, 0].plot(*before.result.scenario.target, "k*", markersize=12, label="target")
    axes[0, 0].set(xlabel="x (m)", ylabel="y (m)", title="s1: paths", aspect="equal")
    axes[0, 1].set(xlabel="time (s)", ylabel="d_o (m)", title="nearest obstacle (empty: none)")
    axes[1, 0].set(xlabel="time (s)", ylabel="phi_t (rad)", title="bearing to the target")
    axes[1, 1].set(xlabel="time (s)", ylabel="voltage (V)", title="wheel voltages")
    for ax in axes.flat:
        ax.legend(fontsize=7)
    path = args.out / "walkthrough.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"figure: {path}")
    return {"before": before, "after": after, "figure": path}


if __name__ == "__main__":
    main()
