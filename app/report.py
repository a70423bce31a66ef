"""``fuzzynav report OUT_DIR``: everything a reviewer needs, for s1-s3 and every controller.

For each scenario and controller it writes a rerun recording (``rrd/``) and the paper's
figure set (``figures/``); then the paper's Fig. 27 (all controllers side by side per
scenario) and the comparison table as ``table4.md`` and ``table4.json``. With
``--readme-images DIR`` the s1-s3 figures the README shows are also copied there, with
the paper controller's membership overview, and ``table4.md`` beside DIR.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from fuzzynav.app.experiments import SCENARIOS, TABLE4_ROWS, table4_row
from fuzzynav.controller.rulebase import read_toml

DEFAULT_CONTROLLERS = ("paper", "baseline", "fuzzynav")


def _markdown(rows: list[dict]) -> str:
    head = [
        "scenario",
        "controller",
        *TABLE4_ROWS,
        "min_clearance_m",
        "time_to_target_s",
        "outcome",
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        paper = row.get("paper")
        cells = [row["scenario"], row["controller"]]
        for key in TABLE4_ROWS:
            value = row[key]
            text = "—" if value is None else f"{value:.3f}"
            if paper:
                text += f" ({paper[key]:.4g})"
            cells.append(text)
        cells.append("—" if row["min_clearance_m"] is None else f"{row['min_clearance_m']:.3f}")
        cells.append("—" if row["time_to_target_s"] is None else f"{row['time_to_target_s']:.1f}")
        cells.append(row["outcome"])
        lines.append("| " + " | ".join(cells) + " |")
    return (
        "\n".join(lines) + "\n\nIn brackets: the paper's published Table 4 value (for `baseline`, "
        "the paper's ref. [19], of which our baseline is only a stand-in).\n"
    )


def write_report(
    out_dir: str | Path,
    controllers=DEFAULT_CONTROLLERS,
    perception: str = "ideal",
    readme_images: str | Path | None = None,
    progress=True,
) -> dict:
    """Run, record and draw every (scenario, controller) pair; returns the table object."""
    from rich.progress import Progress

    from fuzzynav.app.figures import check_writable_dir, write_comparison_figure, write_run_figures
    from fuzzynav.app.recording import record_run
    from fuzzynav.app.runs import build_simulation

    out = check_writable_dir(out_dir, option="OUT_DIR")
    rrd_dir, fig_dir = out / "rrd", out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    rrd_dir.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict] = {s: {} for s in SCENARIOS}
    rows = []
    pairs = [(s, c) for s in SCENARIOS for c in controllers]
    with Progress(disable=not progress) as bar:
        task = bar.add_task("report", total=len(pairs))
        for scenario, name in pairs:
            bar.update(task, description=f"{scenario} · {name}")
            sim = build_simulation(scenario, name, perception=perception, seed=0)
            result = sim.run()
            results[scenario][name] = result
            record_run(
                result,
                rrd_dir / f"{scenario}_{name}.rrd",
                controller=sim.controller,
                sensors=sim.sensors,
                parameters=sim.model.parameters,
            )
            write_run_figures(result, fig_dir, sim.controller, prefix=f"{scenario}_{name}_")
            rows.append(table4_row(name, scenario, SCENARIOS.index(scenario), result))
            bar.advance(task)
    write_comparison_figure(results, fig_dir, name="comparison")
    table = {"perception": perception, "controllers": list(controllers), "rows": rows}
    (out / "table4.json").write_text(json.dumps(table, indent=2), encoding="utf-8")
    (out / "table4.md").write_text(_markdown(rows), encoding="utf-8")
    if readme_images is not None:
        images = Path(readme_images)
        images.mkdir(parents=True, exist_ok=True)
        for path in fig_dir.glob("*.png"):
            if path.name.startswith(("comparison",)) or "_trajectory" in path.name:
                shutil.copy2(path, images / path.name)
        # the README's table lives beside its images' folder (docs/table4.md)
        shutil.copy2(out / "table4.md", images.parent / "table4.md")
        if "paper" in controllers:
            from fuzzynav.app.figures import write_membership_overview
            from fuzzynav.controller.paper import PAPER_RULES

            write_membership_overview(
                read_toml(PAPER_RULES),
                images / "paper_membership.png",
                "Paper controller, tuned membership functions (assets/rules/paper.toml)",
            )
    return table


def cmd_report(args) -> int:
    from fuzzynav.app.cli import UsageError
    from fuzzynav.controller.registry import controller_names

    offered = controller_names()
    wanted = (
        [c.strip() for c in args.controllers.split(",") if c.strip()]
        if args.controllers
        else [c for c in DEFAULT_CONTROLLERS if c in offered]
    )
    for name in wanted:
        if name not in offered:
            raise UsageError(
                f"--controllers: {name!r} is not available (have {', '.join(offered)})"
            )
    write_report(args.out_dir, wanted, args.perception, args.readme_images)
    print(f"report written to {args.out_dir} (table4.md, table4.json, figures/, rrd/)")
    return 0


def add_commands(subparsers) -> None:
    from fuzzynav.world.perception import PERCEPTION_MODES

    p = subparsers.add_parser(
        "report", help="recordings, figures and Table 4 for s1-s3 and every controller"
    )
    p.add_argument("out_dir", type=Path, help="directory to write into (created)")
    p.add_argument(
        "--controllers",
        default=None,
        help=f"comma-separated (default: {', '.join(DEFAULT_CONTROLLERS)} where available)",
    )
    p.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors (default ideal)",
    )
    p.add_argument(
        "--readme-images",
        type=Path,
        default=None,
        help="also copy the trajectory and comparison PNGs here (the README's docs/img)",
    )
    p.set_defaults(func=cmd_report)
