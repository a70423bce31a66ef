"""The paper's Figs. 6-27 for the report (``fuzzynav report``): every run's figures,
the membership functions and Fig. 27, files named by the paper's figure numbers, one
folder per geometry, and ``figures/index.md`` that lists them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fuzzynav.app.figures.comparison import write_comparison_figure
from fuzzynav.app.figures.membership import write_membership_figures
from fuzzynav.app.figures.numbering import (
    COMPARISON_FIGURE,
    FIG27_COLUMNS,
    FIG27_TITLES,
    FIGURE_WHAT,
    MEMBERSHIP_FIGURE,
    RUN_FIGURES,
    membership_figure_stem,
    paper_figure_number,
    paper_figure_stem,
)
from fuzzynav.app.figures.run_figures import write_run_figures
from fuzzynav.app.figures.style import FORMATS, check_writable_dir
from fuzzynav.app.recordings.internals import controller_fis
from fuzzynav.safe_files import write_text_atomically


@dataclass(frozen=True)
class IndexEntry:
    """One figure of the report's index (``figures/index.md``): its number in the paper
    ("12", "27", "27b", "" when the paper has none), what it shows, and its files
    (PNG, SVG)."""

    figure: str
    what: str
    scenario: str
    controller: str
    geometry: str
    files: tuple[Path, ...]


def write_paper_figures(
    results: dict,
    controllers: dict,
    root,
    geometry: str,
    *,
    formats=FORMATS,
    voltage_limit_v: float = 12.0,
) -> list[IndexEntry]:
    """The paper's Figs. 6-27 for one geometry into ``root/<geometry>/``.

    Parameters
    ----------
    results : ``{scenario: {controller name: SimulationResult}}`` (s1-s3 get the paper's
        numbers 12-26)
    controllers : ``{controller name: controller object}``; a fuzzy one also gets its
        membership figures (the paper controller's as Figs. 6-11)
    root : the figures folder; the geometry's subfolder is created
    geometry : ``husky`` or ``paper``, the folder's name and every title's
    formats, voltage_limit_v : as :func:`write_run_figures`

    Fig. 27 is the paper's 3 x 2: rows the scenarios, columns ``baseline`` (the stand-in
    for [19]) and ``paper`` (the proposed method), as far as they were run; every other
    controller (e.g. fuzzynav) gets Fig. "27b", laid out the same, beside it.

    Returns the index entries of every figure written, in order.
    """
    out_dir = check_writable_dir(Path(root) / geometry, option="out_dir")
    entries, names_in_order = _run_entries(
        results, out_dir, geometry, formats=formats, voltage_limit_v=voltage_limit_v
    )
    entries += _membership_entries(controllers, names_in_order, out_dir, geometry, formats)
    entries += _comparison_entries(results, names_in_order, out_dir, geometry, formats)
    return entries


def _run_entries(
    results: dict, out_dir: Path, geometry: str, *, formats, voltage_limit_v: float
) -> tuple[list[IndexEntry], list[str]]:
    """Every run's figures (numbered 12-26 for s1-s3); also the controllers' names in the
    order they first appear."""
    entries: list[IndexEntry] = []
    names_in_order: list[str] = []
    for scenario, inner in results.items():
        for name, result in inner.items():
            if name not in names_in_order:
                names_in_order.append(name)
            stems = {kind: paper_figure_stem(scenario, kind, name) for kind in RUN_FIGURES}
            files = write_run_figures(
                result,
                out_dir,
                names=stems,
                formats=formats,
                voltage_limit_v=voltage_limit_v,
                membership=False,
                controller_label=name,
            )
            for kind in RUN_FIGURES:
                number = paper_figure_number(scenario, kind)
                entries.append(
                    IndexEntry(
                        "" if number is None else str(number),
                        FIGURE_WHAT[kind],
                        scenario,
                        name,
                        geometry,
                        tuple(p for p in files if p.stem == stems[kind]),
                    )
                )
    return entries, names_in_order


def _membership_entries(
    controllers: dict, names_in_order: list[str], out_dir: Path, geometry: str, formats
) -> list[IndexEntry]:
    """Every fuzzy controller's membership figures (the paper controller's as Figs. 6-11)."""
    entries: list[IndexEntry] = []
    for name in names_in_order:
        fis = controller_fis(controllers.get(name), merged=True)
        if fis is None:
            continue
        files = write_membership_figures(
            fis,
            out_dir,
            formats=formats,
            stem=lambda var, name=name: membership_figure_stem(var, name),
            title_suffix=f"\n{name} controller, {geometry} geometry",
            numbers=MEMBERSHIP_FIGURE if name == "paper" else None,
        )
        for var in tuple(fis.inputs) + tuple(fis.outputs):
            stem = membership_figure_stem(var.name, name)
            number = MEMBERSHIP_FIGURE.get(var.name) if name == "paper" else None
            entries.append(
                IndexEntry(
                    "" if number is None else str(number),
                    f"{FIGURE_WHAT['membership']} {var.name}",
                    "—",
                    name,
                    geometry,
                    tuple(p for p in files if p.stem == stem),
                )
            )
    return entries


def _comparison_entries(
    results: dict, names_in_order: list[str], out_dir: Path, geometry: str, formats
) -> list[IndexEntry]:
    """Fig. 27 (baseline and paper) and Fig. 27b (every other controller)."""
    entries: list[IndexEntry] = []
    scenarios = list(results)
    pair = [c for c in FIG27_COLUMNS if c in names_in_order]
    others = [c for c in names_in_order if c not in FIG27_COLUMNS]
    for figure, columns, stem, what in (
        (str(COMPARISON_FIGURE), pair, "fig27_comparison", "the paper's 3 x 2"),
        (f"{COMPARISON_FIGURE}b", others, "fig27b_" + "_".join(others), "beside Fig. 27"),
    ):
        if not columns:
            continue
        who = " and ".join(FIG27_TITLES.get(c, c) for c in columns)
        files = write_comparison_figure(
            results,
            out_dir,
            name=stem,
            formats=formats,
            controllers=columns,
            column_titles=FIG27_TITLES,
            title=(
                f"Fig. {figure}, {geometry} geometry: trajectories while reaching the target\n{who}"
            ),
        )
        entries.append(
            IndexEntry(
                figure,
                f"{FIGURE_WHAT['comparison']} ({what})",
                ", ".join(scenarios),
                ", ".join(columns),
                geometry,
                tuple(files),
            )
        )
    return entries


def write_figure_index(entries, root) -> Path:
    """``root/index.md``: one row per figure (the paper's figure number, what it shows,
    scenario, controller, geometry) with links to its files, relative to ``root``."""
    root = Path(root)
    lines = [
        "# The paper's figures",
        "",
        "Files are named `fig<NN>_<scenario>_<figure>_<controller>` after the paper's figure",
        "numbers (s1: Figs. 12-16, s2: 17-21, s3: 22-26; Fig. 27 the comparison, 27b the",
        "other controllers beside it; the paper controller's membership functions Figs. 6-11),",
        "in one folder per geometry. Wheels: left = v_s1, right = v_s2 (Eqs. 3-4).",
        "",
        "| figure | what it shows | scenario | controller | geometry | files |",
        "|---|---|---|---|---|---|",
    ]
    geometries = list(dict.fromkeys(e.geometry for e in entries))

    def order(e: IndexEntry):
        # by geometry, then the paper's figure number (27b after 27; unnumbered last)
        digits = e.figure.rstrip("abcdefghijklmnopqrstuvwxyz")
        return (geometries.index(e.geometry), int(digits) if digits else 999, e.figure)

    for e in sorted(entries, key=order):
        links = " · ".join(f"[{p.suffix[1:]}]({p.relative_to(root).as_posix()})" for p in e.files)
        number = f"Fig. {e.figure}" if e.figure else "—"
        lines.append(
            f"| {number} | {e.what} | {e.scenario} | {e.controller} | {e.geometry} | {links} |"
        )
    path = root / "index.md"
    write_text_atomically(path, "\n".join(lines) + "\n")
    return path
