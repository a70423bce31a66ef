"""The membership functions of a fuzzy system (the paper's Figs. 6-11): one figure per
variable, and all of them on one page (the README's picture of a rule base).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzynav.app.figures.style import FORMATS, TERMS, _new_figure, _save, check_writable_dir
from fuzzynav.safe_files import atomic_output

#: Written on a membership figure drawn under the paper's number (Figs. 6-11): the
#: paper's figures are not in its text, and these curves were fitted by fuzzynav.
FITTED_NOTE = "(fitted by fuzzynav: not the paper's curves, which its text does not give)"


def membership_figure_names(fis) -> list[str]:
    return [f"membership_{v.name}" for v in tuple(fis.inputs) + tuple(fis.outputs)]


def write_membership_figures(
    fis,
    out_dir,
    *,
    prefix: str = "",
    formats=FORMATS,
    points: int = 1001,
    stem=None,
    title_suffix: str = "",
    numbers: dict | None = None,
) -> list[Path]:
    """One figure per input and output variable of a ``FuzzySystem``: every term's
    membership over the variable's range, named ``membership_<variable>`` (or
    ``stem(variable)`` when given), ``title_suffix`` added to each title."""
    out_dir = check_writable_dir(out_dir, option="out_dir")
    written = []
    variables = [("input", v) for v in fis.inputs] + [("output", v) for v in fis.outputs]
    for kind, var in variables:
        lo, hi = var.range
        x = np.linspace(lo, hi, points)
        lines = bool(title_suffix) + bool((numbers or {}).get(var.name) is not None)
        fig, ax = _new_figure(7.6, 3.0 + 0.2 * lines)
        a = ax[0, 0]
        for k, term in enumerate(var.terms):
            y = np.asarray(term(x), dtype=float)
            # app.palette's term colours: S, M, L... as the recording's fuzzy-logic tab
            (line,) = a.plot(
                x, y, lw=1.6, color=TERMS[k % len(TERMS)], label=f"{term.name} ({term.shape})"
            )
            peak = int(np.argmax(y))
            # a peak at an end of the range (VL at 14 V) is labelled inward, not cut off
            where = (x[peak] - lo) / (hi - lo) if hi > lo else 0.5
            ha = "left" if where < 0.08 else "right" if where > 0.92 else "center"
            a.annotate(
                term.name,
                (x[peak], y[peak]),
                xytext=({"left": 3, "right": -3, "center": 0}[ha], 4),
                textcoords="offset points",
                ha=ha,
                fontsize=8,
                color=line.get_color(),
            )
        unit = f" ({var.unit})" if getattr(var, "unit", "") else ""
        a.set_xlim(lo, hi)
        a.set_ylim(-0.02, 1.12)
        a.set_xlabel(f"{var.name}{unit}")
        a.set_ylabel("membership")
        a.grid(True, lw=0.3, alpha=0.6)
        desc = getattr(var, "description", "")
        number = (numbers or {}).get(var.name)
        head = f"Fig. {number}. " if number is not None else ""
        # the paper's number, not the paper's curves: said under the title
        note = f"\n{FITTED_NOTE}" if number is not None else ""
        a.set_title(
            f"{head}{kind} {var.name}" + (f": {desc}" if desc else "") + title_suffix + note,
            fontsize=9,
        )
        a.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        name = stem(var.name) if stem is not None else f"{prefix}membership_{var.name}"
        written += _save(fig, out_dir, name, formats)
    return written


def write_membership_overview(
    fis, path, title: str, *, points: int = 1001, d_t_shown_m: float = 20.0
) -> Path:
    """All of a system's variables on one page (two columns), like the paper's Figs. 6-11
    side by side: the README's picture of a rule base. ``d_t`` is shown up to
    ``d_t_shown_m`` (its far terms are flat beyond)."""
    import matplotlib.pyplot as plt

    variables = list(fis.inputs) + list(fis.outputs)
    rows = (len(variables) + 1) // 2
    fig, axes = plt.subplots(rows, 2, figsize=(12, 2.8 * rows), squeeze=False)
    for a, var in zip(axes.ravel(), variables):
        lo, hi = var.range
        shown = min(hi, d_t_shown_m) if var.name == "d_t" else hi
        x = np.linspace(lo, shown, points)
        for k, term in enumerate(var.terms):
            a.plot(
                x,
                np.asarray(term(x), dtype=float),
                lw=1.6,
                color=TERMS[k % len(TERMS)],
                label=f"{term.name} ({term.shape})",
            )
        unit = f" [{var.unit}]" if getattr(var, "unit", "") else ""
        note = f" (shown to {shown:g} of {hi:g})" if shown < hi else ""
        a.set_title(f"{var.name}{unit}{note}", fontsize=9)
        a.set_ylim(-0.02, 1.1)
        a.set_xlabel(f"{var.name}{unit}")
        a.set_ylabel("membership")
        a.grid(True, lw=0.3, alpha=0.6)
        a.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))  # not over a term
    for a in axes.ravel()[len(variables) :]:
        a.axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=90, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
