"""The experiments room: many runs, and what they say.

- :mod:`.studies`     ``sweep`` and ``compare`` on seeded layouts and the paper's scenarios;
- :mod:`.tuning`      ``tune``: evolution of a controller's membership functions;
- :mod:`.paper_fit`   ``fit-paper``: the paper controller reconstructed from its numbers;
- :mod:`.batch_runs`  the same studies on the lockstep batch engine;
- :mod:`.executor`    where runs execute: this process, every core, or a Dask cluster;
- :mod:`.resultlog`   ``--out``/``--resume``: rows written as they arrive, read back safely;
- :mod:`.cmaes`       the evolution strategy of the fit.
"""
