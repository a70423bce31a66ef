"""fuzzynav's controllers for the lockstep batch engine (:mod:`world.batch`).

:func:`batch_controller` turns what the pymunk engine drives (a
:class:`~controller.fis_controller.FisController` such as ``paper``, the
:class:`~controller.baseline.BaselineController`, the
:class:`~controller.proportional.ProportionalController`) into an object with
``decide(inputs (n, 4), runs (n,), ranges_m (n, 3)) -> voltages (n, 2)`` that makes
the same decisions for many runs at once. Several controllers of one structure (a
tuning generation's candidates) become one batched controller with a parameter set
per run (``runs`` picks each row's set).

Each controller class makes its own batch form (its ``batched`` class method, declared
in :mod:`controller.interface`; the class beside it in the controller's module): the
fuzzy systems through :class:`~controller.fuzzy_batch.BatchFuzzy` (the same numbers as
``evaluate``), the baseline's sectors and blend and the P law operation for operation.
A controller of your own joins by declaring ``batched``; an object that already has
``decide`` is taken as it is.

Controllers that keep state or plan (fuzzynav's own navigator, with its memory and
its planner) cannot be batched: :class:`NotBatchable` says so and why, and the commands
fall back to the pymunk engine.
"""

from __future__ import annotations

import numpy as np

from fuzzynav.controller.interface import BatchController

__all__ = ["NotBatchable", "batch_controller", "run_groups"]


class NotBatchable(ValueError):
    """A controller the batch engine cannot drive (the message says why)."""


def run_groups(runs: np.ndarray, run_sets: np.ndarray | None) -> np.ndarray | None:
    """Which parameter set each of ``runs`` uses (None: the first for all).

    Parameters
    ----------
    runs : int array (n,)
        The runs being decided for.
    run_sets : int array (N,) or None
        Each run's parameter set (:func:`batch_controller`).
    """
    return None if run_sets is None else run_sets[runs]


def batch_controller(controllers, run_sets=None):
    """One batched controller for a whole batch.

    Parameters
    ----------
    controllers : controller or sequence of controllers
        One controller for every run, or one per parameter set (all of one kind and,
        for fuzzy ones, of one structure).
    run_sets : int array (N,), optional
        Which of ``controllers`` each run of the batch uses (run ``i`` uses
        ``controllers[run_sets[i]]``); every run uses the first if omitted.

    Raises
    ------
    NotBatchable
        A controller the batch engine cannot drive (fuzzynav's navigator, a controller
        with state, a user's Python controller), or a mix of kinds.
    """
    if not isinstance(controllers, (list, tuple)):
        controllers = [controllers]
    if not controllers:
        raise NotBatchable("no controller given")
    kinds = {type(c) for c in controllers}
    if len(kinds) > 1:
        raise NotBatchable(
            f"controllers of several kinds ({', '.join(sorted(k.__name__ for k in kinds))}): "
            "one batch drives one kind"
        )
    kind = kinds.pop()
    if callable(getattr(kind, "batched", None)):  # controller.interface.Batchable
        return kind.batched(list(controllers), run_sets)
    if len(controllers) == 1 and isinstance(controllers[0], BatchController):
        return controllers[0]  # already the batch form
    name = getattr(controllers[0], "name", kind.__name__)
    raise NotBatchable(
        f"controller {name!r} ({kind.__module__}.{kind.__name__}) cannot run on the batch "
        "engine: its class declares no batched(controllers, run_sets) (see "
        "controller/interface.py), as the shipped stateless controllers and any rule base do "
        "(fuzzynav's navigator keeps a memory and plans); use --engine pymunk"
    )
