"""The figures room: the paper's figures for a run, and the reviewer's report.

- :mod:`.run_figures`  a run's figures as PNG and SVG (Figs. 12-16), and ``run --figures``;
- :mod:`.trajectory`   the trajectory panel: path, obstacles, safe distances, closest approaches;
- :mod:`.membership`   membership functions (Figs. 6-11), one per variable or all on a page;
- :mod:`.comparison`   controllers side by side, one row per scenario (Fig. 27);
- :mod:`.numbering`    the paper's figure numbers and the file names they give;
- :mod:`.style`        colours, file types, the Agg figure, files written whole, time axes;
- :mod:`.paper_set`    the report's Figs. 6-27 for one geometry, and their index;
- :mod:`.report`       ``fuzzynav report``: every scenario, controller and geometry.
"""
