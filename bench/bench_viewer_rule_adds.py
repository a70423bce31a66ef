"""The rule editor's Add, as the page makes it: N adds of one rule to the paper system
(s1), each timed; then the time until the robot drives with all of them.

Before, each add rebuilt and compiled the whole system on the page's thread (its cost
grew with the rules: 975 adds took 20 s in the review); now an add edits the rule list
and a thread of its own builds the system, quick adds together
(``ViewerApp.edit_rules(..., wait=False)``). ``--wait`` times the other path, which
builds at every add (what Python callers get by default, and what the page did).

Run: ``.venv/bin/python bench/bench_viewer_rule_adds.py [--adds 1000] [--wait]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

RULE = "if d_t is VS then left is VS and right is VS"


def main() -> None:
    from fuzzynav.app.viewer.model import ViewerApp

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--adds", type=int, default=1000)
    parser.add_argument("--wait", action="store_true", help="build at every add")
    args = parser.parse_args()
    app = ViewerApp("s1", "paper")
    start_rules = len(app.fuzzy_system().rules)
    times = []
    t0 = time.perf_counter()
    for _ in range(args.adds):
        t = time.perf_counter()
        app.edit_rules("add", None, RULE, wait=args.wait)
        times.append(time.perf_counter() - t)
    returned = time.perf_counter() - t0
    want = start_rules + args.adds
    ok = app.wait_for(lambda a: len(a.fuzzy_system().rules) == want, timeout=600)
    driving = time.perf_counter() - t0
    first, last = times[:100], times[-100:]
    print(
        f"{args.adds} adds ({'build at each' if args.wait else 'page path'}): "
        f"all returned after {returned:.2f} s; median add, first 100: "
        f"{statistics.median(first) * 1e3:.3f} ms, last 100: {statistics.median(last) * 1e3:.3f} ms; "
        f"driving with {want} rules after {driving:.2f} s{'' if ok else ' (NOT reached)'}"
    )
    app.stop()


if __name__ == "__main__":
    main()
