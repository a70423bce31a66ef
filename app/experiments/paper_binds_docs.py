"""Two kinds of blocks of docs/paper-controller.md. "What binds": ``scripts/paper_binds.py``'s
experiments on the paper's rule base (``docs/data/paper_binds.json``) and on its Husky
twin (``docs/data/paper_twin_binds.json``). "The selection again":
``scripts/paper_readings_count.py``'s searches (``docs/data/paper_readings_count.json``).
Rendered as tables; :func:`fuzzynav.app.experiments.paper_docs.blocks` places them.
"""

from __future__ import annotations

from fuzzynav.app.experiments.paper_fit import (
    TWIN_CLEARANCE_M,
    TWIN_MAD_FACTOR,
    TWIN_PATH_M,
    TWIN_PHI_RAD,
    select_reading,
)
from fuzzynav.app.published import paper_results

__all__ = ["render_binds", "render_readings_count", "render_twin_binds"]


def render_binds(table: dict) -> str:
    """``scripts/paper_binds.py``'s experiments: what holds the bounds not met."""
    lines = [
        "| experiment | bounds met (of 36) | not met | design rules broken | s3 right wheel max V | s2 / s3 static pass s |",
        "|---|---|---|---|---|---|",
    ]
    found = [(e, e["results"][0]) for e in table["experiments"]]
    for e, r in found:
        runs = r["runs"]
        missed = ", ".join(c["name"] for c in r["checks"] if not c["met"]) or "none"
        broken = (
            ", ".join(sorted({b[1 : b.index("]")] for b in r["design_rules_broken"]})) or "none"
        )
        lines.append(
            f"| {e['label']} | {r['bounds_met']} | {missed} | {broken} "
            f"| {runs['s3']['max_voltage_v'][1]:.2f} "
            f"| {runs['s2']['passes'][0][0]:.1f} / {runs['s3']['passes'][0][0]:.1f} |"
        )

    def met(name: str) -> int:
        return sum(any(c["name"] == name and c["met"] for c in r["checks"]) for _, r in found)

    lines += ["", *_binds_by_bound(found)]
    top = max(r["runs"]["s3"]["max_voltage_v"][1] for _, r in found)
    sizes = "-".join(str(n) for n in sorted({r["evaluations"] for _, r in found}))
    lines += [
        "",
        f"{len(found)} searches of {sizes} candidates; the most "
        f"bounds met: {max(r['bounds_met'] for _, r in found)}. s3's right wheel reaches "
        f"12 V in {met('s3.right_wheel_12V')} of them (at most {top:.2f} V); s3's static "
        f"pass comes after s2's in {met('s3.static_later_than_s2')}.",
    ]
    shipped = table.get("shipped_ceiling")
    if shipped is not None:
        lines += [
            "",
            f"`rules/paper.toml`'s right wheel, on a grid of every input with d_t up to "
            f"{shipped['d_t_max_m']:.2f} m (s3's start-target distance plus the disturbance's "
            f"amplitude): at most {shipped['in_s3']['right_max_v']:.2f} V; with any d_t, "
            f"{shipped['anywhere']['right_max_v']:.2f} V (at d_t = "
            f"{shipped['anywhere']['inputs'][0]:.1f} m, phi_t = "
            f"{shipped['anywhere']['inputs'][2]:.2f} rad: rule 3's VL on both wheels).",
        ]
    if table.get("ceilings") and shipped is not None:
        lines += [
            "",
            "Any vector of the layout's box, with d_t up to the same "
            f"{shipped['d_t_max_m']:.2f} m (differential evolution over the 12 numbers and "
            "the inputs, seeded):",
            "",
        ]
    for c in table.get("ceilings", []):
        sensed = "an obstacle sensed" if c["obstacle_sensed"] else "no obstacle sensed"
        lines.append(
            f"- the layout's box, NONE {c['none']}, {sensed}: "
            f"{c['right_max_v']:.2f} V at d_t = {c['inputs'][0]:.2f} m"
        )
    return "\n".join(lines)


def render_twin_binds(table: dict) -> str:
    """``scripts/paper_binds.py --twin``: each bound the twin misses forced in turn."""
    lines = [
        "| experiment | the forced bound there | twin bounds met (of 36) | not met | slowest arrival s |",
        "|---|---|---|---|---|",
    ]
    for e in table["experiments"]:
        missed = [
            f"{run}.{name}"
            for run, r in e["runs"].items()
            for name, met in r["checks"].items()
            if not met
        ]
        times = [r["time_to_target_s"] for r in e["runs"].values()]
        slowest = "—" if None in times else f"{max(times):.1f}"
        lines.append(
            f"| {e['label']} | {_twin_value(e)} | {e['bounds_met']} "
            f"| {', '.join(missed) or 'none'} | {slowest} |"
        )
    sizes = "-".join(str(n) for n in sorted({e["evaluations"] for e in table["experiments"]}))
    lines += ["", f"{len(table['experiments'])} searches of {sizes} candidates."]
    if table.get("mad_alone"):
        lines += ["", *_mad_alone(table["mad_alone"])]
    return "\n".join(lines)


def _mad_alone(probes: list) -> list[str]:
    """``scripts/paper_binds.py --twin-mad``: s1's MAD searched alone, every other bound
    dropped but the clearance, from each start."""
    bound = probes[0]["mad_bound_m"]
    lines = [
        f"s1's MAD searched alone (bound {bound:.3f} m; every other bound dropped but the "
        "clearance): a safe arrival is s1 reached with 0.25 m kept.",
        "",
        "| start | candidates | safe arrivals ideal / ultrasonic "
        "| smallest MAD of a safe arrival, ideal / ultrasonic m |",
        "|---|---|---|---|",
    ]
    for probe in probes:
        safe, smallest = probe["safe_arrivals"], probe["smallest_safe_mad_m"]
        shown = " / ".join("—" if smallest[p] is None else f"{smallest[p]:.3f}" for p in safe)
        lines.append(
            f"| {probe['label']} | {probe['evaluations']} "
            f"| {' / '.join(str(n) for n in safe.values())} | {shown} |"
        )
    best = {
        p: min((v for q in probes if (v := q["smallest_safe_mad_m"][p]) is not None), default=None)
        for p in probes[0]["safe_arrivals"]
    }
    within = [p for p, v in best.items() if v is not None and v <= bound]
    total = sum(q["evaluations"] for q in probes)
    lines += [
        "",
        f"Of {total} candidates, "
        + (
            f"safe arrivals within the bound in {' and '.join(within)} perception."
            if within
            else "no safe arrival within the bound in either mode; the smallest: "
            + ", ".join(f"{v:.3f} m ({p})" for p, v in best.items() if v is not None)
            + "."
        ),
    ]
    return lines


def _twin_value(experiment: dict) -> str:
    """The forced bound's number in the search's best run, beside the bound."""
    perception, scenario, bound = experiment["forced"].split(".")
    run = experiment["runs"][f"{perception}.{scenario}"]
    mad_bound = TWIN_MAD_FACTOR * paper_results()["table4"][scenario]["mad_m"]
    shown = {
        "clearance": f"clearance {run['min_clearance_m']:.3f} m (>= {TWIN_CLEARANCE_M})",
        "path": f"path {run['path_length_m']:.2f} m (<= {TWIN_PATH_M})",
        "mad": f"MAD {run['mad_m']:.3f} m (<= {mad_bound:.3f})",
        "phi_t": f"phi_t {run['final_phi_t_rad']:+.3f} rad (<= {TWIN_PHI_RAD})",
    }
    return shown[bound]


def _binds_by_bound(found: list) -> list[str]:
    """A row per bound some experiment misses: how many meet it, the most bounds any of
    those meets, and its best residual where it is numeric (the trade-off in numbers)."""
    names = [c["name"] for c in found[0][1]["checks"]]
    missed = [n for n in names if any(not _check(r, n)["met"] for _, r in found)]
    lines = [
        "| bound | experiments meeting it | the most bounds met by one of those | smallest residual / bound |",
        "|---|---|---|---|",
    ]
    for name in missed:
        meeting = [r["bounds_met"] for _, r in found if _check(r, name)["met"]]
        scaled = [_check(r, name)["scaled"] for _, r in found]
        best = min((v for v in scaled if v is not None), default=None)
        lines.append(
            f"| {name} | {len(meeting)} of {len(found)} | {max(meeting) if meeting else '—'} "
            f"| {'—' if best is None else f'{best:.2f}'} |"
        )
    return lines


def _check(result: dict, name: str) -> dict:
    return next(c for c in result["checks"] if c["name"] == name)


def render_readings_count(
    table: dict, readings: dict | None = None, shipped_met: set[str] | None = None
) -> str:
    """``scripts/paper_readings_count.py``: every reading searched again with the done
    bounds counted first, one budget each, and the selection rule applied again (beside
    the readings table's selection, and what its pick trades against ``shipped_met``,
    the names of the bounds the shipped rule base meets)."""
    chosen = select_reading(table["results"])
    lines = [
        "| reading | readings table | stage 1 | stage 2 | worst residual (x its bound) | not met after stage 2 |",
        "|---|---|---|---|---|---|",
    ]
    for r in table["results"]:
        mark = " **(selected)**" if r is chosen else ""
        missed = ", ".join(c["name"] for c in r["stages"][-1]["checks"] if not c["met"])
        stages = " | ".join(str(s["bounds_met"]) for s in r["stages"])
        lines.append(
            f"| {r['reading']}{mark} | {r['table_bounds_met']} | {stages} "
            f"| {r['worst_scaled']:.2f} | {missed or 'none'} |"
        )
    runner_up = max((r for r in table["results"] if r is not chosen), key=lambda r: r["bounds_met"])
    said = f"Selected: {chosen['reading']}"
    if readings is not None:
        before = select_reading(readings["results"])["reading"]
        same = before == chosen["reading"]
        said += ", as in the readings table" if same else f" (the readings table: {before})"
    behind = chosen["bounds_met"] - runner_up["bounds_met"]
    lines += ["", f"{said}; next: {runner_up['reading']}, {behind} bound(s) behind."]
    if shipped_met is not None:  # what the selected reading's search trades otherwise
        shipped = shipped_met
        found = {c["name"] for c in chosen["stages"][-1]["checks"] if c["met"]}
        lines += [
            "",
            f"Its stage 2 ({chosen['bounds_met']} met) beside `rules/paper.toml` "
            f"({len(shipped)} met): met here only: "
            f"{', '.join(sorted(found - shipped)) or 'none'}; met by the rule base only: "
            f"{', '.join(sorted(shipped - found)) or 'none'}.",
        ]
    stages = "; ".join(
        f"stage {k + 1}: CMA-ES 16 x {gens}, sigma {sigma}, seed {seed}"
        for k, (sigma, gens, seed) in enumerate(table["budget"]["stages"])
    )
    lines += [
        "",
        f"Bounds met of 36, judged on the pymunk engine at 0.02 s. Each reading from its "
        f"readings-table vector, the done bounds counted first (`--force "
        f"{' --force '.join(table['budget']['force'])}`) at 0.02 s; {stages}.",
    ]
    return "\n".join(lines)
