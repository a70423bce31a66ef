"""A controller of a user's own, for the registry's tests: importable by name
(``toy_controller:ToyController``) in this process and in worker processes."""

from __future__ import annotations

import math

import numpy as np


class ToyController:
    """Go to the target, veer from an obstacle ahead: a dozen lines (docs/api.md)."""

    name = "toy"

    def __init__(self, gain_v_per_rad: float = 4.0, cruise_v: float = 6.0):
        self.gain_v_per_rad = gain_v_per_rad
        self.cruise_v = cruise_v

    def reset(self) -> None:
        """Stateless."""

    def __call__(self, inputs) -> np.ndarray:
        d_t, d_o, phi_t, phi_o = (float(x) for x in inputs)
        turn = self.gain_v_per_rad * phi_t
        if not math.isnan(d_o) and d_o < 1.0:  # steer away from the obstacle's side
            turn -= self.gain_v_per_rad * math.copysign(1.0 - d_o, phi_o)
        forward = min(self.cruise_v, 4.0 * d_t)
        return np.array([forward - turn, forward + turn])


class ToyBatch:
    """ToyController's batch form: the same law on arrays."""

    def __init__(self, controllers, run_sets=None):
        self.gain = controllers[0].gain_v_per_rad
        self.cruise = controllers[0].cruise_v

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        d_t, d_o, phi_t, phi_o = inputs.T
        turn = self.gain * phi_t
        near = ~np.isnan(d_o) & (d_o < 1.0)
        away = self.gain * np.copysign(1.0 - np.where(near, d_o, 1.0), np.where(near, phi_o, 1.0))
        turn = turn - np.where(near, away, 0.0)
        forward = np.minimum(self.cruise, 4.0 * d_t)
        return np.stack([forward - turn, forward + turn], axis=1)


class BatchableToy(ToyController):
    """ToyController with a batch form declared."""

    @classmethod
    def batched(cls, controllers, run_sets=None):
        """The batch engine's form."""
        return ToyBatch(controllers, run_sets)


def toy_law(inputs) -> tuple[float, float]:
    """ToyController's law as one plain scalar function: (4,) inputs -> two volts."""
    return tuple(ToyController()(inputs))


def toy_decide(inputs: np.ndarray) -> np.ndarray:
    """The same law vectorised as one plain function: (n, 4) inputs -> (n, 2) volts."""
    return ToyBatch([ToyController()]).decide(np.asarray(inputs, dtype=float), None)


def failing_factory():
    """A factory that fails as a user's may (no hardware, a missing file)."""
    raise RuntimeError("no hardware here")
