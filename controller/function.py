"""A controller written as one plain function, no class.

Two forms are taken, told apart by trying the function on a batch of sample inputs:

- **scalar**: ``f(inputs) -> (left, right)`` with ``inputs = [d_t, d_o, phi_t, phi_o]``
  (4,), the voltages in V (:mod:`controller.interface`);
- **vectorised**: ``f(inputs) -> voltages`` with ``inputs`` (n, 4), one row per run,
  and ``voltages`` (n, 2). It runs on the lockstep batch engine as it is: its batch form
  is the function itself.

The function must be stateless (it is called on any runs, in any order) and, to run in
worker processes, importable by name (a module-level ``def``, not a lambda).
:func:`function_controller` wraps it; :func:`as_controller` is what ``simulate``,
``sweep`` and the registry call on whatever they are given.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from fuzzynav.controller.interface import SAMPLE_INPUTS

__all__ = [
    "FunctionController",
    "VectorisedFunctionController",
    "as_controller",
    "function_controller",
]


class FunctionController:
    """A scalar plain function as a controller (``reset`` does nothing)."""

    def __init__(self, function: Callable[[np.ndarray], Any]):
        self.function = function
        self.name = getattr(function, "__name__", type(function).__name__)

    def reset(self) -> None:
        """Nothing to forget: the function is stateless."""

    def __call__(self, inputs: np.ndarray) -> Any:
        return self.function(inputs)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name})"


class _FunctionBatch:
    """The batch form of a vectorised function: the function on the rows."""

    def __init__(self, function: Callable[[np.ndarray], Any]):
        self.function = function

    def decide(
        self, inputs: np.ndarray, runs: np.ndarray, ranges_m: np.ndarray | None = None
    ) -> np.ndarray:
        return np.asarray(self.function(inputs))


class VectorisedFunctionController(FunctionController):
    """A vectorised plain function as a controller: one run's call is the function on
    one row; the batch engine calls it on all the rows at once (``batched``)."""

    def __call__(self, inputs: np.ndarray) -> Any:
        return np.asarray(self.function(np.asarray(inputs, dtype=float).reshape(1, 4)))[0]

    @classmethod
    def batched(cls, controllers, run_sets=None) -> _FunctionBatch:
        """The batch engine's form (one function for every run)."""
        functions = {id(c.function) for c in controllers}
        if len(functions) != 1:
            raise ValueError("a batch of function controllers must share one function")
        return _FunctionBatch(controllers[0].function)


def _is_vectorised(function: Callable[[np.ndarray], Any]) -> bool:
    """True when ``function`` on (n, 4) sample inputs returns (n, 2) real numbers, each
    row its decision on that row alone."""

    try:
        together = np.asarray(function(SAMPLE_INPUTS.copy()))
    except Exception:  # noqa: BLE001 - a scalar function may fail on a batch any way
        return False
    if together.dtype.kind not in "iuf" or together.shape != (len(SAMPLE_INPUTS), 2):
        return False
    try:
        rows = [np.asarray(function(row[None, :].copy())) for row in SAMPLE_INPUTS]
    except Exception:  # noqa: BLE001
        return False
    alone = np.array([r.reshape(-1) for r in rows]) if all(r.size == 2 for r in rows) else None
    return alone is not None and np.allclose(alone, together, rtol=0, atol=1e-9, equal_nan=True)


def function_controller(function: Callable[[np.ndarray], Any]) -> FunctionController:
    """A controller of a plain function (module docstring: scalar or vectorised, told
    apart by a trial on sample inputs).

    Parameters
    ----------
    function : callable
        ``f(inputs (4,)) -> (left, right)`` or ``f(inputs (n, 4)) -> (n, 2)``, V.

    Returns
    -------
    FunctionController
        A :class:`VectorisedFunctionController` (batchable) for the vectorised form.
    """
    if _is_vectorised(function):
        return VectorisedFunctionController(function)
    _check_scalar(function)
    return FunctionController(function)


def _check_scalar(function: Callable[[np.ndarray], Any]) -> None:
    """ValueError unless ``function`` decides two real numbers on a sample input."""
    from fuzzynav.world.run_limits import wheel_voltages

    name = getattr(function, "__qualname__", None) or repr(function)
    sample = SAMPLE_INPUTS[0]
    try:
        returned = function(sample.copy())
    except Exception as exc:  # noqa: BLE001 - reported, with its type
        raise ValueError(
            f"controller function {name}: on inputs {sample.tolist()} it raised {exc!r} "
            "(f(inputs (4,)) -> (left, right) V, or vectorised f(inputs (n, 4)) -> (n, 2))"
        ) from exc
    wheel_voltages(returned, FunctionController(function))


def is_controller_function(value: object) -> bool:
    """A plain function (a ``def``, a lambda, a method, a builtin or a
    ``functools.partial``) of one positional argument: a controller written as a
    function, not a factory. An object of a class of one's own is a controller object,
    held to the protocol (a ``reset`` among it), even where it is callable."""
    plain = (
        inspect.isfunction(value)
        or inspect.ismethod(value)
        or inspect.isbuiltin(value)
        or isinstance(value, functools.partial)
    )
    if not plain or not callable(value):
        return False
    try:
        parameters = inspect.signature(value).parameters.values()
    except (TypeError, ValueError):
        return False
    required = [
        p
        for p in parameters
        if p.default is p.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    return len(required) == 1


def as_controller(value: Any) -> Any:
    """``value`` as a controller: a plain function wrapped (:func:`function_controller`),
    anything else as it is (the checks that follow name what is wrong)."""
    return function_controller(value) if is_controller_function(value) else value
