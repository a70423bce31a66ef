"""``fuzzynav report OUT_DIR``: everything a reviewer needs, for s1-s3 and every controller.

For each geometry (``--geometry husky|paper|both``, default both), scenario and controller
it writes a rerun recording (``rrd/<geometry>/``) and the paper's figures, named by the
paper's figure numbers (``figures/<geometry>/fig12_s1_trajectory_paper.png``, ...; Fig. 27
the paper's 3 x 2 comparison, Fig. 27b the other controllers beside it), with an index
``figures/index.md``; then Table 4 in every geometry beside the paper's numbers, with the
differences in per cent, as ``table4.md`` and ``table4.json``. With ``--readme-images DIR``
the husky-geometry s1-s3 trajectories and Fig. 27 are also copied there under the names the
docs use (``s1_paper_trajectory.png``, ``comparison.png``), with the paper controller's
membership overview, and ``table4.md`` beside DIR.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from fuzzynav.app.args import UsageError, add_force_option
from fuzzynav.app.experiments.compare import SCENARIOS, TABLE4_ROWS, table4_row
from fuzzynav.app.figures.numbering import FIG27_COLUMNS
from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.app.published import published_table4
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.safe_files import (
    OutputScope,
    check_output_path,
    write_bytes_atomically,
    write_text_atomically,
)
from fuzzynav.world.perception import GEOMETRIES

DEFAULT_CONTROLLERS = ("paper", "baseline", "fuzzynav")
GEOMETRY_CHOICES = (*GEOMETRIES, "both")


def geometries_of(choice: str) -> tuple[str, ...]:
    """``--geometry``'s value as the geometries to report: ``both`` = husky and paper."""
    if choice == "both":
        return tuple(GEOMETRIES)
    if choice not in GEOMETRIES:
        raise ValueError(f"--geometry {choice!r}: must be one of {', '.join(GEOMETRY_CHOICES)}")
    return (choice,)


def percent_difference(ours, published) -> float | None:
    """``100 (ours - published) / published``: how far ours is from the paper's number,
    in per cent of the paper's; None when either is missing or not finite, or the
    paper's is zero."""
    if ours is None or published is None:
        return None
    ours, published = float(ours), float(published)
    if not (math.isfinite(ours) and math.isfinite(published)) or published == 0.0:
        return None
    return 100.0 * (ours - published) / published


def paper_events(result, scenario: str) -> list[dict]:
    """Section 4's events (closest approach to each obstacle: time and centre distance)
    as the paper gives them beside ours, each with its difference in per cent."""
    from fuzzynav.app.experiments.paper_fit import closest_approaches, paper_results

    events = paper_results().get("events", {}).get(scenario, [])
    log = result.log
    ours = closest_approaches(log.time_s, log.center_distance_m) if len(log) else []
    rows = []
    for event in events:
        k = int(event["obstacle"])
        time_s, distance_m = ours[k] if k < len(ours) else (None, None)
        if distance_m is not None and not math.isfinite(distance_m):
            time_s, distance_m = None, None
        paper_time, paper_distance = event.get("time_s"), event.get("distance_m")
        rows.append(
            {
                "obstacle": k,
                "time_s": time_s,
                "distance_m": distance_m,
                "paper_time_s": paper_time,
                "paper_distance_m": paper_distance,
                "time_difference_percent": percent_difference(time_s, paper_time),
                "distance_difference_percent": percent_difference(distance_m, paper_distance),
            }
        )
    return rows


def report_row(controller: str, scenario: str, result, geometry: str) -> dict:
    """One row of the report's Table 4: the run's numbers (as ``compare``'s rows), its
    geometry, the paper's numbers and ours' difference from them in per cent (and, for
    the paper controller, section 4's events)."""
    row = table4_row(controller, scenario, SCENARIOS.index(scenario), result)
    published = published_table4(controller, scenario)
    row["geometry"] = geometry
    row["voltage_jumps"] = result.metrics["voltage_jumps"]
    row["min_safety_distance_m"] = result.metrics["min_safety_distance_m"]
    row["paper"] = published
    row["difference_percent"] = (
        {k: percent_difference(row[k], published[k]) for k in TABLE4_ROWS} if published else None
    )
    if controller == "paper":
        row["events"] = paper_events(result, scenario)
    return {"geometry": geometry, **row}


def _number(value, digits: int = 3) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def _percent(value) -> str:
    return "—" if value is None else f"{value:+.1f} %"


def _markdown(rows: list[dict], perception: str) -> str:
    head = [
        "geometry",
        "scenario",
        "controller",
        *TABLE4_ROWS,
        "min_safety_distance_m",
        "time_to_target_s",
        "voltage_jumps",
        "outcome",
    ]
    out = [
        f"# Table 4 — {perception} perception",
        "",
        "Each cell: ours (the paper's published value; ours' difference in per cent of it).",
        "For `paper` the paper's proposed method; for `baseline` the paper's ref. [19], of",
        "which our baseline is only a stand-in. `min_safety_distance_m` is what the 0.25 m",
        "safe distance is judged on: the footprint's clearance in the husky geometry, the",
        "centre distance in the paper's (a point robot). `voltage_jumps`: control steps with",
        "a wheel jump over 2 V, outside s3's disturbance.",
    ]
    for geometry in dict.fromkeys(r["geometry"] for r in rows):
        out += ["", f"## {geometry} geometry", ""]
        out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in (r for r in rows if r["geometry"] == geometry):
            paper, diff = row.get("paper"), row.get("difference_percent")
            cells = [row["geometry"], row["scenario"], row["controller"]]
            for key in TABLE4_ROWS:
                text = _number(row[key])
                if paper:
                    text += f" ({paper[key]:.4g}; {_percent(diff[key])})"
                cells.append(text)
            cells += [
                _number(row["min_safety_distance_m"]),
                _number(row["time_to_target_s"], 1),
                str(row["voltage_jumps"]),
                row["outcome"],
            ]
            out.append("| " + " | ".join(cells) + " |")
    events = [(r, e) for r in rows for e in r.get("events", [])]
    if events:
        out += [
            "",
            "## Section 4's events, paper controller",
            "",
            "Closest approach to each obstacle, centre to centre: ours (the paper's; "
            "difference in per cent). The paper gives no time for s1's passes.",
            "",
            "| geometry | scenario | obstacle | time_s | distance_m |",
            "|---|---|---|---|---|",
        ]
        for row, e in events:
            time_cell = _number(e["time_s"], 1)
            if e["paper_time_s"] is not None:
                time_cell += f" ({e['paper_time_s']:g}; {_percent(e['time_difference_percent'])})"
            dist_cell = _number(e["distance_m"])
            if e["paper_distance_m"] is not None:
                dist_cell += (
                    f" ({e['paper_distance_m']:g}; {_percent(e['distance_difference_percent'])})"
                )
            out.append(
                f"| {row['geometry']} | {row['scenario']} | {obstacle_label(e['obstacle'])} "
                f"| {time_cell} | {dist_cell} |"
            )
    return "\n".join(out) + "\n"


def write_report(
    out_dir: str | Path,
    controllers=DEFAULT_CONTROLLERS,
    perception: str = "ideal",
    readme_images: str | Path | None = None,
    geometries=GEOMETRIES,
    force: bool = False,
) -> dict:
    """Run, record and draw every (geometry, scenario, controller); returns the table.

    Parameters
    ----------
    out_dir : the report's folder (created)
    controllers : controller names
    perception : ``ideal`` or ``ultrasonic`` (the paper's geometry takes only ideal)
    readme_images : optional folder for the docs' copies (see the module docstring)
    geometries : any of ``husky`` and ``paper``
    force : replace existing files: without it, no file the report names (in
        ``out_dir``, in ``readme_images``, ``table4.md`` beside it) replaces one it did
        not write itself (ValueError, before the runs where the name is known)
    """
    from fuzzynav.app.figures.style import check_writable_dir
    from fuzzynav.world.perception import check_geometry

    geometries = tuple(geometries)
    for geometry in geometries:
        check_geometry(geometry, perception)
    # Every file is named by the report: none replaces one it did not write, unless
    # force; the names known in advance are checked before the first run.
    outputs = OutputScope("report", overwrite=force)
    if readme_images is not None:  # before the runs, through the one output guard
        images = Path(readme_images)
        check_output_path(images, "--readme-images", folder=True)  # not in the package
        check_output_path(readme_table_path(images), "--readme-images", folder=True)
        outputs.check(_readme_paths(images, controllers, geometries))
    outputs.check(_report_paths(Path(out_dir), controllers, geometries))
    out = check_writable_dir(out_dir, option="OUT_DIR")
    with outputs:
        table = _run_and_write(out, controllers, perception, geometries)
        if readme_images is not None:
            _copy_readme_images(out, out / "figures", Path(readme_images), controllers, geometries)
    return table


def _report_paths(out: Path, controllers, geometries) -> list[Path]:
    """The report's files whose names are known before its runs (the figures' are
    checked as they are written)."""
    paths = [out / "table4.json", out / "table4.md", out / "figures" / "index.md"]
    paths += [
        out / "rrd" / g / f"{s}_{c}.rrd" for g in geometries for s in SCENARIOS for c in controllers
    ]
    return paths


def _readme_paths(images: Path, controllers, geometries) -> list[Path]:
    """What ``--readme-images DIR`` may write (see :func:`_copy_readme_images`)."""
    paths = [readme_table_path(images)]
    if "husky" in geometries:
        paths += [images / f"{s}_{c}_trajectory.png" for s in SCENARIOS for c in controllers]
        if any(c in FIG27_COLUMNS for c in controllers):  # Fig. 27 drawn
            paths.append(images / "comparison.png")
    if "paper" in controllers:
        paths.append(images / "paper_membership.png")
    return paths


def _run_and_write(out: Path, controllers, perception, geometries) -> dict:
    """Run, record and draw every (geometry, scenario, controller) into ``out``; write
    the figure index and Table 4; returns the table."""
    from rich.progress import Progress

    from fuzzynav.app.figures.paper_set import write_figure_index, write_paper_figures
    from fuzzynav.app.figures.style import FORMATS
    from fuzzynav.app.recordings.record import record_run
    from fuzzynav.app.runs import build_simulation

    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    rows, entries = [], []
    jobs = [(g, s, c) for g in geometries for s in SCENARIOS for c in controllers]
    results: dict[str, dict[str, dict]] = {g: {s: {} for s in SCENARIOS} for g in geometries}
    controller_objects: dict[str, dict] = {g: {} for g in geometries}
    with Progress() as bar:
        task = bar.add_task("report", total=len(jobs) + len(geometries))
        for geometry, scenario, name in jobs:
            bar.update(task, description=f"{geometry} · {scenario} · {name}")
            sim = build_simulation(scenario, name, perception=perception, seed=0, geometry=geometry)
            result = sim.run()
            results[geometry][scenario][name] = result
            controller_objects[geometry].setdefault(name, sim.controller)
            rrd_dir = out / "rrd" / geometry
            rrd_dir.mkdir(parents=True, exist_ok=True)
            record_run(
                result,
                rrd_dir / f"{scenario}_{name}.rrd",
                controller=sim.controller,
                sensors=sim.sensors,
                parameters=sim.model.parameters,
            )
            rows.append(report_row(name, scenario, result, geometry))
            bar.advance(task)
        for geometry in geometries:
            bar.update(task, description=f"{geometry} · figures")
            entries += write_paper_figures(
                results[geometry], controller_objects[geometry], fig_dir, geometry, formats=FORMATS
            )
            bar.advance(task)
    write_figure_index(entries, fig_dir)
    table = {
        "perception": perception,
        "geometries": list(geometries),
        "controllers": list(controllers),
        "rows": rows,
    }
    write_text_atomically(out / "table4.json", json.dumps(table, indent=2))
    write_text_atomically(out / "table4.md", _markdown(rows, perception))
    return table


def _copy(source: Path, target: Path) -> None:
    """Copy a file through the one atomic writer (the target whole or not at all)."""
    from fuzzynav.resources import read_user_bytes

    write_bytes_atomically(target, read_user_bytes(source, "figure", 64 * 1024 * 1024))


def readme_table_path(images: Path) -> Path:
    """Where ``--readme-images DIR`` puts the README's copy of Table 4: beside DIR."""
    return Path(images).parent / "table4.md"


def _copy_readme_images(out: Path, fig_dir: Path, images: Path, controllers, geometries):
    """The docs' pictures under the names they use: the husky geometry's trajectories
    (``s1_paper_trajectory.png``), its Fig. 27 (``comparison.png``), the paper
    controller's membership overview; ``table4.md`` beside the folder."""
    from fuzzynav.app.figures.numbering import paper_figure_stem

    images.mkdir(parents=True, exist_ok=True)
    if "husky" in geometries:
        husky = fig_dir / "husky"
        for scenario in SCENARIOS:
            for name in controllers:
                source = husky / f"{paper_figure_stem(scenario, 'trajectory', name)}.png"
                if source.exists():
                    _copy(source, images / f"{scenario}_{name}_trajectory.png")
        if (husky / "fig27_comparison.png").exists():
            _copy(husky / "fig27_comparison.png", images / "comparison.png")
    # the README's table lives beside its images' folder (docs/table4.md)
    _copy(out / "table4.md", readme_table_path(images))
    if "paper" in controllers:
        from fuzzynav.app.figures.membership import write_membership_overview
        from fuzzynav.controller.paper import PAPER_RULES

        write_membership_overview(
            read_toml(PAPER_RULES),
            images / "paper_membership.png",
            "Paper controller, tuned membership functions (assets/rules/paper.toml)",
        )


def cmd_report(args) -> int:
    from fuzzynav.controller.registry import controller_names

    offered = controller_names()
    wanted = (
        [c.strip() for c in args.controllers.split(",") if c.strip()]
        if args.controllers is not None  # `--controllers ''` ran the default set
        else [c for c in DEFAULT_CONTROLLERS if c in offered]
    )
    if args.controllers is not None and not wanted:  # `--controllers ,` wrote an empty table
        raise UsageError(
            f"--controllers {args.controllers!r}: names no controller (have {', '.join(offered)})"
        )
    for name in wanted:
        if name not in offered:
            raise UsageError(
                f"--controllers: {name!r} is not available (have {', '.join(offered)})"
            )
    geometries = geometries_of(args.geometry)
    if "paper" in geometries and args.perception != "ideal":
        raise UsageError(
            f"--perception {args.perception} with --geometry {args.geometry}: the paper's "
            "geometry (a point robot) takes ideal perception only; use --geometry husky"
        )
    write_report(
        args.out_dir,
        wanted,
        args.perception,
        args.readme_images,
        geometries=geometries,
        force=getattr(args, "force", False),
    )
    print(
        f"report written to {args.out_dir} (table4.md, table4.json, figures/index.md, "
        "figures/, rrd/)"
    )
    return 0


def add_commands(subparsers) -> None:
    from fuzzynav.world.perception import PERCEPTION_MODES

    p = subparsers.add_parser(
        "report",
        help="recordings, the paper's Figs. 6-27 and Table 4 for s1-s3 and every controller",
    )
    p.add_argument("out_dir", type=Path, help="directory to write into (created)")
    p.add_argument(
        "--controllers",
        help=f"comma-separated (default: {', '.join(DEFAULT_CONTROLLERS)} where available)",
    )
    p.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors (default "
        "ideal; the paper's geometry takes ideal only)",
    )
    p.add_argument(
        "--geometry",
        default="both",
        choices=GEOMETRY_CHOICES,
        help="husky: the real Husky A200's footprint (husky.toml); paper: the paper's point robot, "
        "centre to centre (Eqs. 7-12); both (default): each, side by side in the table",
    )
    p.add_argument(
        "--readme-images",
        type=Path,
        help="also copy the husky geometry's trajectories and Fig. 27 here (the docs' "
        "docs/img), and table4.md beside it (an existing one only with --force)",
    )
    add_force_option(p, "an earlier report's files (in OUT_DIR, --readme-images DIR, table4.md)")
    p.set_defaults(func=cmd_report)
