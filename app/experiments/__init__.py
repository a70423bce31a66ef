"""The experiments room: many runs, and what they say.

- :mod:`.studies`     a study's layout jobs and their fingerprints, run on an executor;
- :mod:`.rows`        a study's rows: their keys, and the check of a row read back;
- :mod:`.study_sources` scenario sets and controller objects as a study's jobs;
- :mod:`.sweep`       ``sweep``: a controller on seeded layouts, its success rate;
- :mod:`.compare`     ``compare``: Table 4 on the paper's scenarios, beside the paper;
- :mod:`.objective`   the cost ``tune`` minimises: a parameter vector's runs;
- :mod:`.tuning`      the ``tune`` command: options, checkpoint, the tuned file;
- :mod:`.search`      tuning: the one ``tune`` (CMA-ES, DE or a local search; your cost
  or the objective's runs) and ``DesignSearch``, its ask/tell form;
- :mod:`.paper_fit`   ``fit-paper``: the paper controller reconstructed from its numbers;
- :mod:`.paper_fit_command` ``fit-paper``'s command line: options, checks, report;
- :mod:`.paper_docs`  what docs/paper-controller.md states of the shipped rule bases, computed;
- :mod:`.paper_ceiling` how high the paper rule base's right wheel can go where s3 drives;
- :mod:`.paper_binds_docs` what binds the fits: the experiments of scripts/paper_binds.py as tables;
- :mod:`.batch_runs`  the same studies on the lockstep batch engine;
- :mod:`.executor`    where runs execute: this process, every core, or a Dask cluster;
- :mod:`.resultlog`   ``--out``/``--resume``: rows written as they arrive, read back safely;
- :mod:`.evolution`   pycma's CMA-ES on a box, seeded: the one wrapper (fit-paper, tune).
"""
