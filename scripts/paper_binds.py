"""What binds the paper controller's fit (issue 35: "show it with numbers").

Eight of issue 35's 36 done bounds are not met by ``rules/paper.toml``. This script asks,
with the readings table's own budget (``scripts/paper_readings.py``: 160 seeded draws,
then CMA-ES 16 x 30, seed 1, at 0.05 s; judged on the pymunk engine at 0.02 s) and the
selected reading (heading 0, the text's NONE, the front half-plane), what holds them:

* **the design rules?** The layout's box widened past ``span`` (d_t's VL may start
  below the upper half of its universe) and past ``rates`` (steeper growth of d_t's and
  the wheels' spacings); the vectors found are checked against every design rule.
* **the box's edges?** The bounds-first stages rest on edges of the box (the ``width``
  rule's on phi_o, the layout's own on d_t's growth and the slow wheel's VS): the last
  experiment widens them, from stage 7's rule base (``STAGE7``).
* **each numeric bound still missed?** (s1's and s2's paths, s1's first pass, s2's
  minimum distance) forced in turn at ten times the others' weight, bounds first, from
  stage 7's rule base in the widened box: what meeting it costs the others.
* **the fit's own weights?** The 12 V term of the fit's cost is flat below 7 V (a capped
  hinge), and so is the static-later term past 10 s; ``--force`` adds an uncapped cost
  for each in turn, from the hand layout and from the shipped vector: what meeting
  them would cost the other bounds.

Writes ``docs/data/paper_binds.json``; ``scripts/paper_check.py`` renders it into
docs/paper-controller.md ("What binds").

    .venv/bin/python scripts/paper_binds.py      (about 25 minutes on one core)
    .venv/bin/python scripts/paper_binds.py --ceiling   (then: the 12 V ceilings alone)
    .venv/bin/python scripts/paper_binds.py --ceiling --shipped-only   (a new rule base's)
    .venv/bin/python scripts/paper_binds.py --only 9   (one experiment again, by index)
    .venv/bin/python scripts/paper_binds.py --twin   (the Husky twin's, about 15 minutes)
    .venv/bin/python scripts/paper_binds.py --twin-mad   (s1's MAD alone, about 25 minutes)

History: this script made data for docs/paper-controller.md's history section (the rule
bases shipped until 2026-12-06). The layout's angle numbers, the done bounds and
``paper_readings.py``'s readings have changed since, so it reproduces those data only
from the commit that made them (git log of the data file); it is kept for that.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import paper_readings  # noqa: E402  (the script beside this one)
import paper_search  # noqa: E402

from fuzzynav.app.experiments.paper_ceiling import (  # noqa: E402
    right_wheel_ceiling,
    s3_farthest_m,
)
from fuzzynav.app.experiments.paper_docs import twin_checks  # noqa: E402
from fuzzynav.controller.paper import RULES_BY_GEOMETRY  # noqa: E402
from fuzzynav.controller.paper_design import PaperDesignTunable  # noqa: E402
from fuzzynav.controller.rulebase import read_toml  # noqa: E402
from fuzzynav.safe_files import write_text_atomically  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "data" / "paper_binds.json"
TWIN_OUT = ROOT / "docs" / "data" / "paper_twin_binds.json"
TWIN_SEARCH = [
    "--heading", "0", "--none", "matlab", "--modes", "husky-ideal,husky-ultrasonic",
    "--husky-weight", "1", "--maxiter", "30", "--popsize", "16", "--seed", "13",
    "--sigma", "0.1", "--dt", "0.02", "--bounds-first",
]  # fmt: skip
SELECTED = "2"  # paper_readings.READINGS' index of the shipped reading
WIDE_SPAN = ["--bound", "d_t.top=6:30"]
WIDE_RATES = ["--bound", "v.r=0.2:2", "--bound", "d_t.r=1:4"]


#: The rule base shipped before the bounds-first stages (28 of 36 bounds; its header's
#: tuned vector), where the experiments "from the shipped vector" started.
PREVIOUS = (
    "0.55771,22.3746,1.02623,0.538546,1.84572,0.282201,1.51076,0.151466,1.05035,"
    "0.587149,13.1945,1.47681"
)
#: The box widened past the ``width`` rule on phi_o and past the layout's own edges
#: (d_t's spacings growing, the slow wheel's VS at most 1 V), where the bounds-first
#: stages rest.
WIDE_EDGES = [
    "--bound", "v.e0=-0.15:3", "--bound", "d_t.r=0.6:2.2",
    "--bound", "phi_o.p=0.05:1.5", "--bound", "phi_o.q=0.3:8",
]  # fmt: skip
#: The numeric bounds stage 7's rule base missed; one experiment forces each in turn.
UNMET_NUMERIC = ("s1.path", "s2.path", "s1.pass0.distance", "s2.min_center_distance_m")
BOUNDS_FIRST = ["--force", "bounds", "--force", "chatter", "--screen", "0", "--sigma", "0.05"]
BOUNDS_FIRST += ["--maxiter", "30", "--seed", "8", "--dt", "0.02"]


#: The rule base of the bounds-first stages' stage 7 (29 of 36 bounds; the header's
#: tuned vector of rules/paper.toml before stage 8), where the bounds-first experiments
#: started.
STAGE7 = "1.14441,30.0,1.0,0.423113,1.9412,0.344423,1.65897,0.13,1.001,1.0,13.8311,1.61049"


def experiments(shipped: str = STAGE7) -> list[tuple[str, list[str]]]:
    """(label, paper_readings.py arguments) of every experiment, in the table's order
    (``shipped``: where the bounds-first ones start, stage 7's rule base)."""
    x0 = [f"--x0={PREVIOUS}"]
    return [
        ("control: the readings table's fit", []),
        ("box widened past span", WIDE_SPAN),
        ("box widened past rates", WIDE_RATES),
        ("box widened past both, from the shipped vector", x0 + WIDE_SPAN + WIDE_RATES),
        ("12 V forced", ["--force", "12V"]),
        ("12 V forced, from the shipped vector", x0 + ["--force", "12V"]),
        ("12 V forced, box widened past both", ["--force", "12V"] + WIDE_SPAN + WIDE_RATES),
        ("static pass later forced", ["--force", "static_later"]),
        ("static pass later forced, from the shipped vector", x0 + ["--force", "static_later"]),
        (
            "bounds first, from stage 7's rule base, box widened past width and the layout's edges",
            [f"--x0={shipped}", *BOUNDS_FIRST, *WIDE_EDGES],
        ),
    ] + [
        (
            f"{name} forced (ten times each other bound's weight), bounds first, "
            "from stage 7's rule base, box widened past width and the layout's edges",
            [f"--x0={shipped}", *BOUNDS_FIRST, *WIDE_EDGES, "--force", name],
        )
        for name in UNMET_NUMERIC
    ]


def ceilings(d_t_max_m: float) -> list[dict]:
    """The highest right-wheel voltage any vector of the layout's box gives at any input
    with ``d_t <= d_t_max_m`` (differential evolution over the 12 numbers and the
    inputs; seeded), for each NONE reading, with and without a sensed obstacle: can the
    box reach 12 V where s3 drives at all?"""
    import numpy as np
    from scipy.optimize import differential_evolution

    tunable = PaperDesignTunable()
    out = []
    for none in ((), ("d_o",)):
        for sensed in (False, True):

            def right(z, none=none, sensed=sensed):
                system = tunable.system(z[:12]).replace(unsensed_none=none)
                inputs = [z[12], z[13] if sensed else np.nan, z[14], z[15]]
                return -float(system.evaluate_one(inputs)[1])

            box = [
                *tunable.bounds(),
                (0.0, d_t_max_m),
                (0.0, 3.0),
                (-np.pi, np.pi),
                (-np.pi, np.pi),
            ]
            found = differential_evolution(
                right, box, seed=1, maxiter=150, popsize=15, tol=1e-8, polish=False
            )
            out.append(
                {
                    "none": "unsensed" if none else "matlab",
                    "obstacle_sensed": sensed,
                    "right_max_v": -float(found.fun),
                    "vector": [float(v) for v in found.x[:12]],
                    "inputs": [float(v) for v in found.x[12:]],
                }
            )
            print(out[-1], flush=True)
    return out


def shipped_ceiling() -> dict:
    """The shipped rule base's right-wheel ceiling where s3 drives and anywhere."""
    system = read_toml(RULES_BY_GEOMETRY["paper"])
    farthest = s3_farthest_m()
    d_t_top = system.inputs[0].range[1]
    return {
        "shipped_ceiling": {
            "d_t_max_m": farthest,
            "in_s3": right_wheel_ceiling(system, farthest),
            "anywhere": right_wheel_ceiling(system, d_t_top),
        }
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--only",
        type=lambda text: [int(k) for k in text.split(",")],
        default=None,
        help="these experiments again (indices, comma-separated), the others as stored",
    )
    p.add_argument("--ceiling", action="store_true", help="the 12 V ceilings alone")
    p.add_argument(
        "--twin",
        action="store_true",
        help="the Husky twin's missed bounds, each forced in turn (docs/data/paper_twin_binds.json)",
    )
    p.add_argument(
        "--twin-mad",
        action="store_true",
        help="the twin's s1 MAD alone, from three starts (into docs/data/paper_twin_binds.json)",
    )
    p.add_argument(
        "--shipped-only",
        action="store_true",
        help="with --ceiling: the shipped rule base's alone (the box's do not change with it)",
    )
    args = p.parse_args(argv)
    shipped = STAGE7  # the bounds-first experiments' start, pinned as the data were made
    stored = json.loads(OUT.read_text(encoding="utf-8")) if OUT.exists() else None
    if args.twin or args.twin_mad:
        table = json.loads(TWIN_OUT.read_text(encoding="utf-8")) if TWIN_OUT.exists() else {}
        if args.twin:
            table["experiments"] = twin_experiments()
        if args.twin_mad:
            table["mad_alone"] = [mad_probe(*start) for start in MAD_PROBE_STARTS]
        write_text_atomically(TWIN_OUT, json.dumps(table, indent=1) + "\n")
        print(f"wrote {TWIN_OUT}")
        return 0
    if args.ceiling:
        data = dict(stored or {}, **shipped_ceiling())
        if not args.shipped_only:
            data["ceilings"] = ceilings(s3_farthest_m())
    elif args.only is not None and stored is not None:
        rows = {row["label"]: row for row in stored["experiments"]}
        rows.update(run_experiments(shipped, args.only))
        order = [label for label, _ in experiments(shipped)]
        data = dict(stored, experiments=[rows[label] for label in order if label in rows])
    else:
        rows = run_experiments(shipped, args.only)
        data = {
            "experiments": list(rows.values()),
            **shipped_ceiling(),
            "ceilings": ceilings(s3_farthest_m()),
        }
    write_text_atomically(OUT, json.dumps(data, indent=1) + "\n")
    print(f"wrote {OUT}")
    return 0


def twin_unmet() -> list[str]:
    """The twin's forceable bounds rules/paper_husky.toml misses (``ideal.s1.mad``, ...),
    read from its runs in docs/data/paper_controller.json (tests/test_paper_docs.py holds
    that file to today's rule bases); ``--twin`` forces each in turn."""
    runs = json.loads((ROOT / "docs" / "data" / "paper_controller.json").read_text())["husky"]
    return [
        f"{perception}.{scenario}.{bound}"
        for perception, by_scenario in runs.items()
        for scenario, run in by_scenario.items()
        for bound, met in twin_checks(run, scenario).items()
        if not met and bound in paper_search.TWIN_FORCEABLE
    ]


def twin_experiments() -> list[dict]:
    """Each bound the twin misses forced in turn (ten times the others' weight, the
    twin's bounds counted first) from today's twin: what meeting it costs the others."""
    twin = RULES_BY_GEOMETRY["husky"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in twin_unmet():
            out = Path(tmp) / "twin.json"
            arguments = [*TWIN_SEARCH, "--force-twin", name, "--x0", str(twin)]
            print(f"== {name} forced: paper_search.py {' '.join(arguments)}", flush=True)
            paper_search.main([*arguments, "--json", str(out)])
            found = json.loads(out.read_text(encoding="utf-8"))
            label = f"{name} forced (ten times each other bound's weight), from today's twin"
            rows.append({"label": label, "forced": name, **found})
    return rows


#: ``--twin-mad``'s starts: (label, rule base to start from or None for the best of
#: random draws over the box, seed). Each: that start and 96 seeded draws of the box,
#: the best of them, then CMA-ES 16 x 60 (sigma 0.2) on s1's MAD alone.
MAD_PROBE_STARTS = (
    ("from today's twin", "husky", 31),
    ("from the paper geometry's rule base", "paper", 32),
    ("from the best of 480 random draws", None, 33),
)
MAD_PROBE_SEARCH = {"screen": 96, "random_screen": 480, "popsize": 16, "maxiter": 60, "sigma": 0.2}


def mad_probe(label: str, start: str | None, seed: int) -> dict:
    """s1 on the twin in both perception modes with every other bound dropped: the cost
    is each mode's MAD over its bound, plus 20 per metre of clearance short of the twin's bound
    (a run not reached: 10 plus its distance left). Is there any vector of the layout's
    box whose s1 passes the three obstacles safely with MAD within twice the paper's?
    Records every safe arrival's MAD (reached, clearance kept) and the best vector."""
    import time

    import numpy as np

    from fuzzynav.app.experiments import paper_fit
    from fuzzynav.app.experiments.batch_runs import fit_measures
    from fuzzynav.app.experiments.evolution import cmaes

    fit = paper_fit.FitCost(0.02, husky=True, reading=paper_fit.Reading(0.0, "matlab"))
    bound = paper_fit.TWIN_MAD_FACTOR * fit.paper["table4"]["s1"]["mad_m"]
    modes = ("ideal", "ultrasonic")
    seen: list[tuple[float, list, dict]] = []

    def costs(vectors) -> list[float]:
        per_mode = [fit_measures(fit, ("s1",), vectors, "husky", p) for p in modes]
        out = []
        for k, vector in enumerate(vectors):
            cost, runs = 0.0, {}
            for perception, measured in zip(modes, per_mode):
                if measured[k] is None:
                    cost += 100.0
                    continue
                m = measured[k][0]
                runs[perception] = {
                    "reached": bool(m["reached"]),
                    "mad_m": float(m["mad_m"]),
                    "min_clearance_m": float(m["min_clearance_m"]),
                    "time_to_target_s": m["time_to_target_s"],
                }
                if not m["reached"]:
                    cost += 10.0 + float(m["closest_to_target_m"])
                else:
                    cost += m["mad_m"] / bound + 20.0 * max(
                        0.0, paper_fit.TWIN_CLEARANCE_M - m["min_clearance_m"]
                    )
            seen.append((cost, [float(v) for v in vector], runs))
            out.append(cost)
        return out

    tunable = PaperDesignTunable()
    lo, hi = np.array(tunable.bounds()).T
    rng = np.random.default_rng(seed)
    n = MAD_PROBE_SEARCH["random_screen" if start is None else "screen"]
    draws = lo + rng.random((n, len(lo))) * (hi - lo)
    if start is not None:
        x0 = paper_fit.read_fitted(RULES_BY_GEOMETRY[start])
        draws = np.vstack([x0, draws])
    started = time.perf_counter()
    screened = []
    for k in range(0, len(draws), 32):
        screened += costs(list(draws[k : k + 32]))
    x0 = draws[int(np.argmin(screened))]
    print(f"== s1's MAD alone, {label}: screened {len(draws)}", flush=True)
    cmaes(
        None,
        tunable.bounds(),
        x0,
        MAD_PROBE_SEARCH["sigma"],
        MAD_PROBE_SEARCH["maxiter"],
        MAD_PROBE_SEARCH["popsize"],
        seed,
        lambda _f, xs: costs(list(xs)),
        lambda g, f, x, s: print(f"gen {g}: {f:.3f} ({time.perf_counter() - started:.0f} s)"),
    )
    safe = {
        p: [r[p]["mad_m"] for _, _, r in seen if p in r and r[p]["reached"]
            and r[p]["min_clearance_m"] >= paper_fit.TWIN_CLEARANCE_M]
        for p in modes
    }  # fmt: skip
    best = min(seen, key=lambda row: row[0])
    return {
        "label": label,
        "start": start,
        "seed": seed,
        **MAD_PROBE_SEARCH,
        "mad_bound_m": bound,
        "evaluations": len(seen),
        "safe_arrivals": {p: len(v) for p, v in safe.items()},
        "smallest_safe_mad_m": {p: min(v, default=None) for p, v in safe.items()},
        "best": {"cost": best[0], "vector": best[1], "runs": best[2]},
    }


def run_experiments(shipped: str, only: list[int] | None) -> dict[str, dict]:
    """The experiments (all, or those of ``only``) by label, each its stored row."""
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, extra) in enumerate(experiments(shipped)):
            if only is not None and k not in only:
                continue
            out = Path(tmp) / f"{k}.json"
            arguments = ["--only", SELECTED, *extra, "--json", str(out)]
            print(f"== {label}: paper_readings.py {' '.join(arguments[:-2])}", flush=True)
            paper_readings.main(arguments)
            found = json.loads(out.read_text(encoding="utf-8"))
            rows[label] = {"label": label, "arguments": extra, **found}
    return rows


if __name__ == "__main__":
    sys.exit(main())
