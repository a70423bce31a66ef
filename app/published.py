"""The paper's published numbers that are not in ``assets/paper/results.toml``: Table 4's
row for the method of its ref. [19] (our baseline is a stand-in for it), beside the
paper's own; and the lookup that recordings, reports and comparisons share. Below
every command module, so that recording, report and experiments need not import each
other."""

from __future__ import annotations

from fuzzynav.world.metrics import TABLE4_ROWS

SCENARIOS = ("s1", "s2", "s3")

PAPER_TABLE4 = {
    "baseline": {  # the paper's ref. [19]; our baseline is only a stand-in for it
        "path_length_m": (12.4996, 20.7641, 22.0387),
        "mad_m": (0.7037, 2.6611, 2.8844),
        "rmse_m": (0.8964, 3.2797, 3.4752),
        "min_center_distance_m": (0.3891, 2.22, 2.3),
    },
    "paper": {
        "path_length_m": (11.8332, 11.8672, 11.8263),
        "mad_m": (0.3653, 0.5727, 0.6298),
        "rmse_m": (0.4825, 0.7449, 0.7474),
        "min_center_distance_m": (0.2557, 0.3834, 0.6398),
    },
}


def published_table4(controller: str, scenario: str) -> dict | None:
    """The paper's Table 4 numbers for a controller's row: the proposed method's (for
    ``paper``) from ``assets/paper/results.toml``; the method of [19]'s (for
    ``baseline``, a stand-in for it), which that file does not hold, from
    :data:`PAPER_TABLE4`; None for any other controller."""
    if controller == "paper":
        from fuzzynav.app.experiments.paper_fit import paper_results

        table = paper_results()["table4"].get(scenario)
        return None if table is None else {k: float(table[k]) for k in TABLE4_ROWS}
    ref = PAPER_TABLE4.get(controller)
    if ref is None or scenario not in SCENARIOS:
        return None
    index = SCENARIOS.index(scenario)
    return {k: float(ref[k][index]) for k in TABLE4_ROWS}
