"""Why the Husky-geometry paper rule base ignores obstacles behind its axle line.

Takes the shipped ``rules/paper.toml`` and lengthens only phi_o's VN/VP tails, so that an
obstacle straight behind (|phi_o| = pi) fires Table 1's "VP -> go straight" rules at a
given floor (0 is the shipped rule base), then runs s1-s3 in ideal perception, the
loop's 0.02 s period, the scenarios' full duration. Prints one row per (floor, scenario).

.venv/bin/python scripts/rear_coverage.py
"""

from __future__ import annotations

import math

from fuzzynav.app.experiments.tuning import read_vector
from fuzzynav.controller.fis_controller import FisController
from fuzzynav.controller.paper import PAPER_RULES, PaperTunable
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

FLOORS = (0.0, 0.05, 0.1, 0.2)


def with_rear_floor(vector, names, floor: float):
    """The vector with phi_o's VP (and VN) reaching ``floor`` at |phi_o| = pi."""
    v = vector.copy()
    if floor > 0.0:
        peak_end = v[names.index("phi_o.peak")] + v[names.index("phi_o.width")]
        v[names.index("phi_o.tail")] = (math.pi - peak_end) / (1.0 - floor)
    return v


def main() -> None:
    tunable = PaperTunable()
    names = tunable.parameter_names()
    shipped = read_vector(PAPER_RULES, names)
    print("floor at pi  scenario  outcome   path m  time s  min clearance m")
    for floor in FLOORS:
        system = tunable.system(with_rear_floor(shipped, names, floor))
        for name in ("s1", "s2", "s3"):
            sim = Simulation(load_scenario(name), FisController(system, name="paper"), seed=0)
            m = sim.run().metrics
            time_s = m["time_to_target_s"]
            print(
                f"{floor:11.2f}  {name:8}  {m['outcome']:8}  {m['path_length_m']:6.2f}  "
                f"{'-' if time_s is None else f'{time_s:6.1f}':>6}  {m['min_clearance_m']:.3f}"
            )


if __name__ == "__main__":
    main()
