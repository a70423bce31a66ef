r"""Linear-graph (LG) state-space model of the Clearpath Husky A200.

The plant of the paper (Eq. 1-6, Tables 2-3), taken from E. McCormick, H. Lang and
C. W. de Silva, "Dynamic Modeling and Simulation of a Four-Wheel Skid-Steer Mobile
Robot Using Linear Graphs", Electronics 11(15):2453, 2022, with the sign errors of
the printed :math:`A` corrected (see :func:`paper_printed_A`).

State, input and output, in the paper's order:

.. math::

    x = [\omega_{LW},\ \omega_{RW},\ v_{MH},\ \omega_{JH},\ i_{L1},\ i_{L2}]^T, \qquad
    u = [v_{s1},\ v_{s2}]^T, \qquad
    y = [\omega_{LW},\ \omega_{RW},\ v_{MH},\ \omega_{JH}]^T

with the left and right drivetrain speeds [rad/s], the hull's forward speed [m/s]
and yaw rate [rad/s, counter-clockwise positive], the left and right motor currents
[A]; :math:`v_{s1}` drives the LEFT motor, :math:`v_{s2}` the right one [V].

The parameters (``husky.toml``) and the assembly of :math:`A` and :math:`B` are
:mod:`world.husky_params`'s; this module discretises them with the exact zero-order
hold (:func:`zoh_discretise`, :class:`HuskyModel`, whose step also gives the mean state
over the step) and keeps the paper's printed :math:`A` (:func:`paper_printed_A`). The
equations and why they are passive: docs/model.md, "The plant's equations". The names
of :data:`__all__` (and ``N_STATES``, ``ROBOT_TABLES``) are imported here, so that
``fuzzynav.world.husky`` still offers them.
"""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from fuzzynav.world.husky_params import (
    DEFAULT_PARAMETER_FILE,
    INPUT_NAMES,
    N_INPUTS,
    N_STATES,
    OUTPUT_NAMES,
    PHYSICAL_RANGES,
    STATE_NAMES,
    HuskyParameters,
    Wheel,
    _check_positive_finite,
    assemble_state_space,
    check_physical_plant,
    dissipation_matrix,
    gyrator_matrix,
    input_matrix,
    slip_matrix,
    storage_matrix,
    wheel_table,
)
from fuzzynav.world.husky_params import MAX_STEADY_SPEED_MPS as MAX_STEADY_SPEED_MPS
from fuzzynav.world.husky_params import ROBOT_TABLES as ROBOT_TABLES

__all__ = [
    "DEFAULT_PARAMETER_FILE",
    "STATE_NAMES",
    "INPUT_NAMES",
    "OUTPUT_NAMES",
    "HuskyParameters",
    "Wheel",
    "DiscreteHusky",
    "HuskyModel",
    "wheel_table",
    "slip_matrix",
    "storage_matrix",
    "dissipation_matrix",
    "gyrator_matrix",
    "input_matrix",
    "assemble_state_space",
    "paper_printed_A",
    "zoh_discretise",
    "check_physical_plant",
    "PHYSICAL_RANGES",
]


def paper_printed_A(p: HuskyParameters) -> np.ndarray:
    """The :math:`A` of the paper's Eq. 3 with the signs exactly as printed.

    NOT used by the simulation: kept to document the sign errors. Rows 1-2 subtract
    the rear-wheel terms (``B_FL*TF3 - B_RL*TF1``) where the reciprocal coupling
    needs a sum, and :math:`A_{62} = +T_{MR}/L_2` turns the right back-EMF into
    positive feedback; the result has an eigenvalue near +263 1/s.

    Uses the paper's numbering: :math:`TF_1, TF_2` rear left, :math:`TF_3, TF_4`
    front left, :math:`TF_5, TF_6` front right, :math:`TF_7, TF_8` rear right (odd:
    speed ratio, even: yaw ratio).
    """
    wheels = {wheel.name: wheel for wheel in wheel_table(p)}
    tf1, tf2 = wheels["RL"].tf_odd, wheels["RL"].tf_even
    tf3, tf4 = wheels["FL"].tf_odd, wheels["FL"].tf_even
    tf5, tf6 = wheels["FR"].tf_odd, wheels["FR"].tf_even
    tf7, tf8 = wheels["RR"].tf_odd, wheels["RR"].tf_even
    b_fl, b_rl = p.wheel_damping_fl, p.wheel_damping_rl
    b_fr, b_rr = p.wheel_damping_fr, p.wheel_damping_rr
    j_l = j_r = p.wheel_inertia_kg_m2
    m_h, j_h, b_h = p.hull_mass_kg, p.hull_inertia_kg_m2, p.hull_yaw_damping
    t_ml = t_mr = p.motor_torque_ratio
    l_1 = l_2 = p.L_henry
    r_1 = r_2 = p.R_ohm
    cross = -b_fl * tf3 * tf4 - b_fr * tf5 * tf6 - b_rl * tf1 * tf2 - b_rr * tf7 * tf8
    return np.array(
        [
            [(-b_fl - b_rl) / j_l, 0.0, (b_fl * tf3 - b_rl * tf1) / j_l,
             (b_fl * tf4 - b_rl * tf2) / j_l, t_ml / j_l, 0.0],
            [0.0, (-b_fr - b_rr) / j_r, (b_fr * tf5 - b_rr * tf7) / j_r,
             (b_fr * tf6 - b_rr * tf8) / j_r, 0.0, t_mr / j_r],
            [(b_fl * tf3 + b_rl * tf1) / m_h, (b_fr * tf5 + b_rr * tf7) / m_h,
             (-b_rl * tf1**2 - b_fl * tf3**2 - b_fr * tf5**2 - b_rr * tf7**2) / m_h,
             cross / m_h, 0.0, 0.0],
            [(b_fl * tf4 + b_rl * tf2) / j_h, (b_fr * tf6 + b_rr * tf8) / j_h,
             cross / j_h,
             (-b_rl * tf2**2 - b_fl * tf4**2 - b_fr * tf6**2 - b_rr * tf8**2 - b_h) / j_h,
             0.0, 0.0],
            [-t_ml / l_1, 0.0, 0.0, 0.0, -r_1 / l_1, 0.0],
            [0.0, t_mr / l_2, 0.0, 0.0, 0.0, -r_2 / l_2],
        ]
    )  # fmt: skip


class DiscreteHusky(NamedTuple):
    r"""Exact zero-order-hold matrices for one step size.

    Attributes
    ----------
    dt_s : float
        Step size [s].
    Ad, Bd : ndarray
        :math:`x_{k+1} = A_d x_k + B_d u_k`, with :math:`A_d = e^{A \Delta t}`,
        :math:`B_d = \int_0^{\Delta t} e^{A s} ds\, B`.
    Ad_mean, Bd_mean : ndarray
        :math:`\bar x_k = \tfrac{1}{\Delta t}\int_{t_k}^{t_k+\Delta t} x\,dt =
        \bar A_d x_k + \bar B_d u_k`.
    step_matrix : ndarray
        (12 x 8) ``[[Ad, Bd], [Ad_mean, Bd_mean]]``, applied to ``[x; u]``.
    """

    dt_s: float
    Ad: np.ndarray
    Bd: np.ndarray
    Ad_mean: np.ndarray
    Bd_mean: np.ndarray
    step_matrix: np.ndarray


#: The coefficients of the degree-13 Pade approximant of exp (Higham 2005, Table 2.3).
_PADE13 = (
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
)
#: The largest 1-norm for which the degree-13 approximant is exact to double precision.
_PADE13_THETA = 5.371920351148152


def matrix_exponential(M: np.ndarray) -> np.ndarray:
    r"""The exponential :math:`e^M` of a square matrix, by scaling and squaring of the
    degree-13 Pade approximant (N. J. Higham, "The scaling and squaring method for the
    matrix exponential revisited", SIAM J. Matrix Anal. Appl. 26(4), 2005).

    :math:`e^M = (r_{13}(M / 2^s))^{2^s}` with :math:`s` the least power that brings
    :math:`\lVert M \rVert_1 / 2^s` under :math:`\theta_{13} = 5.37`: the method
    ``scipy.linalg.expm`` refines (it agrees to 1e-13 at a run's steps, tested), in numpy
    alone, so that a first run need not load ``scipy.linalg``.
    """
    M = np.asarray(M, dtype=float)
    norm = float(np.abs(M).sum(axis=0).max()) if M.size else 0.0
    if not np.isfinite(norm):
        raise ValueError("matrix_exponential: the matrix holds NaN or inf")
    if norm == 0.0:
        return np.eye(len(M))
    squarings = max(0, int(np.ceil(np.log2(norm / _PADE13_THETA))))
    A = M / 2.0**squarings
    b = _PADE13
    eye = np.eye(len(A))
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A2 @ A4
    U = A @ (
        A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye
    )
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    R = np.linalg.solve(V - U, V + U)
    for _ in range(squarings):
        R = R @ R
    return R


def zoh_discretise(A: np.ndarray, B: np.ndarray, dt_s: float) -> DiscreteHusky:
    r"""Exact ZOH discretisation, with the step-mean map, from one matrix exponential.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    dt_s : float
        Step size [s], finite and > 0.

    Returns
    -------
    DiscreteHusky

    Notes
    -----
    With :math:`M = [[A, B], [0, 0]]` ((n+m) x (n+m)),
    :math:`\exp([[M, I], [0, 0]]\, \Delta t) = [[\Phi, \Gamma], [0, I]]`,
    where :math:`\Phi = e^{M\Delta t}` and :math:`\Gamma = \int_0^{\Delta t}
    e^{Ms} ds`. The first n rows of :math:`\Phi` are :math:`[A_d, B_d]`, those of
    :math:`\Gamma / \Delta t` are :math:`[\bar A_d, \bar B_d]`.
    """
    dt_s = _check_positive_finite(dt_s, "dt_s")
    n_states, n_inputs = B.shape
    n_hold = n_states + n_inputs
    augmented = np.zeros((2 * n_hold, 2 * n_hold))
    augmented[:n_states, :n_states] = A
    augmented[:n_states, n_states:n_hold] = B
    augmented[:n_hold, n_hold:] = np.eye(n_hold)
    exponential = matrix_exponential(augmented * dt_s)
    transition = exponential[:n_states, :n_hold]
    mean = exponential[:n_states, n_hold:] / dt_s
    step_matrix = np.ascontiguousarray(np.vstack([transition, mean]))
    step_matrix.setflags(write=False)
    return DiscreteHusky(
        dt_s=dt_s,
        Ad=step_matrix[:n_states, :n_states],
        Bd=step_matrix[:n_states, n_states:],
        Ad_mean=step_matrix[n_states:, :n_states],
        Bd_mean=step_matrix[n_states:, n_states:],
        step_matrix=step_matrix,
    )


def step_product(step_matrix: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The plant's step for rows of ``[x; u]``: ``z`` (n, 8) -> (n, 12), row ``i`` being
    ``step_matrix @ z[i]`` (the new state, then the step-mean state).

    Both engines step the plant through this one function (:meth:`HuskyModel.step`,
    :class:`world.simulation.Simulation`, :mod:`world.batch`), so they compute the same
    bits. It is an einsum, not a BLAS product: BLAS's result for a row depends on the
    rows around it (its kernels block them), einsum's does not, so a run gives the same
    numbers alone, in a batch of any size, and on the pymunk engine.
    """
    return np.einsum("ij,kj->ik", z, step_matrix)


class HuskyModel:
    r"""The sign-corrected LG Husky plant, continuous and exactly discretised.

    Parameters
    ----------
    parameters : HuskyParameters

    Attributes
    ----------
    parameters : HuskyParameters
    A : ndarray, shape (6, 6)
        State matrix, assembled from the parameters (read-only).
    B : ndarray, shape (6, 2)
        Input matrix (read-only).
    C : ndarray, shape (4, 6)
        Output matrix: :math:`y = [\omega_{LW}, \omega_{RW}, v_{MH}, \omega_{JH}]`.
    D : ndarray, shape (4, 2)
        Zero feedthrough.

    Examples
    --------
    >>> model = HuskyModel.default()
    >>> x = np.zeros(6)
    >>> for _ in range(50):
    ...     x, x_mean = model.step(x, np.array([12.0, 12.0]), 0.02)
    """

    def __init__(self, parameters: HuskyParameters) -> None:
        self.parameters = parameters
        A, B = assemble_state_space(parameters)
        C = np.eye(len(OUTPUT_NAMES), N_STATES)
        D = np.zeros((len(OUTPUT_NAMES), N_INPUTS))
        # Read-only: the cached discretisations are only valid for these matrices.
        for matrix in (A, B, C, D):
            matrix.setflags(write=False)
        self.A, self.B, self.C, self.D = A, B, C, D
        self._discrete: dict[float, DiscreteHusky] = {}
        self._step_matrices: dict[float, np.ndarray] = {}

    @classmethod
    def default(cls) -> HuskyModel:
        """The model with the paper's parameters from ``assets/husky.toml``."""
        return cls.from_toml(DEFAULT_PARAMETER_FILE)

    @classmethod
    def from_toml(cls, path: str | Path) -> HuskyModel:
        """The model with parameters read by :meth:`HuskyParameters.from_toml`."""
        return cls(HuskyParameters.from_toml(path))

    def with_parameters(self, **changes: float) -> HuskyModel:
        """A new model with some parameters changed, e.g. ``with_parameters(c_m=0.3)``.

        Raises
        ------
        TypeError
            If a name is not a ``HuskyParameters`` field.
        ValueError
            If a value is not a finite number > 0.
        """
        known = {field.name for field in fields(HuskyParameters)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise TypeError(
                f"unknown Husky parameter(s) {', '.join(map(repr, unknown))}; "
                f"known: {', '.join(sorted(known))}"
            )
        return type(self)(replace(self.parameters, **changes))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.parameters!r})"

    def discrete(self, dt_s: float) -> DiscreteHusky:
        """The exact ZOH matrices for step ``dt_s`` [s], computed once per step size."""
        try:
            return self._discrete[dt_s]
        except KeyError:
            discrete = zoh_discretise(self.A, self.B, dt_s)
            self._discrete[dt_s] = discrete
            self._step_matrices[dt_s] = discrete.step_matrix
            return discrete

    def step(self, x: np.ndarray, u: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
        r"""Advance one step with the voltages held constant; exact for any ``dt_s``.

        Parameters
        ----------
        x : ndarray, shape (6,)
            State at the start of the step.
        u : ndarray, shape (2,)
            Voltages ``[v_s1 (left), v_s2 (right)]`` [V] held over the step.
        dt_s : float
            Step size [s]. Each distinct value costs one matrix exponential, then
            is cached.

        Returns
        -------
        x_next : ndarray, shape (6,)
            State at the end of the step.
        x_mean : ndarray, shape (6,)
            Mean state over the step, :math:`\tfrac{1}{\Delta t}\int x\,dt`
            (e.g. the mean hull speed and yaw rate, to move the body).

        Notes
        -----
        One (12 x 8) product with ``[x; u]`` (:func:`step_product`, shared by both
        engines); both results are views of one fresh array, so callers may keep them. Shapes are not checked here (hot path).
        """
        step_matrix = self._step_matrices.get(dt_s)
        if step_matrix is None:
            step_matrix = self.discrete(dt_s).step_matrix
        result = step_product(step_matrix, np.concatenate((x, u))[None, :])[0]
        return result[:N_STATES], result[N_STATES:]

    def steady_state(self, u: np.ndarray) -> np.ndarray:
        """Equilibrium for constant voltages: solve :math:`A x = -B u`."""
        return np.linalg.solve(self.A, -(self.B @ np.asarray(u, dtype=float)))

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of :math:`A` [1/s], sorted by real part, most negative first."""
        eigenvalues = np.linalg.eigvals(self.A)
        return eigenvalues[np.argsort(eigenvalues.real, kind="stable")]
