"""``fuzzynav compare-runs A.rrd B.rrd``: what differs between two recordings of runs.

``rerun rrd compare`` of a recording and of its reproduction reports a mismatch where
nothing of the run differs: NaN against NaN (a gap in a series), the process's command
line, the wall time, the recording's id and start time. This compares what the runs
hold, entity by entity and component by component, on the run's timeline
(``sim_time``): the times of every entity's rows, then the values, a NaN equal to a NaN;
the documents (``/meta``) line by line. Left out: the recording's properties (its id,
name and start time), rerun's row ids and log times, the layout (it is the viewer's),
and the lines of a document that name the wall time or the command line (the process
that made the recording, not the run).

:func:`compare_recordings` returns the differences as lines (none: the runs are the
same); the command prints them and exits 0 when the recordings hold the same run, 1 when
they differ, 2 when one cannot be read.
"""

from __future__ import annotations

import math
import re
from collections import defaultdict

import numpy as np

#: Lines of a document that say how the recording was made, not what the run was.
IGNORED_LINES = re.compile(r"wall_time|\| command line \||^\s*$")
#: The run page's wrapped command line (its own section).
COMMAND_SECTION = re.compile(r"## command line\n\n```sh\n.*?\n```", re.S)
TIMELINE = "sim_time"


def _read(path) -> tuple[dict, dict]:
    """(static, temporal) of a recording's data: ``static[(entity, component)]`` the last
    value; ``temporal[(entity, component)]`` (times in ns, values) sorted by time."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    static: dict = {}
    parts: dict = defaultdict(list)
    for store in reader.recordings():
        for chunk in reader.stream(store=store):
            entity = chunk.entity_path
            if entity.startswith("/__properties"):
                continue
            batch = chunk.to_record_batch()
            names = [n for n in batch.schema.names if ":" in n and not n.startswith("rerun.")]
            if chunk.is_static:
                for n in names:
                    static[(entity, n)] = batch.column(n).to_pylist()[-1]
                continue
            if TIMELINE not in batch.schema.names:
                continue
            times = batch.column(TIMELINE).cast(pa.int64()).to_numpy()
            for n in names:
                parts[(entity, n)].append((times, batch.column(n)))
    temporal = {}
    for key, pieces in parts.items():
        times = np.concatenate([t for t, _ in pieces])
        values = pa.concat_arrays([c for _, c in pieces])
        order = np.argsort(times, kind="stable")
        temporal[key] = (times[order], values.take(pa.array(order)))
    return static, temporal


def _same(a, b) -> bool:
    """Equal, a NaN equal to a NaN, lists and dicts element by element."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return a == b


def _leaves(array):
    """(the flattened numbers of a (nested) list array or None, its offsets at each
    level): a fast NaN-aware comparison of numeric columns."""
    import pyarrow as pa

    offsets = []
    while pa.types.is_list(array.type) or pa.types.is_fixed_size_list(array.type):
        if pa.types.is_list(array.type):
            offsets.append(np.asarray(array.offsets))
            offsets.append(np.asarray(array.is_null()))
        array = array.flatten()
    if not (pa.types.is_floating(array.type) or pa.types.is_integer(array.type)):
        return None, offsets
    values = array.to_numpy(zero_copy_only=False).astype(float)
    return values, offsets


def _column_difference(name: str, a, b) -> str | None:
    """What differs between two columns of rows (None: the same)."""
    times_a, values_a = a
    times_b, values_b = b
    if len(times_a) != len(times_b):
        return f"{name}: {len(times_a)} rows against {len(times_b)}"
    if not np.array_equal(times_a, times_b):
        k = int(np.flatnonzero(times_a != times_b)[0])
        return f"{name}: row {k} at {times_a[k] / 1e9:.6g} s against {times_b[k] / 1e9:.6g} s"
    if values_a.type != values_b.type:
        return f"{name}: type {values_a.type} against {values_b.type}"
    leaves_a, offsets_a = _leaves(values_a)
    leaves_b, offsets_b = _leaves(values_b)
    if leaves_a is not None and leaves_b is not None:
        structure = len(offsets_a) == len(offsets_b) and all(
            np.array_equal(x, y) for x, y in zip(offsets_a, offsets_b)
        )
        if structure and leaves_a.shape == leaves_b.shape:
            equal = (leaves_a == leaves_b) | (np.isnan(leaves_a) & np.isnan(leaves_b))
            if equal.all():
                return None
            gap = np.abs(leaves_a - leaves_b)
            gap = gap[np.isfinite(gap)]
            biggest = f", largest difference {gap.max():.3g}" if gap.size else ""
            return f"{name}: {int((~equal).sum())} values differ{biggest}"
    rows_a, rows_b = values_a.to_pylist(), values_b.to_pylist()
    differ = [k for k, (x, y) in enumerate(zip(rows_a, rows_b)) if not _same(x, y)]
    if not differ:
        return None
    k = differ[0]
    return f"{name}: {len(differ)} rows differ, the first at {times_a[k] / 1e9:.6g} s"


def _document_lines(value) -> list[str]:
    text = value[0] if isinstance(value, list) and value else value
    if not isinstance(text, str):
        return [repr(text)]
    text = COMMAND_SECTION.sub("", text)
    return [line for line in text.splitlines() if not IGNORED_LINES.search(line)]


def compare_recordings(path_a, path_b) -> list[str]:
    """The differences between the runs two recordings hold, one line each (an empty
    list: the same run), NaN-aware and leaving out the wall time and the command line
    (see the module's docstring)."""
    static_a, temporal_a = _read(path_a)
    static_b, temporal_b = _read(path_b)
    out = []
    for key in sorted(set(static_a) | set(static_b)):
        name = f"{key[0]} {key[1]} (static)"
        if key not in static_a or key not in static_b:
            out.append(f"{name}: only in {'B' if key not in static_a else 'A'}")
            continue
        a, b = static_a[key], static_b[key]
        if key[1] == "TextDocument:text":
            lines_a, lines_b = _document_lines(a), _document_lines(b)
            if lines_a != lines_b:
                only_a = [x for x in lines_a if x not in lines_b]
                only_b = [x for x in lines_b if x not in lines_a]
                out.append(
                    f"{name}: A has {only_a[:3]!r}, B has {only_b[:3]!r}"
                    if only_a or only_b
                    else f"{name}: the same lines in another order"
                )
        elif not _same(a, b):
            out.append(f"{name}: {str(a)[:60]} against {str(b)[:60]}")
    for key in sorted(set(temporal_a) | set(temporal_b)):
        name = f"{key[0]} {key[1]}"
        if key not in temporal_a or key not in temporal_b:
            out.append(f"{name}: only in {'B' if key not in temporal_a else 'A'}")
            continue
        difference = _column_difference(name, temporal_a[key], temporal_b[key])
        if difference:
            out.append(difference)
    return out


def add_compare_command(subparsers) -> None:
    # (its description and examples: cli.COMMAND_DOCS["compare-runs"])
    parser = subparsers.add_parser(
        "compare-runs", help="say what differs between the runs two .rrd recordings hold"
    )
    parser.add_argument("a", metavar="A.rrd", help="the first recording")
    parser.add_argument("b", metavar="B.rrd", help="the second recording")
    parser.set_defaults(func=cmd_compare_runs)


def cmd_compare_runs(args) -> int:
    from pathlib import Path

    from fuzzynav.resources import escape_controls

    for path in (args.a, args.b):
        if not Path(path).is_file():
            raise ValueError(f"{escape_controls(path)}: no such recording")
    try:
        differences = compare_recordings(args.a, args.b)
    except (OSError, ValueError, RuntimeError) as exc:
        raise ValueError(f"cannot read the recordings ({exc})") from None
    if not differences:
        print("the same run: no difference (wall time and command line left out)")
        return 0
    for line in differences:
        print(escape_controls(line))
    print(f"{len(differences)} difference(s)")
    return 1
