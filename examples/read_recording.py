"""Reading a recording back: run s2 headless, save it as a rerun recording (``.rrd``),
then open the file with the rerun SDK and get the wheel voltages and the run's
metadata out of it again, as a reviewer who only has the file would.

It shows :meth:`fuzzynav.Run.save_rrd` and rerun's ``RrdReader``: a recording holds
every time series as columns on the ``sim_time`` timeline, and documents under
``/meta``.

Run it: ``python examples/read_recording.py --out s2.rrd``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from rerun.chunk import RrdReader

import fuzzynav


def read_series(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(time in s, values (rows, series), the series' names) of one plot in a recording."""
    times, rows, names = [], [], []
    for chunk in RrdReader(path).stream():
        if chunk.entity_path != entity:
            continue
        batch = chunk.to_record_batch()
        if chunk.is_static:
            if "SeriesLines:names" in batch.schema.names:
                names = batch.column("SeriesLines:names").to_pylist()[-1]
            continue
        if "Scalars:scalars" not in batch.schema.names:
            continue
        nanos = batch.column("sim_time").cast("int64").to_numpy()
        times.append(nanos / 1e9)
        rows += batch.column("Scalars:scalars").to_pylist()
    t = np.concatenate(times)
    order = np.argsort(t, kind="stable")
    values = np.array([[np.nan if x is None else x for x in rows[i]] for i in order], dtype=float)
    return t[order], values, names


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("s2.rrd"), help="the recording to write")
    args = parser.parse_args(argv)

    run = fuzzynav.simulate("s2", controller="paper")
    path = run.save_rrd(args.out)
    print(f"{run} -> {path} ({path.stat().st_size / 1e6:.1f} MB)")

    times, volts, names = read_series(path, "/plots/voltage")
    left = volts[:, 0]
    print(f"read back {len(times)} rows of /plots/voltage: {names[:2]}")
    print(
        f"left wheel: peak {np.nanmax(np.abs(left)):.2f} V; the run's trace: "
        f"{np.nanmax(np.abs(run.trace['v_left_v'])):.2f} V"
    )
    same = np.array_equal(left[:-1], run.trace["v_left_v"][:-1])
    print(f"recording and trace agree step for step: {same}")
    return {"run": run, "path": path, "time_s": times, "voltages_v": volts, "names": names}


if __name__ == "__main__":
    main()
