"""What docs/paper-controller.md states about the shipped paper controller, computed.

Every number the page gives about the shipped rule bases comes from here:
:func:`shipped_runs` runs s1-s3 the way ``fuzzynav run sN --controller paper`` does (the
paper's geometry with ``rules/paper.toml``; the Husky's with its twin
``rules/paper_husky.toml``, ideal and ultrasonic), :func:`bound_checks` holds them to
the done bounds, and :func:`render` writes the page's generated blocks (between
``<!-- generated:NAME -->`` and ``<!-- /generated:NAME -->``) from that data, from the
readings table (``docs/data/paper_readings.json``) and from the held-out layouts
(``docs/data/paper_generalise.json``). ``scripts/paper_check.py`` writes
``docs/data/paper_controller.json`` and the page; ``tests/test_paper_docs.py`` runs
them again and fails when the page, the data or the rule bases drifted apart.
"""

from __future__ import annotations

import re

import numpy as np

from fuzzynav.app.experiments.paper_binds_docs import (
    render_binds,
    render_readings_count,
    render_twin_binds,
)
from fuzzynav.app.experiments.paper_fit import (
    DISTURBANCE_DELAY_S,
    DISTURBANCE_WIDENING_M,
    MIN_APPROACH_SPEED_RATIO,
    MIN_RIGHT_OFFSET_M,
    SATURATION_V,
    SHIPPED_READING,
    TWIN_CLEARANCE_M,
    TWIN_LINE_OFFSET_M,
    TWIN_MAD_FACTOR,
    TWIN_MEDIAN_PASS_M,
    TWIN_PATH_M,
    TWIN_PHI_RAD,
    TWIN_TOP_VOLTAGE_V,
    measure,
)
from fuzzynav.app.published import SCENARIOS, paper_results

HUSKY_PERCEPTION = ("ideal", "ultrasonic")
# the done bounds (paper geometry) and the twin's (Husky geometry)
PATH_BOUND, TABLE4_BOUND = 0.03, 0.25
EVENT_TIME_BOUND, EVENT_DISTANCE_BOUND_M = 0.20, 0.15
FINAL_PHI_BOUND_RAD, MAX_JUMPS = 0.1, 2
KEYS = (
    "reached",
    "collided",
    "time_to_target_s",
    "path_length_m",
    "mad_m",
    "rmse_m",
    "min_center_distance_m",
    "min_clearance_m",
    "passes",
    "final_phi_t_rad",
    "max_voltage_v",
    "largest_right_offset_m",
    "chatter_steps",
    "approach_speed_ratio",
    "horizon_s",
    "largest_line_offset_m",
    "pass_clearances_m",
)


def _run(name: str, geometry: str, perception: str) -> dict:
    from fuzzynav.app.runs import run_scenario

    result = run_scenario(name, "paper", perception=perception, geometry=geometry)
    measured = measure(result)
    if geometry == "paper":  # Table 4's MAD and RMSE over the shipped reading's horizon
        measured = SHIPPED_READING.scored(measured)
    return {k: _plain(measured[k]) for k in KEYS}


def _plain(value):
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def shipped_runs() -> dict:
    """s1-s3 with the shipped rule bases: ``{"paper": {s: run}, "husky": {perception:
    {s: run}}}``, each run the measures of :func:`app.experiments.paper_fit.measure`."""
    return {
        "paper": {name: _run(name, "paper", "ideal") for name in SCENARIOS},
        "husky": {
            perception: {name: _run(name, "husky", perception) for name in SCENARIOS}
            for perception in HUSKY_PERCEPTION
        },
    }


def bound_checks(runs: dict, paper: dict | None = None) -> list[dict]:
    """The done bounds on paper-geometry runs ``{s: run}``: name, met, and for a
    numeric bound the residual in units of its bound (|error| / bound)."""
    paper = paper or paper_results()
    out = []

    def add(name, met, scaled=None):
        out.append({"name": name, "met": bool(met), "scaled": scaled})

    for name, m in runs.items():
        table = paper["table4"][name]
        add(f"{name}.reached", m["reached"] and not m["collided"])
        path = abs(m["path_length_m"] / table["path_length_m"] - 1) / PATH_BOUND
        add(f"{name}.path", path <= 1, path)
        for key in ("mad_m", "rmse_m", "min_center_distance_m"):
            r = abs(m[key] / table[key] - 1) / TABLE4_BOUND
            add(f"{name}.{key}", r <= 1, r)
        for event in paper["events"].get(name, []):
            t, d = m["passes"][event["obstacle"]]
            if "time_s" in event:
                r = abs(t / event["time_s"] - 1) / EVENT_TIME_BOUND
                add(f"{name}.pass{event['obstacle']}.time", r <= 1, r)
            r = abs(d - event["distance_m"]) / EVENT_DISTANCE_BOUND_M
            add(f"{name}.pass{event['obstacle']}.distance", r <= 1, r)
        r = abs(m["final_phi_t_rad"]) / FINAL_PHI_BOUND_RAD
        add(f"{name}.final_phi_t", r <= 1, r)
        add(f"{name}.no_chatter", m["chatter_steps"] <= MAX_JUMPS)
        add(f"{name}.no_crawl", m["approach_speed_ratio"] >= MIN_APPROACH_SPEED_RATIO)
    s1 = [d for _, d in runs["s1"]["passes"]]
    add("s1.first_passed_farthest", s1[0] > max(s1[1:]))
    add("s1.from_the_right", runs["s1"]["largest_right_offset_m"] >= MIN_RIGHT_OFFSET_M)
    (t2, d2), (t3, d3) = runs["s2"]["passes"][0], runs["s3"]["passes"][0]
    add("s3.static_pass_delayed", DISTURBANCE_DELAY_S[0] <= t3 - t2 <= DISTURBANCE_DELAY_S[1])
    add("s3.static_pass_wider", DISTURBANCE_WIDENING_M[0] <= d3 - d2 <= DISTURBANCE_WIDENING_M[1])
    add("s3.mad_at_least_s2", runs["s3"]["mad_m"] >= runs["s2"]["mad_m"])
    return out


def twin_checks(run: dict, name: str, paper: dict | None = None) -> dict[str, bool]:
    """The Husky twin's bounds on one run: where it arrives and how it drives there."""
    paper = paper or paper_results()
    reached = run["reached"] and not run["collided"]
    return {
        "reached": reached,
        "clearance": reached and run["min_clearance_m"] >= TWIN_CLEARANCE_M,
        "path": reached and run["path_length_m"] <= TWIN_PATH_M,
        "mad": reached and run["mad_m"] <= TWIN_MAD_FACTOR * paper["table4"][name]["mad_m"],
        "phi_t": reached and abs(run["final_phi_t_rad"]) <= TWIN_PHI_RAD,
        "no_chatter": run["chatter_steps"] <= MAX_JUMPS,
        "close_passes": reached
        and float(np.median(run["pass_clearances_m"])) <= TWIN_MEDIAN_PASS_M,
        "near_the_line": reached and run["largest_line_offset_m"] <= TWIN_LINE_OFFSET_M,
        "top_voltage": max(run["max_voltage_v"]) >= TWIN_TOP_VOLTAGE_V,
        "no_crawl": reached and run["approach_speed_ratio"] >= MIN_APPROACH_SPEED_RATIO,
    }


# -- the page's generated blocks --------------------------------------------------------


def _pct(ours, paper):
    return f"{ours:.3f} ({paper:g}; {100 * (ours / paper - 1):+.1f} %)"


def render_paper(data: dict) -> str:
    paper = paper_results()
    runs = data["paper"]
    lines = [
        "| | path m | MAD m | RMSE m | min centre distance m | time s | final phi_t rad | max V (left, right) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, m in runs.items():
        t4 = paper["table4"][name]
        if not m["reached"]:
            lines.append(f"| {name} | {'collided' if m['collided'] else 'timeout'} |||||||")
            continue
        lines.append(
            f"| {name} | {_pct(m['path_length_m'], t4['path_length_m'])} "
            f"| {_pct(m['mad_m'], t4['mad_m'])} | {_pct(m['rmse_m'], t4['rmse_m'])} "
            f"| {_pct(m['min_center_distance_m'], t4['min_center_distance_m'])} "
            f"| {m['time_to_target_s']:.1f} | {m['final_phi_t_rad']:+.3f} "
            f"| {m['max_voltage_v'][0]:.2f}, {m['max_voltage_v'][1]:.2f} |"
        )
    lines += ["", "| event | paper | ours | difference |", "|---|---|---|---|"]
    for name, m in runs.items():
        for event in paper["events"].get(name, []):
            t, d = m["passes"][event["obstacle"]]
            label = f"{name} obstacle {event['obstacle'] + 1}"
            if "time_s" in event:
                lines.append(
                    f"| {label} passed at | {event['time_s']:g} s | {t:.1f} s "
                    f"| {t - event['time_s']:+.1f} s ({100 * (t / event['time_s'] - 1):+.1f} %) |"
                )
            lines.append(
                f"| {label} passed by | {event['distance_m']:g} m | {d:.3f} m "
                f"| {d - event['distance_m']:+.3f} m |"
            )
    checks = bound_checks(runs, paper)
    met = sum(c["met"] for c in checks)
    failed = [c for c in checks if not c["met"]]
    s1 = [d for _, d in runs["s1"]["passes"]]
    (t2, d2), (t3, d3) = runs["s2"]["passes"][0], runs["s3"]["passes"][0]
    ratios = ", ".join(f"{runs[s]['approach_speed_ratio']:.2f}" for s in runs)
    lines += [
        "",
        f"Story: s1's obstacles passed at {', '.join(f'{d:.2f}' for d in s1)} m, the robot "
        f"at most {runs['s1']['largest_right_offset_m']:.2f} m right of the start-target line; "
        f"s3's static obstacle passed {t3 - t2:+.1f} s and {d3 - d2:+.2f} m from s2's "
        f"(the paper: +4 s, +0.25 m); s3's right wheel at most "
        f"{runs['s3']['max_voltage_v'][1]:.2f} V (the paper's reaches the 12 V saturation: "
        f"{'reached' if runs['s3']['max_voltage_v'][1] >= SATURATION_V - 0.01 else 'not reached'}"
        f"). Pace: the mean speed over the last 2 m is {ratios} times the run's median speed "
        "in s1, s2, s3 (the no-crawl bound: at least 0.5).",
        "",
        f"**The done bounds: {met} of {len(checks)} met.** Not met: "
        + (
            "; ".join(
                f"{c['name']}" + (f" ({c['scaled']:.2f} x its bound)" if c["scaled"] else "")
                for c in failed
            )
            or "none"
        )
        + ".",
    ]
    narrow = [c for c in checks if c["met"] and c["scaled"] is not None and c["scaled"] > NARROW]
    if narrow:
        lines[-1] += " Met within 5 % of the bound's edge: " + ", ".join(
            f"{c['name']} ({c['scaled']:.3f} x)" for c in narrow
        )
        lines[-1] += "."
    return "\n".join(lines)


#: A bound met with less than 5 % of its tolerance to spare is said to be met narrowly.
NARROW = 0.95


def render_twin(data: dict) -> str:
    paper = paper_results()
    lines = [
        "| perception | scenario | outcome | path m (<= 13) | MAD m (<= 2 x paper) | clearance m (>= 0.25) | median pass clearance m (<= 0.7) | off the line m (<= 1.2) | top V (>= 9) | last 2 m speed / median (>= 0.5) | phi_t at arrival rad (<= 0.3) | time s | jumps (<= 2) | bounds |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    total = met = 0
    for perception, runs in data["husky"].items():
        for name, m in runs.items():
            checks = twin_checks(m, name, paper)
            total += len(checks)
            met += sum(checks.values())
            outcome = "reached" if m["reached"] else "collided" if m["collided"] else "timeout"
            time_s = "—" if m["time_to_target_s"] is None else f"{m['time_to_target_s']:.1f}"
            lines.append(
                f"| {perception} | {name} | {outcome} | {m['path_length_m']:.2f} "
                f"| {m['mad_m']:.3f} ({2 * paper['table4'][name]['mad_m']:.3f}) "
                f"| {m['min_clearance_m']:.3f} | {float(np.median(m['pass_clearances_m'])):.3f} "
                f"| {m['largest_line_offset_m']:.2f} | {max(m['max_voltage_v']):.2f} "
                f"| {m['approach_speed_ratio']:.2f} | {m['final_phi_t_rad']:+.3f} | {time_s} "
                f"| {m['chatter_steps']} | {sum(checks.values())} of {len(checks)} |"
            )
    lines += ["", f"**The twin's bounds: {met} of {total} met.**"]
    narrow = [
        f"{perception} {name}'s clearance ({m['min_clearance_m']:.5f} m)"
        for perception, runs in data["husky"].items()
        for name, m in runs.items()
        if TWIN_CLEARANCE_M <= m["min_clearance_m"] < TWIN_CLEARANCE_M / NARROW
    ]
    if narrow:
        lines[-1] += " Met within 5 % of the bound: " + ", ".join(narrow) + "."
    return "\n".join(lines)


def render_readings(table: dict) -> str:
    from fuzzynav.app.experiments.paper_fit import select_reading

    chosen = select_reading(table["results"])
    lines = [
        "| reading | bounds met (of 36) | worst residual (x its bound) | fit cost | s1 passes m | s2 / s3 static pass s | s3 right wheel max V |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in table["results"]:
        runs = r["runs"]
        passes = ", ".join(f"{d:.2f}" for _, d in runs["s1"]["passes"])
        mark = " **(selected)**" if r is chosen else ""
        lines.append(
            f"| {r['reading']}{mark} | {r['bounds_met']} | {r['worst_scaled']:.2f} "
            f"| {r['fit_cost']:.1f} | {passes} "
            f"| {runs['s2']['passes'][0][0]:.1f} / {runs['s3']['passes'][0][0]:.1f} "
            f"| {runs['s3']['max_voltage_v'][1]:.2f} |"
        )
    budget = table["budget"]
    lines += [
        "",
        f"Budget per reading: {budget['screen']} seeded uniform draws plus the hand layout, "
        f"then CMA-ES {budget['popsize']} x {budget['maxiter']} (seed {budget['seed']}, "
        f"sigma {budget['sigma']}) at {budget['dt']} s; judged on the pymunk engine at 0.02 s.",
    ]
    return "\n".join(lines)


def render_behaviour_readings(table: dict) -> str:
    """The readings table made again with the behaviour among the done bounds
    (``docs/data/paper_readings_behaviour.json``): every row, the selected one marked."""
    from fuzzynav.app.experiments.paper_fit import select_reading

    chosen = select_reading(table["results"])
    lines = [
        "| reading | design rules | bounds met | worst residual (x its bound) | arrived "
        "| s1 passes m | s2 / s3 static pass s, m | last 2 m speed / median s1, s2, s3 "
        "| MAD s1, s2, s3 m | s3 right wheel max V |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table["results"]:
        runs = r["runs"]
        passes = ", ".join(f"{d:.2f}" for _, d in runs["s1"]["passes"])
        (t2, d2), (t3, d3) = runs["s2"]["passes"][0], runs["s3"]["passes"][0]
        ratios = ", ".join(f"{runs[s]['approach_speed_ratio']:.2f}" for s in SCENARIOS)
        mads = ", ".join(f"{runs[s]['mad_m']:.3f}" for s in SCENARIOS)
        arrived = ", ".join(s for s in SCENARIOS if runs[s]["reached"]) or "none"
        kept = "kept" if not r["design_rules_broken"] else f"{len(r['design_rules_broken'])} broken"
        mark = " **(selected)**" if r is chosen else ""
        lines.append(
            f"| {r['reading']}{mark} | {kept} | {r['bounds_met']} of {r['bounds']} "
            f"| {r['worst_scaled']:.2f} | {arrived} | {passes} | {t2:.1f}, {d2:.2f} / {t3:.1f}, {d3:.2f} "
            f"| {ratios} | {mads} | {runs['s3']['max_voltage_v'][1]:.2f} |"
        )
    budget = table["budget"]
    lines += [
        "",
        f"Budget per reading: {budget['screen']} seeded uniform draws plus the hand layout, "
        f"then CMA-ES {budget['popsize']} x {budget['maxiter']} (seed {budget['seed']}, "
        f"sigma {budget['sigma']}) at {budget['dt']} s, forced: {', '.join(budget['force'])}; "
        "judged on the pymunk engine at 0.02 s.",
    ]
    return "\n".join(lines)


def render_generalise(table: dict) -> str:
    lines = [
        "| controller | rule base | geometry | perception | reached safely (budget) | reached safely (4x budget) | reached (budget) | collided (budget) | failures within the budget, by what they do with 4x |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table["rows"]:
        if r["controller"] == "fuzzynav":
            lines.append(
                f"| fuzzynav | — | {r['geometry']} | {r['perception']} "
                f"| {r['reached_safely_pct']:.1f} % | (not run) | {r['reached_pct']:.1f} % | | |"
            )
            continue
        words = {"collided": "collide", "slow (arrives within 4x)": "arrive later"}
        kinds = ", ".join(
            f"{words.get(k, 'never arrive')} {v}" for k, v in r["failures_within_budget"].items()
        )
        lines.append(
            f"| paper | {r['rule_base']} | {r['geometry']} | {r['perception']} "
            f"| {r['reached_safely_pct']:.1f} % | {r['reached_safely_4x_pct']:.1f} % "
            f"| {r['reached_pct']:.1f} % | {r['within_budget']['collided']} | {kinds} |"
        )
    lines += [
        "",
        f"Seed {table['seed']} (held out: no fit used it), family {table['family']}, "
        f"{table['rows'][0]['n']} layouts; 'reached safely': the target reached with at "
        "least 0.25 m between the robot (its footprint in the Husky geometry) and every "
        "obstacle.",
    ]
    return "\n".join(lines)


PROFILE_STEP = 0.10


def profiles() -> dict:
    """Each of the shipped paper rule base's 12 numbers moved by -10 % and +10 % (clipped
    to the layout's bounds): the done bounds met and the fit's cost (batch engine, 0.02 s)."""
    import numpy as np

    from fuzzynav.app.experiments.batch_runs import fit_measures
    from fuzzynav.app.experiments.paper_fit import FitCost, read_fitted
    from fuzzynav.controller.paper import PAPER_RULES
    from fuzzynav.controller.paper_design import PaperDesignTunable

    tunable = PaperDesignTunable()
    names = tunable.parameter_names()
    lo, hi = np.array(tunable.bounds()).T
    x = read_fitted(PAPER_RULES)
    vectors = [x]
    for k in range(len(names)):
        for factor in (1.0 - PROFILE_STEP, 1.0 + PROFILE_STEP):
            v = x.copy()
            v[k] = float(np.clip(x[k] * factor, lo[k], hi[k]))
            vectors.append(v)
    fit = FitCost(0.02, stall_s=None)
    measured = fit_measures(fit, SCENARIOS, vectors, "paper", "ideal")

    def judged(k):
        runs = {m["scenario"]: m for m in measured[k]}
        return {
            "bounds_met": sum(c["met"] for c in bound_checks(runs)),
            "cost": round(fit.combine([measured[k]]), 3),
        }

    rows = []
    for k, name in enumerate(names):
        row = {"name": name, "fitted": float(x[k])}
        for side, index in (("minus_10pct", 1 + 2 * k), ("plus_10pct", 2 + 2 * k)):
            value = float(vectors[index][k])
            row[side] = {
                "value": value,
                "clipped": not np.isclose(
                    value, x[k] * (1 + (-1 if side[0] == "m" else 1) * PROFILE_STEP)
                ),
                **judged(index),
            }
        rows.append(row)
    return {"rules": PAPER_RULES.name, "fitted": judged(0), "profiles": rows}


def render_profiles(table: dict) -> str:
    base = table["fitted"]
    lines = [
        f"The shipped vector (header's 6 digits) meets {base['bounds_met']} bounds at a fit "
        f"cost of {base['cost']:.1f}.",
        "",
        "| number | fitted | -10 %: bounds met, cost | +10 %: bounds met, cost |",
        "|---|---|---|---|",
    ]
    for row in table["profiles"]:
        cells = []
        for side in ("minus_10pct", "plus_10pct"):
            r = row[side]
            cells.append(
                f"{r['bounds_met']}, {r['cost']:.1f}" + (" (clipped)" if r["clipped"] else "")
            )
        lines.append(f"| `{row['name']}` | {row['fitted']:.4g} | {cells[0]} | {cells[1]} |")
    free = [
        f"`{row['name']}`"
        for row in table["profiles"]
        if min(row["minus_10pct"]["bounds_met"], row["plus_10pct"]["bounds_met"])
        >= base["bounds_met"] - 1
    ]
    lines += [
        "",
        "Left free by the paper's results (both moves lose at most one bound): "
        + (", ".join(free) or "none")
        + "; every other number is pinned (a 10 % move loses two bounds or more).",
    ]
    return "\n".join(lines)


def render_readme_headline(data: dict, generalise: dict | None) -> str:
    """The README's headline paragraph on the paper's controller, from the same data."""
    paper = paper_results()
    runs = data["paper"]
    checks = bound_checks(runs, paper)
    met = sum(c["met"] for c in checks)
    pct = {
        name: {
            key: 100 * (m[key] / paper["table4"][name][key] - 1)
            for key in ("path_length_m", "mad_m", "rmse_m", "min_center_distance_m")
        }
        for name, m in runs.items()
    }
    worst = {key: max(abs(pct[n][key]) for n in pct) for key in pct["s1"]}
    twin_total = twin_met = twin_reached = 0
    for twin_runs in data["husky"].values():
        for name, m in twin_runs.items():
            c = twin_checks(m, name, paper)
            twin_total += len(c)
            twin_met += sum(c.values())
            twin_reached += c["reached"]
    s1 = ", ".join(f"{d:.2f}" for _, d in runs["s1"]["passes"])
    text = (
        "**The paper's controller, in the paper's own world.** Table 1's 40 rules with "
        "membership functions drawn from 12 numbers under design rules a reviewer would ask "
        "of a hand-drawn controller (`controller/design_rules.py`), fitted in the paper's "
        "geometry (a point robot, `--geometry paper`) under the reading of the text its "
        "results and its robot's behaviour support, chosen by a rule written down before "
        "the fits: a start facing +x, ideal perception of a 60-degree cone ahead, and Table "
        "1's NONE as the text has it (the goal rules hold only while no obstacle is sensed). "
        f"It reaches s1-s3 and meets **{met} of the {len(checks)} done bounds**, among them "
        "no crawl to the target: Table 4's MAD, RMSE "
        f"and minimum distance within {max(worst['mad_m'], worst['rmse_m'], worst['min_center_distance_m']):.0f} % "
        f"(paths {worst['path_length_m']:.1f} % short at most), s1's obstacles passed at "
        f"{s1} m (the paper: 0.46, 0.29, 0.26) coming from the right of the line, the "
        "target bearing settling to "
        f"{max(abs(m['final_phi_t_rad']) for m in runs.values()):.3f} rad; s3's right wheel "
        f"stays at {runs['s3']['max_voltage_v'][1]:.1f} V (the paper: clipped at 12 V). "
        "The Husky's footprint (the default world, the viewer's) is driven by its twin, "
        "`rules/paper_husky.toml`, fitted for that body: it reaches "
        f"{twin_reached} of s1-s3's six runs (ideal and sonars) and meets {twin_met} of its "
        f"{twin_total} bounds."
    )
    if generalise is not None:
        rows = {
            (r["geometry"], r["perception"].split(",")[0]): r
            for r in generalise["rows"]
            if r["controller"] == "paper"
        }
        own, twin = rows.get(("paper", "ideal")), rows.get(("husky", "ideal"))
        if own is not None and twin is not None:
            text += (
                f" On {twin['n']} held-out random layouts the paper's rule base reaches "
                f"{own['reached_safely_pct']:.0f} % safely within their time budget in its own "
                f"geometry ({own['reached_safely_4x_pct']:.0f} % with four times it), the "
                f"twin {twin['reached_safely_pct']:.0f} % on the Husky's body "
                f"({twin['reached_safely_4x_pct']:.0f} %)."
            )
    return text + (
        " Every residual, the readings table and what binds: "
        "[docs/paper-controller.md](docs/paper-controller.md); every controller beside the "
        "paper's numbers: [docs/table4.md](docs/table4.md)."
    )


def render_readme_compare(compare: dict) -> str:
    """The README's table of ``fuzzynav compare`` sweeps (ideal and ultrasonic)."""
    by = {(r["controller"], r["perception"]): r for c in compare.values() for r in c["sweeps"]}
    names = {"baseline": "baseline (stand-in)", "p": "p (obstacle-blind)"}
    lines = [
        "| controller | ideal: success / safe | ultrasonic: success / safe |",
        "|---|---|---|",
    ]
    for controller in compare["ideal"]["controllers"]:
        cells = []
        for perception in ("ideal", "ultrasonic"):
            r = by[(controller, perception)]
            cell = f"{100 * r['success_rate']:.0f} % / {100 * r['safe_success_rate']:.0f} %"
            cells.append(f"**{cell}**" if controller == "fuzzynav" else cell)
        lines.append(f"| {names.get(controller, controller)} | {cells[0]} | {cells[1]} |")
    n = compare["ideal"]["sweeps"][0]["n"]
    seed = compare["ideal"]["sweeps"][0]["seed"]
    lines += [
        "",
        f"({n} standard layouts of held-out seed {seed}, Husky geometry; `paper` is its "
        "twin there.)",
    ]
    return "\n".join(lines)


LAYOUT_MEANINGS = {
    "d_t.c0": "where VS stops holding 1 (m)",
    "d_t.top": "where VL starts holding 1 (m)",
    "d_t.r": "growth of each d_t spacing over the one before",
    "d_o.near": "where near stops holding 1 (m)",
    "d_o.far": "where far starts holding 1 (m; medium half-way)",
    "phi_t.vp": "where VP holds 1 (VN at -vp; rad), in the upper half of [0, 2 pi]",
    "phi_t.q": "P's centre at vp / (1 + q) (N mirrored)",
    "phi_o.vp": "the same for the obstacle bearing (rad), in the upper half of [0, pi]",
    "phi_o.q": "the same for the obstacle bearing",
    "v.e0": "where the wheels' VS holds 1 (V; the slow wheel of a turn)",
    "v.top": "where VL starts holding 1 (V)",
    "v.r": "growth of the voltage spacing from one term to the next",
}


def render_layout() -> str:
    """The 12 numbers, their meaning, bounds and the shipped values (both rule bases)."""
    from fuzzynav.app.experiments.tuning import read_vector
    from fuzzynav.controller.paper import RULES_BY_GEOMETRY
    from fuzzynav.controller.paper_design import DESIGN_PARAMETERS

    names = [p[0] for p in DESIGN_PARAMETERS]
    shipped = {g: read_vector(path, names) for g, path in RULES_BY_GEOMETRY.items()}
    lines = [
        "| number | meaning | bounds | paper.toml | paper_husky.toml |",
        "|---|---|---|---|---|",
    ]
    for k, (name, lo, hi, _) in enumerate(DESIGN_PARAMETERS):
        lines.append(
            f"| `{name}` | {LAYOUT_MEANINGS[name]} | {lo:g} .. {hi:g} "
            f"| {shipped['paper'][k]:.4g} | {shipped['husky'][k]:.4g} |"
        )
    for geometry, file in (("paper", "paper.toml"), ("husky", "paper_husky.toml")):
        edges = [
            f"`{name}` at its {'lower' if abs(v - lo) <= abs(v - hi) else 'upper'} bound"
            for (name, lo, hi, _), v in zip(DESIGN_PARAMETERS, shipped[geometry])
            if min(abs(v - lo), abs(v - hi)) <= 0.01 * (hi - lo)
        ]
        lines += ["", f"On the box's edge (within 1 % of its width) in `{file}`: "]
        lines[-1] += ", ".join(edges) + "." if edges else "none."
    return "\n".join(lines)


def blocks(
    data: dict,
    readings: dict,
    generalise: dict | None,
    profiles_table: dict | None = None,
    binds: dict | None = None,
    twin_binds: dict | None = None,
    readings_count: dict | None = None,
    behaviour_readings: dict | None = None,
) -> dict[str, str]:
    out = {
        "layout": render_layout(),
        "paper-results": render_paper(data),
        "twin-results": render_twin(data),
        "readings-table": render_readings(readings),
    }
    if behaviour_readings is not None:
        out["readings-behaviour"] = render_behaviour_readings(behaviour_readings)
    if generalise is not None:
        out["generalise"] = render_generalise(generalise)
    if profiles_table is not None:
        out["profiles"] = render_profiles(profiles_table)
    if binds is not None:
        out["binds"] = render_binds(binds)
    if twin_binds is not None:
        out["twin-binds"] = render_twin_binds(twin_binds)
    if readings_count is not None:  # history: the rule bases it compared are in git
        out["readings-count"] = render_readings_count(readings_count, readings)
    return out


def readme_blocks(data: dict, generalise: dict | None, compare: dict | None) -> dict[str, str]:
    out = {"readme-headline": render_readme_headline(data, generalise)}
    if compare is not None:
        out["readme-compare"] = render_readme_compare(compare)
    return out


def generated(text: str) -> dict[str, str]:
    """The generated blocks of a page, by name."""
    return {
        m.group(1): m.group(2).strip("\n")
        for m in re.finditer(
            r"<!-- generated:([\w-]+) -->\n(.*?)<!-- /generated:\1 -->", text, re.S
        )
    }


def with_blocks(text: str, new: dict[str, str]) -> str:
    """``text`` with each generated block replaced by ``new``'s (a missing one is an error)."""
    for name, body in new.items():
        pattern = re.compile(rf"(<!-- generated:{name} -->\n).*?(<!-- /generated:{name} -->)", re.S)
        if not pattern.search(text):
            raise ValueError(f"the page has no generated block {name!r}")
        text = pattern.sub(lambda m, b=body: m.group(1) + b + "\n" + m.group(2), text)
    return text
