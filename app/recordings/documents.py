"""The run's documents in a recording (static ``TextDocument`` entities under
``/meta``): the run and its reproduce command, the versions, the scenario, the rules,
the robot, the metrics and the summary beside the paper's Table 4."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from fuzzynav.app.figures.numbering import scenario_stem
from fuzzynav.app.provenance import command_line, package_versions, reproduce_run, wrap_command

from .internals import controller_label
from .sending import Statics


def _markdown_table(rows: dict) -> str:
    lines = ["| key | value |", "|---|---|"]
    for key, value in rows.items():
        if isinstance(value, float):
            value = f"{value:.6g}"
        lines.append(f"| {key} | {value} |")
    return "\n".join(lines)


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return _json_safe(value.item())
    return value


def _rules_text(fis, first: int = 1) -> str:
    """A rule base as its rules numbered from ``first``, then its TOML file."""
    try:
        from fuzzynav.controller.rulebase import dumps_toml

        rules = dumps_toml(fis)
    except Exception:  # a system the TOML writer refuses: list the rules instead
        rules = "\n".join(f"R{k + 1}: {fis.rule_text(k)}" for k in range(len(fis.rules)))
    numbered = "\n".join(f"# R{first + k}: {fis.rule_text(k)}" for k in range(len(fis.rules)))
    return numbered + "\n\n" + rules


def _rules_document(controller, fis) -> str:
    """/meta/rules: the rule base (a fuzzynav's blocks and its crisp parameters), or a
    controller's parameters when it has none."""
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    blocks = getattr(inner, "rule_blocks", None)
    if fis is not None:
        return _rules_text(fis)
    if callable(blocks):  # fuzzynav: its blocks and its crisp parameters
        # Numbered on through the blocks, as the recording's rule plot numbers them.
        parts, first = [], 1
        for name, block in blocks().items():
            parts.append(f"# ===== block {name!r} =====\n{_rules_text(block, first)}")
            first += len(block.rules)
        params = getattr(inner, "params_toml", None)
        if callable(params):
            parts.append("# ===== crisp parameters =====\n" + params())
        return "\n".join(parts)
    attrs = (
        {k: v for k, v in vars(controller).items() if not k.startswith("_")}
        if controller is not None and hasattr(controller, "__dict__")
        else {}
    )
    return (
        f"controller {controller_label(controller)!r} is not fuzzy: no rule "
        f"base.\nparameters: {json.dumps(_json_safe(attrs), default=repr)}\n"
    )


def _robot_document(parameters, sensor_config) -> str:
    """/meta/robot: the robot's parameters, the sensors' and their mounts."""
    robot = ["# robot (HuskyParameters)"]
    robot += [f"{f.name} = {getattr(parameters, f.name)!r}" for f in dataclasses.fields(parameters)]
    robot += ["", "# sensors (SensorConfig)"]
    robot += [
        f"{f.name} = {getattr(sensor_config, f.name)!r}"
        for f in dataclasses.fields(sensor_config)
        if f.name != "mounts"
    ]
    robot += [
        f"mount {m.name}: x = {m.x_m!r} m, y = {m.y_m!r} m, angle = {m.angle_rad!r} rad"
        for m in sensor_config.mounts
    ]
    return "\n".join(robot) + "\n"


def _run_document(
    *,
    scenario,
    controller,
    parameters,
    sensor_config,
    seed,
    perception,
    control_period_s,
    voltage_limit_v,
    extra_metadata,
    geometry: str,
) -> str:
    """/meta/run: the run's table (how to reproduce it), its commands, the versions."""
    from fuzzynav.app.runs import scenario_digest

    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    again = reproduce_run(
        scenario,
        controller,
        perception,
        seed,
        control_period_s,
        geometry=geometry,
        noise_std_m=sensor_config.noise_std_m,
        voltage_limit_v=voltage_limit_v,
        parameters=parameters,
    )
    run = {
        "scenario": scenario.name,
        "scenario file": getattr(scenario, "source", ""),
        "scenario sha256": scenario_digest(scenario),
        "controller": controller_label(controller),
        "perception": perception,
        "geometry": geometry,
        "seed": seed,
        "sensor noise (m)": sensor_config.noise_std_m,
        "control period (s)": control_period_s,
        "voltage limit (V)": voltage_limit_v,
        "reproduce": "`" + again.command + "`",
    }
    if again.notes:
        run["reproduce needs"] = "; ".join(again.notes)
    run["command line"] = "`" + command_line() + "`"
    parts_off = tuple(getattr(inner, "parts_off", None) or ())
    if parts_off:  # fuzzynav with parts switched off (assets/rules/fuzzynav_parts.toml)
        run = {
            **dict(list(run.items())[:4]),
            "parts off": ", ".join(parts_off),
            **dict(list(run.items())[4:]),
        }
    for key, value in (extra_metadata or {}).items():
        run[str(key)] = value
    # The commands again below the table, one option a line: a table cell does not
    # wrap, and a long command was cut at the panel's edge.
    commands = {"reproduce": again.command}
    line = str(run.get("command line", "")).strip("`")
    if line:
        commands["command line"] = line
    shown = "".join(
        f"\n\n## {what}\n\n```sh\n{wrap_command(text)}\n```" for what, text in commands.items()
    )
    return (
        "# Run\n\n"
        + _markdown_table(run)
        + shown
        + "\n\n# Versions\n\n"
        + _markdown_table(versions_with_tree(package_versions()))
    )


def git_tree_state(revision: str | None) -> str:
    """What ``git describe --dirty`` says of the checkout the run came from: ``clean``,
    ``dirty`` (uncommitted changes: the revision alone does not reproduce the run), or
    ``not a git checkout`` (an installed package: its version says which)."""
    if not revision:
        return "not a git checkout"
    if revision.endswith("-dirty"):
        return "dirty (uncommitted changes: the revision alone does not reproduce the run)"
    return "clean"


def versions_with_tree(versions: dict) -> dict:
    """``versions`` with the git tree's state (:func:`git_tree_state`) after its revision."""
    out = dict(versions)
    out["git tree"] = git_tree_state(versions.get("git"))
    return out


def metadata(
    static: Statics,
    *,
    scenario,
    controller,
    fis,
    parameters,
    sensor_config,
    seed,
    perception,
    control_period_s,
    voltage_limit_v,
    extra_metadata,
    geometry: str = "husky",
) -> None:
    """The run's documents: /meta/run (with the versions), /meta/scenario, /meta/rules,
    /meta/robot (with the sensors)."""
    import rerun as rr

    def doc(path, text, markdown=True):
        media = rr.MediaType.MARKDOWN if markdown else rr.MediaType.TEXT
        static.add_archetype(path, rr.TextDocument(text, media_type=media))

    doc("/meta/scenario", scenario.to_toml(), markdown=False)
    doc("/meta/rules", _rules_document(controller, fis), markdown=False)
    doc("/meta/robot", _robot_document(parameters, sensor_config), markdown=False)
    doc(
        "/meta/run",
        _run_document(
            scenario=scenario,
            controller=controller,
            parameters=parameters,
            sensor_config=sensor_config,
            seed=seed,
            perception=perception,
            control_period_s=control_period_s,
            voltage_limit_v=voltage_limit_v,
            extra_metadata=extra_metadata,
            geometry=geometry,
        ),
    )


def metrics(static: Statics, metrics: dict, outcome: str) -> None:
    import rerun as rr

    rows = {"outcome": outcome, **metrics}
    text = (
        "# Metrics\n\n"
        + _markdown_table(rows)
        + "\n\n```json\n"
        + json.dumps(_json_safe(rows), indent=2, default=repr)
        + "\n```\n"
    )
    static.add_archetype("/meta/metrics", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))


def summary(static: Statics, result, controller, events) -> None:
    """/meta/summary: the outcome, Table 4's metrics beside the paper's published values
    (s1-s3, the paper and baseline controllers), and the events."""
    import rerun as rr

    from fuzzynav.world.metrics import TABLE4_ROWS

    m = result.metrics or {}
    name = controller_label(controller)
    stem = scenario_stem(result.scenario)
    lines = [
        f"# {result.scenario.name}",
        "",
        f"**{getattr(result, 'outcome', 'running')}** — {name} controller, "
        f"{result.perception} perception, {getattr(result, 'geometry', 'husky')} geometry, "
        f"seed {result.seed}",
        "",
    ]
    published = None
    try:
        from fuzzynav.app.published import published_table4

        published = published_table4(name, stem)
    except Exception:  # the paper's numbers are optional here
        published = None
    head = "| metric | this run | paper | difference |" if published else "| metric | this run |"
    lines += [head, "|---|---|---|---|" if published else "|---|---|"]
    for key in (*TABLE4_ROWS, "time_to_target_s", "min_clearance_m", "voltage_jumps"):
        value = m.get(key)
        ours = (
            "—"
            if value is None or (isinstance(value, float) and not math.isfinite(value))
            else f"{value:.4g}"
        )
        if published:
            paper = published.get(key)
            if paper is None or value is None or not math.isfinite(float(value)):
                lines.append(f"| {key} | {ours} | {'—' if paper is None else f'{paper:.4g}'} | — |")
            else:
                diff = 100.0 * (float(value) - paper) / paper if paper else float("nan")
                lines.append(f"| {key} | {ours} | {paper:.4g} | {diff:+.1f} % |")
        else:
            lines.append(f"| {key} | {ours} |")
    if not published:
        lines += [
            "",
            "(The paper publishes Table 4 for s1-s3 and its own controller and ref. [19].)",
        ]
    paper_events = {}
    if name == "paper" and stem in ("s1", "s2", "s3"):
        try:
            from fuzzynav.app.experiments.paper_fit import paper_results

            for ev in paper_results().get("events", {}).get(stem, []):
                paper_events[int(ev["obstacle"])] = ev
        except Exception:
            paper_events = {}
    lines += ["", "## Safety and saturation", ""] + _safety_lines(result, events)
    lines += ["", "## Events", ""]
    for e in events:
        extra = ""
        ev = paper_events.get(e.obstacle) if e.kind == "closest" else None
        if ev:
            when = f"{ev['time_s']:g} s, " if ev.get("time_s") is not None else ""
            extra = (
                f" (paper: {when}{ev['distance_m']:g} m)"
                if ev.get("distance_m") is not None
                else ""
            )
        lines.append(f"- {e.time_s:.2f} s: {e.text}{extra}")
    static.add_archetype(
        "/meta/summary", rr.TextDocument("\n".join(lines) + "\n", media_type=rr.MediaType.MARKDOWN)
    )


#: What the paper says of its wheel voltages (section 4): s3's saturate at the limit.
PAPER_SATURATES = {"s3": True}


def _safety_lines(result, events) -> list[str]:
    """The safe distance (inside it from when to when, how close; or never, and the
    closest) and the largest |V| beside the limit and the paper's claim."""
    from .style import SAFE_DISTANCE_M

    log = result.log
    lines = []
    breaches = [e for e in events if e.kind == "safe distance"]
    if breaches:
        for e in breaches:
            lines.append(f"- **{e.text}**")
    elif len(log) and len(log.obstacle_ids):
        c = np.asarray(log.clearance_m, dtype=float)
        c = c[np.isfinite(c)]
        closest = f" (closest {float(c.min()):.2f} m)" if c.size else ""
        lines.append(f"- never inside the {SAFE_DISTANCE_M:g} m safe distance{closest}")
    v = np.asarray(log.controller_output_v, dtype=float) if len(log) else np.zeros((0, 2))
    v = v[np.isfinite(v)]
    if v.size:
        limit = float(getattr(result, "voltage_limit_v", 12.0) or 12.0)
        peak = float(np.abs(v).max())
        saturated = peak >= limit
        stem = scenario_stem(result.scenario)
        claim = PAPER_SATURATES.get(stem)
        paper = ""
        if claim is not None:
            agree = "as" if claim == saturated else "unlike"
            paper = f"; {agree} the paper, which says {stem}'s voltages saturate"
        lines.append(
            f"- max |V| before the limit {peak:.2f} V: "
            f"{'saturated at' if saturated else 'within'} the ±{limit:g} V limit{paper}"
        )
    return lines
