"""The recordings room: every run as a rerun ``.rrd`` recording or a CSV trace.

- :mod:`.record`     ``record_run`` (a finished or interrupted run to a file) and
  ``run --rrd``'s options; the list of every entity a recording holds;
- :mod:`.live`       the live recorder: a running simulation, a chunk of steps at a time;
- :mod:`.files`      a recording written whole beside its target, or ``RecordingError``;
- :mod:`.columns`    the column writer both share: the world, the plots, the controller;
- :mod:`.series`     the table of the plots: entity, panel, series, columns, live view;
- :mod:`.scene`      the world's static parts: the y-up mirror, the start, a scale;
- :mod:`.internals`  the controller's inside: which it is, its rules' heatmap, its state;
- :mod:`.fuzzy`      the fuzzy inference at the time cursor (a controller with a ``fis``);
- :mod:`.events`     closest approaches, the disturbance window and the end;
- :mod:`.plot_events` those events marked on every time-series plot;
- :mod:`.documents`  the run's documents under ``/meta`` (run, versions, rules, summary);
- :mod:`.blueprint`  the default layout and the application id;
- :mod:`.legend`     where a plot's legend goes, and the headroom made for it;
- :mod:`.sending`    the timelines, and the columns and static parts sent to rerun;
- :mod:`.style`      colours, draw orders and sizes;
- :mod:`.trace`      ``run --trace PATH.csv``: one row per control step;
- :mod:`.compare`    ``fuzzynav compare-runs A.rrd B.rrd``: what differs between two runs.

Provenance (versions, git revision, reproduce commands) is :mod:`fuzzynav.app.provenance`'s,
shared with the sweeps and the tuning; the geometry drawn (footprints, beams, bearings)
is :mod:`fuzzynav.world.geometry`'s, shared with the viewer and the figures.
"""
