"""The shipped paper controller's membership functions laid out as the paper's Figs. 6-11.

Six panels in the order of the paper's captions: Fig. 6 distance from the target
(d_t), Fig. 7 angle of the target (phi_t), Fig. 8 distance from the obstacle (d_o),
Fig. 9 angle of the obstacle (phi_o), Figs. 10 and 11 the left and right wheels'
voltage. Each term is labelled with its name and family, and the 12 design numbers
are written under the panels they shape.

    .venv/bin/python scripts/paper_design_figure.py [--rules PATH] [--out PNG]
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fuzzynav.controller.paper import PAPER_RULES  # noqa: E402
from fuzzynav.controller.rulebase import read_toml  # noqa: E402

PANELS = [
    ("d_t", "Fig. 6: distance from the target", "d_t."),
    ("phi_t", "Fig. 7: angle of the target", "phi_t."),
    ("d_o", "Fig. 8: distance from the obstacle", "d_o."),
    ("phi_o", "Fig. 9: angle of the obstacle", "phi_o."),
    ("left", "Fig. 10: left wheel voltage", "v."),
    ("right", "Fig. 11: right wheel voltage", "v."),
]
D_T_SHOWN_M = 30.0  # the whole universe: VL holds 1 from its upper corner on


def tuned_numbers(path: Path) -> dict[str, float]:
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("# tuned vector:"):
            return {k: float(v) for k, v in re.findall(r"([\w.]+)=([-+0-9.eE]+)", line)}
    return {}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rules", type=Path, default=PAPER_RULES)
    parser.add_argument("--out", type=Path, default=Path("docs/img/paper_design_membership.png"))
    args = parser.parse_args()
    system = read_toml(args.rules)
    numbers = tuned_numbers(args.rules)
    variables = {v.name: v for v in list(system.inputs) + list(system.outputs)}
    fig, axes = plt.subplots(3, 2, figsize=(11, 9.5))
    for ax, (name, title, prefix) in zip(axes.ravel(), PANELS):
        var = variables[name]
        lo, hi = var.range
        shown = min(hi, D_T_SHOWN_M) if name == "d_t" else hi
        x = np.linspace(lo, shown, 2001)
        for term in var.terms:
            y = np.asarray(term(x), dtype=float)
            (line,) = ax.plot(x, y, lw=1.8, label=f"{term.name} ({term.shape})")
            k = int(np.argmax(y))
            ax.annotate(
                term.name,
                (x[k], y[k]),
                xytext=(0, 4),
                textcoords="offset points",
                ha="center",
                fontsize=8,
                color=line.get_color(),
            )
        unit = f" [{var.unit}]" if var.unit else ""
        note = f" (shown to {shown:g} of {hi:g})" if shown < hi else ""
        ax.set_title(f"{title}{note}", fontsize=10)
        shaped = [
            f"{k.split('.', 1)[1]} = {v:.3g}" for k, v in numbers.items() if k.startswith(prefix)
        ]
        numbers_note = f"   ({', '.join(shaped)})" if shaped else ""
        ax.set_xlabel(f"{name}{unit}{numbers_note}", fontsize=9)
        ax.set_xlim(lo, shown)
        ax.set_ylim(-0.02, 1.15)
        ax.grid(True, lw=0.3, alpha=0.6)
        ax.legend(fontsize=7, loc="center right")
    fig.suptitle(
        f"Paper controller ({args.rules.name}): membership functions fitted by fuzzynav, not "
        "the paper's\n(its Figs. 6-11 are not in the text); drawn from 12 numbers "
        "(controller/paper_design.py)",
        fontsize=11,
    )
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
