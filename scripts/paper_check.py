"""The shipped paper controller against the paper and the issue's bounds, as tables.

For each start heading (the scenarios' pi/4 and the other reading, 0), runs s1-s3 at
the loop's 0.02 s in the paper's geometry (ideal perception) and in the Husky's (ideal
and ultrasonic), and prints Markdown tables: Table 4 and the events with their
residuals, the story checks, and the Husky bounds. docs/paper-controller.md quotes
them. About 15 runs a heading (a minute on a free core).

    .venv/bin/python scripts/paper_check.py [--rules PATH] [--headings 0.785398,0]
"""

from __future__ import annotations

import argparse
import math

from fuzzynav.app.experiments.paper_fit import measure, paper_results
from fuzzynav.controller.fis_controller import FisController
from fuzzynav.controller.paper import PAPER_RULES
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

SCENARIOS = ("s1", "s2", "s3")


def run(system, name, heading_rad, geometry, perception):
    scenario = load_scenario(name).replace(heading_rad=heading_rad)
    sim = Simulation(
        scenario,
        FisController(system, name="paper"),
        perception=perception,
        geometry=geometry,
        seed=0,
    )
    result = sim.run()
    return result, measure(result)


def pct(ours, paper):
    return f"{ours:.3f} ({paper:g}; {100 * (ours / paper - 1):+.1f} %)"


def paper_tables(system, heading_rad, paper):
    print(f"\n#### Paper geometry, start heading {heading_rad:.4f} rad\n")
    print("| | path m | MAD m | RMSE m | min centre distance m | time s | final phi_t rad |")
    print("|---|---|---|---|---|---|---|")
    runs = {}
    for name in SCENARIOS:
        result, m = run(system, name, heading_rad, "paper", "ideal")
        runs[name] = m
        t4 = paper["table4"][name]
        if not m["reached"]:
            print(f"| {name} | {result.outcome} | | | | | |")
            continue
        print(
            f"| {name} | {pct(m['path_length_m'], t4['path_length_m'])} "
            f"| {pct(m['mad_m'], t4['mad_m'])} | {pct(m['rmse_m'], t4['rmse_m'])} "
            f"| {pct(m['min_center_distance_m'], t4['min_center_distance_m'])} "
            f"| {m['time_to_target_s']:.1f} | {m['final_phi_t_rad']:+.3f} |"
        )
    print("\n| event | paper | ours | difference |")
    print("|---|---|---|---|")
    for name in SCENARIOS:
        for event in paper["events"].get(name, []):
            t, d = runs[name]["passes"][event["obstacle"]]
            label = f"{name} obstacle {event['obstacle'] + 1}"
            if "time_s" in event:
                print(
                    f"| {label} passed at | {event['time_s']:g} s | {t:.1f} s "
                    f"| {t - event['time_s']:+.1f} s ({100 * (t / event['time_s'] - 1):+.1f} %) |"
                )
            print(
                f"| {label} passed by | {event['distance_m']:g} m | {d:.3f} m "
                f"| {d - event['distance_m']:+.3f} m |"
            )
    s1 = [p[1] for p in runs["s1"]["passes"]]
    print(
        f"\nStory: s1's first obstacle passed farthest: {s1[0] > max(s1[1:])} "
        f"({', '.join(f'{d:.2f}' for d in s1)} m); s3's static pass later than s2's: "
        f"{runs['s3']['passes'][0][0] > runs['s2']['passes'][0][0]} "
        f"({runs['s3']['passes'][0][0]:.1f} s against {runs['s2']['passes'][0][0]:.1f} s); "
        f"largest wheel voltage in s3: {max(runs['s3']['max_voltage_v']):.2f} V (right "
        f"{runs['s3']['max_voltage_v'][1]:.2f} V)."
    )


def husky_tables(system, heading_rad, paper):
    print(f"\n#### Husky geometry, start heading {heading_rad:.4f} rad\n")
    print(
        "| perception | scenario | outcome | path m (<= 13) | MAD m (<= 2 x paper) "
        "| clearance m (>= 0.25) | phi_t at arrival rad (<= 0.3) | time s | jumps |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for perception in ("ideal", "ultrasonic"):
        for name in SCENARIOS:
            result, m = run(system, name, heading_rad, "husky", perception)
            limit = 2 * paper["table4"][name]["mad_m"]
            time_s = m["time_to_target_s"]
            print(
                f"| {perception} | {name} | {result.outcome} | {m['path_length_m']:.2f} "
                f"| {m['mad_m']:.3f} ({limit:.3f}) | {m['min_clearance_m']:.3f} "
                f"| {m['final_phi_t_rad']:+.3f} | {'—' if time_s is None else f'{time_s:.1f}'} "
                f"| {m['chatter_steps']} |"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rules", default=str(PAPER_RULES))
    parser.add_argument("--headings", default=f"{math.pi / 4!r},0.0")
    parser.add_argument("--geometries", default="paper,husky")
    args = parser.parse_args()
    system = read_toml(args.rules)
    paper = paper_results()
    for heading in (float(h) for h in args.headings.split(",")):
        if "paper" in args.geometries:
            paper_tables(system, heading, paper)
        if "husky" in args.geometries:
            husky_tables(system, heading, paper)


if __name__ == "__main__":
    main()
