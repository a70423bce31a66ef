"""The recordings room: every run as a rerun ``.rrd`` recording or a CSV trace.

- :mod:`.record`  rerun columns, the blueprint, the live recorder, the files;
- :mod:`.trace`   ``run --trace PATH.csv``: one row per control step.
"""
