"""The paper's published numbers, read from ``assets/paper/results.toml`` (the one place
they are written): Table 4's rows for the proposed method and for the method of its
ref. [19] (fuzzynav's baseline is a stand-in for it), and section 4's events. Recordings,
reports, comparisons, the fit and the viewer all read them here. Below every command
module, so that none of them need import another for the paper's numbers."""

from __future__ import annotations

from pathlib import Path

from fuzzynav.resources import asset_path, loads_user_toml, read_user_text
from fuzzynav.world.metrics import TABLE4_ROWS

SCENARIOS = ("s1", "s2", "s3")
RESULTS_PATH = asset_path("paper", "results.toml")
#: Table 4's rows in the results file, by the controller whose row each is.
TABLE4_TABLES = {"paper": "table4", "baseline": "table4_ref19"}


def paper_results(path: str | Path = RESULTS_PATH) -> dict:
    """The paper's numbers: ``{"table4": {s: {...}}, "table4_ref19": {...}, "events":
    {s: [...]}}`` (the file is parsed, never evaluated; a malformed one is refused with
    its name)."""
    return loads_user_toml(read_user_text(path, "results file"), str(path))


def _table4_by_controller() -> dict[str, dict[str, tuple[float, float, float]]]:
    results = paper_results()
    return {
        controller: {
            key: tuple(float(results[table][s][key]) for s in SCENARIOS) for key in TABLE4_ROWS
        }
        for controller, table in TABLE4_TABLES.items()
    }


#: ``{controller: {metric: (s1, s2, s3)}}``: Table 4 as the comparisons tabulate it.
PAPER_TABLE4 = _table4_by_controller()


def published_table4(controller: str, scenario: str) -> dict | None:
    """The paper's Table 4 numbers of a controller's row in a scenario: the proposed
    method's for ``paper``, the method of [19]'s for ``baseline`` (a stand-in for it);
    None for any other controller or scenario."""
    ref = PAPER_TABLE4.get(controller)
    if ref is None or scenario not in SCENARIOS:
        return None
    index = SCENARIOS.index(scenario)
    return {k: ref[k][index] for k in TABLE4_ROWS}
