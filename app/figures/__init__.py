"""The figures room: the paper's figures for a run, and the reviewer's report.

- :mod:`.run_figures`  a run's figures as PNG and SVG, numbered as the paper's;
- :mod:`.report`       ``fuzzynav report``: every scenario, controller and geometry.
"""
