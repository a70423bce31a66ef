"""``Run.trace`` streams (issue 37 item 9): building its columns holds little more than
the columns themselves (it held every row's strings first: 1.3 GB beside 86 MB of
arrays at 720,000 steps)."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np

import fuzzynav
from fuzzynav.app.recordings.trace import TRACE_COLUMNS


def test_the_trace_is_built_within_twice_its_own_size():
    run = fuzzynav.simulate("s1", controller="p", control_period_s=0.005)
    n = len(run.result.log)
    assert n > 2_000
    tracemalloc.start()
    try:
        trace = run.trace
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    size = sum(column.nbytes for column in trace.values())
    assert size == len(TRACE_COLUMNS) * n * 8
    assert peak < 2 * size + 1_000_000, (peak, size)
    # and the columns are the CSV's (the same cells, read back)
    from fuzzynav.app.recordings.trace import trace_rows

    first = next(iter(trace_rows(run.result.log)))
    for k, name in enumerate(TRACE_COLUMNS):
        want = float(first[k]) if first[k] != "" else math.nan
        assert np.array_equal(trace[name][:1], [want], equal_nan=True), name
