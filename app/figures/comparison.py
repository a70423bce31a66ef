"""The comparison grid (the paper's Fig. 27): the trajectories of several controllers
side by side, one row per scenario, panels lettered as the paper's.
"""

from __future__ import annotations

from pathlib import Path

from fuzzynav.app.figures.style import (
    FORMATS,
    _default_footprint,
    _new_figure,
    _save,
    check_writable_dir,
)
from fuzzynav.app.figures.trajectory import draw_trajectory, separate_labels


def _orient(results: dict) -> dict:
    """``{scenario: {controller: result}}``; a mapping given the other way round
    (``{controller: {scenario: result}}``) is recognised by its results' scenarios and
    transposed."""

    def names(inner):
        return {getattr(r.scenario, "name", None) for r in inner.values() if r is not None}

    outer_is_scenario = all(len(names(inner)) <= 1 for inner in results.values())
    if outer_is_scenario:
        return results
    flipped: dict = {}
    for outer, inner in results.items():
        for key, result in inner.items():
            flipped.setdefault(key, {})[outer] = result
    if all(len(names(inner)) <= 1 for inner in flipped.values()):
        return flipped
    return results


def comparison_figure(
    results_by_controller_by_scenario: dict,
    *,
    controllers=None,
    column_titles: dict | None = None,
    title: str | None = None,
):
    """The comparison grid as a matplotlib ``Figure`` (not saved): one row per scenario,
    one column per controller (``controllers`` fixes which and in what order; default
    every controller present, in order of appearance), each panel the trajectory of that
    controller in that scenario, same axes along a row, panels lettered (a), (b), ...
    row by row as the paper's Fig. 27. ``column_titles`` maps a controller to the name
    its panels carry (default the controller's label)."""
    grid = _orient(results_by_controller_by_scenario)
    scenarios = list(grid)
    if controllers is None:
        controllers = []
        for inner in grid.values():
            for c in inner:
                if c not in controllers:
                    controllers.append(c)
    controllers = list(controllers)
    if not scenarios or not controllers:
        raise ValueError("comparison figure: no results to draw")
    column_titles = column_titles or {}
    footprint_m = _default_footprint()
    rows, cols = len(scenarios), len(controllers)
    # wide enough for its title even with one column
    fig, axes = _new_figure(max(3.6 * cols + 0.4, 6.4), 3.5 * rows + 0.3, rows, cols)
    letters = "abcdefghijklmnopqrstuvwxyz"
    for i, scenario in enumerate(scenarios):
        row_results = [grid[scenario].get(c) for c in controllers]
        for j, (controller, result) in enumerate(zip(controllers, row_results)):
            ax = axes[i, j]
            index = i * cols + j
            tag = f"({letters[index]})" if index < len(letters) else f"({index + 1})"
            shown = column_titles.get(controller, controller)
            if result is None:
                ax.set_axis_off()
                ax.set_title(f"{tag} {shown}, {scenario}: not run", fontsize=8)
                continue
            m = result.metrics or {}
            length = m.get("path_length_m")
            extra = f", {length:.2f} m" if isinstance(length, (int, float)) else ""
            draw_trajectory(
                ax,
                result,
                footprint_m=footprint_m,
                footprints=False,
                legend=False,
                title=f"{tag} {shown}, {scenario}: {result.outcome}{extra}",
                events=False,
            )
            # which run a panel shows, for a reader of the Figure object (and the tests)
            ax.set_gid(f"{scenario}/{controller}")
    # One legend for every panel (each panel's own limits: sharing a row's squashed a
    # panel whose path is short beside a long one).
    handles = {}
    for ax in axes.ravel():
        for handle, text in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(text, handle)
    if handles:
        fig.legend(
            list(handles.values()),
            list(handles),
            loc="outside lower center",
            ncols=min(4, len(handles)),
            fontsize=7,
        )
    fig.suptitle(title or "Trajectories while reaching the target (paper Fig. 27)", fontsize=10)
    separate_labels(fig)
    return fig


def write_comparison_figure(
    results_by_controller_by_scenario: dict,
    out_dir,
    *,
    name: str = "comparison",
    formats=FORMATS,
    controllers=None,
    column_titles: dict | None = None,
    title: str | None = None,
) -> list[Path]:
    """The paper's Fig. 27: one row per scenario, one column per controller, each panel
    the trajectory of that controller in that scenario (same axes along a row).

    ``results_by_controller_by_scenario`` maps a scenario label to a mapping of
    controller label to ``SimulationResult``, e.g. ``{"s1": {"baseline": r1, "paper":
    r2}, "s2": {...}}``; any number of either. (Given as ``{controller: {scenario:
    result}}`` it is recognised and transposed.) A missing pair is drawn as an empty
    panel. ``controllers``, ``column_titles`` and ``title`` as
    :func:`comparison_figure`. Returns the files written.
    """
    out_dir = check_writable_dir(out_dir, option="out_dir")
    fig = comparison_figure(
        results_by_controller_by_scenario,
        controllers=controllers,
        column_titles=column_titles,
        title=title,
    )
    return _save(fig, out_dir, name, formats)
