"""The paper's figure numbers and the file names they give (one numbering everywhere:
``run --figures``, the report, the recordings' panels).

Figs. 6-11 are the paper controller's membership functions; Figs. 12-16 s1's run
figures in :data:`RUN_FIGURES` order, s2 repeats them as 17-21 and s3 as 22-26; Fig. 27
is the comparison of the proposed method with ref. [19].
"""

from __future__ import annotations

from pathlib import Path

RUN_FIGURES = ("trajectory", "distances", "angles", "obstacle_angles", "voltages")
# Figs. 12-16 are s1's run figures in RUN_FIGURES order; s2 repeats them as 17-21, s3 as 22-26.
FIRST_RUN_FIGURE = {"s1": 12, "s2": 17, "s3": 22}
COMPARISON_FIGURE = 27
# Figs. 6-11: the membership functions of the paper's controller.
MEMBERSHIP_FIGURE = {"d_t": 6, "phi_t": 7, "d_o": 8, "phi_o": 9, "left": 10, "right": 11}
# Fig. 27's columns in the paper's order: (a) method of [19] s1, (b) proposed s1, (c) ...
FIG27_COLUMNS = ("baseline", "paper")
FIG27_TITLES = {"baseline": "ref. [19] stand-in (baseline)", "paper": "proposed (paper)"}
FIGURE_WHAT = {
    "trajectory": "trajectory of the robot's centre, obstacles and their safe distance",
    "distances": "distance to the target and to each obstacle over time",
    "angles": "target angle phi_t and heading over time",
    "obstacle_angles": "angle of each obstacle from the heading over time",
    "voltages": "wheel voltages, left (v_s1) and right (v_s2), and their difference",
    "membership": "membership functions of",
    "comparison": "trajectories in s1-s3, side by side",
}


def paper_figure_number(scenario: str, kind: str) -> int | None:
    """The paper's figure number of a run figure (Fig. 12 = s1's trajectory, ..., Fig. 26
    = s3's voltages), or None for a scenario the paper has no figures of."""
    first = FIRST_RUN_FIGURE.get(scenario)
    if first is None or kind not in RUN_FIGURES:
        return None
    return first + RUN_FIGURES.index(kind)


def paper_figure_stem(scenario: str, kind: str, controller: str) -> str:
    """The file name (no extension) of a run figure in the report: ``fig12_s1_trajectory_
    paper`` = Fig. 12, scenario s1, the trajectory, controller ``paper``; the geometry is
    the folder's name. Scenarios outside s1-s3 go without a number."""
    number = paper_figure_number(scenario, kind)
    head = f"fig{number:02d}_" if number is not None else ""
    return f"{head}{scenario}_{kind}_{controller}"


def membership_figure_stem(variable: str, controller: str) -> str:
    """``fig06_membership_d_t_paper`` for the paper controller's Figs. 6-11, else
    ``membership_<variable>_<controller>`` (the paper has no such figure)."""
    number = MEMBERSHIP_FIGURE.get(variable) if controller == "paper" else None
    head = f"fig{number:02d}_" if number is not None else ""
    return f"{head}membership_{variable}_{controller}"


def scenario_stem(scenario) -> str:
    """A scenario's short name: its file's stem (s1) or its name."""
    source = getattr(scenario, "source", "") or ""
    return Path(source).stem if source and source != "<memory>" else scenario.name


def numbered_scenario(scenario) -> str | None:
    """The shipped scenario's name (s1) when the run drove a shipped file, whose figures
    have the paper's numbers; None for any other (a copy named s2.toml elsewhere too)."""
    from fuzzynav.world.scenario import SCENARIO_DIR

    source = getattr(scenario, "source", "") or ""
    if not source or source == "<memory>":
        return None
    try:
        shipped = Path(source).resolve().parent == SCENARIO_DIR.resolve()
    except OSError:
        return None
    return Path(source).stem if shipped else None


def run_figure_stem(scenario, kind: str, controller: str) -> str:
    """A run figure's file name: ``fig17_s2_trajectory_paper`` for a shipped s1-s3 (the
    report's names), ``<stem>_<kind>_<controller>`` for any other scenario."""
    shipped = numbered_scenario(scenario)
    if shipped is not None:
        return paper_figure_stem(shipped, kind, controller)
    return f"{scenario_stem(scenario)}_{kind}_{controller}"
