r"""Linear-graph (LG) state-space model of the Clearpath Husky A200.

The plant of the paper (Eq. 1-6, Tables 2-3), taken from E. McCormick, H. Lang and
C. W. de Silva, "Dynamic Modeling and Simulation of a Four-Wheel Skid-Steer Mobile
Robot Using Linear Graphs", Electronics 11(15):2453, 2022, with the sign errors of
the printed :math:`A` corrected (see :func:`paper_printed_A` and the project notes).

State, input and output, in the paper's order:

.. math::

    x = [\omega_{LW},\ \omega_{RW},\ v_{MH},\ \omega_{JH},\ i_{L1},\ i_{L2}]^T, \qquad
    u = [v_{s1},\ v_{s2}]^T, \qquad
    y = [\omega_{LW},\ \omega_{RW},\ v_{MH},\ \omega_{JH}]^T

with the left and right drivetrain speeds [rad/s], the hull's forward speed [m/s]
and yaw rate [rad/s, counter-clockwise positive], the left and right motor currents
[A]; :math:`v_{s1}` drives the LEFT motor, :math:`v_{s2}` the right one [V].

Model
-----
Each wheel :math:`k \in \{FL, RL, FR, RR\}` is a damper :math:`B_k` between its
side's drivetrain and the hull, through two transformers
:math:`TF_{odd} = 1/r_w` (forward speed) and :math:`TF_{even,k} = \mp c/r_w`
(yaw rate; minus on the left wheels, plus on the right, x forward, y left). The
damper sees the slip rate

.. math::

    s_k = \omega_{side(k)} - TF_{odd}\, v_{MH} - TF_{even,k}\, \omega_{JH}

and puts the torque :math:`-B_k s_k` on the drivetrain, the force
:math:`B_k s_k TF_{odd}` on the hull and the yaw moment :math:`B_k s_k TF_{even,k}`.
With the hull yaw damping :math:`B_H` and DC motors
(:math:`L\, di/dt = v_s - R i - T_M \omega_{side}`, torque :math:`T_M i` on the
drivetrain, :math:`T_M = k_t\, GR`) the whole plant is

.. math::

    E \dot x = (G - D)\, x + F u, \qquad
    E = \mathrm{diag}(J_{LW}, J_{RW}, M_H, J_H, L, L),

    D = \sum_k B_k g_k g_k^T + B_H e_4 e_4^T + R (e_5 e_5^T + e_6 e_6^T), \qquad
    G = T_M (e_1 e_5^T - e_5 e_1^T + e_2 e_6^T - e_6 e_2^T),

where :math:`s_k = g_k^T x` and :math:`F = [e_5, e_6]`; hence
:math:`A = E^{-1}(G - D)` and :math:`B = E^{-1} F`. :math:`D` is symmetric positive
semi-definite and :math:`G` skew, so the stored energy
:math:`H = \tfrac12 x^T E x` obeys

.. math::

    \dot H = u^T i - R\,|i|^2 - \sum_k B_k s_k^2 - B_H \omega_{JH}^2 ,

i.e. the model is passive. That is exactly what the printed signs break.

Discretisation
--------------
:math:`A` is constant, so the zero-order-hold solution is exact for piecewise
constant voltages at any step size (the plant is stiff: :math:`L/R = 0.48` ms, and
explicit Euler diverges at 10 ms). With :math:`M = [[A, B], [0, 0]]` and
:math:`z = [x; u]`,

.. math::

    \exp\left(\begin{bmatrix} M & I \\ 0 & 0 \end{bmatrix} \Delta t\right)
    = \begin{bmatrix} \Phi & \Gamma \\ 0 & I \end{bmatrix}, \qquad
    \Phi = e^{M \Delta t}, \quad \Gamma = \int_0^{\Delta t} e^{M s}\, ds,

so :math:`x(\Delta t) = [\Phi z_0]_{1:6}` and the mean state over the step is
:math:`\bar x = \tfrac{1}{\Delta t}\int_0^{\Delta t} x\, dt = [\Gamma z_0]_{1:6} /
\Delta t`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from numbers import Real
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.linalg import expm

from fuzzynav.resources import InputError, asset_path, loads_user_toml, read_user_text, shown
from fuzzynav.world import compat_numpy

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

DEFAULT_PARAMETER_FILE = asset_path("husky.toml")

STATE_NAMES = ("w_LW", "w_RW", "v_MH", "w_JH", "i_L1", "i_L2")
INPUT_NAMES = ("v_s1", "v_s2")
OUTPUT_NAMES = STATE_NAMES[:4]

N_STATES = len(STATE_NAMES)
N_INPUTS = len(INPUT_NAMES)

# State indices, to keep the assembly readable.
_W_LW, _W_RW, _V_MH, _W_JH, _I_L1, _I_L2 = range(N_STATES)

# TOML layout: the top-level keys are the field names, except the footprint, which
# lives in its own [footprint] table because the world code (collisions) reads it.
_FOOTPRINT_TABLE = "footprint"
_FOOTPRINT_KEYS = {"length_m": "footprint_length_m", "width_m": "footprint_width_m"}
#: Tables of the same file that describe the robot beyond its dynamics (its sonars, its
#: drive's limit): world/robot.py reads and checks them, the plant skips them.
ROBOT_TABLES = ("sonars", "drive")


#: What a husky.toml value may be: far around the Husky's own numbers (a robot from a
#: toy to a car), and inside what the plant computes without overflow (a hull inertia
#: of 1e-300 gave NaN; some extreme values drove the robot at 1e85 m/s). The unit is
#: part of the message.
PHYSICAL_RANGES: dict[str, tuple[float, float, str]] = {
    "R_ohm": (1e-4, 1e3, "ohm"),
    "L_henry": (1e-7, 10.0, "H"),
    "torque_constant_nm_per_a": (1e-4, 100.0, "N m/A"),
    "gear_ratio": (1e-2, 1e4, "-"),
    "wheel_inertia_kg_m2": (1e-6, 1e3, "kg m^2"),
    "hull_mass_kg": (0.1, 1e5, "kg"),
    "hull_inertia_kg_m2": (1e-3, 1e6, "kg m^2"),
    "wheel_radius_m": (0.01, 5.0, "m"),
    "a_m": (1e-3, 20.0, "m"),
    "b_m": (1e-3, 20.0, "m"),
    "c_m": (1e-3, 20.0, "m"),
    "wheel_damping_fl": (1e-6, 1e6, "N m s/rad"),
    "wheel_damping_rl": (1e-6, 1e6, "N m s/rad"),
    "wheel_damping_fr": (1e-6, 1e6, "N m s/rad"),
    "wheel_damping_rr": (1e-6, 1e6, "N m s/rad"),
    "hull_yaw_damping": (1e-6, 1e6, "N m s/rad"),
    "footprint_length_m": (0.05, 20.0, "m"),
    "footprint_width_m": (0.05, 20.0, "m"),
}
#: The fastest the plant may drive at 12 V in steady state: more is no ground robot.
MAX_STEADY_SPEED_MPS = 50.0


def check_physical_plant(p: HuskyParameters, source: str = "husky parameters") -> None:
    """Refuse a plant no robot has, naming the key and the value (ValueError).

    Every value within :data:`PHYSICAL_RANGES`; the state matrix finite with every
    eigenvalue's real part below zero (the passive model is stable: a plant that is not
    would blow up); the steady forward speed at 12 V at most
    :data:`MAX_STEADY_SPEED_MPS`.
    """
    keys = {v: k for k, v in _toml_key_to_field().items()}
    for name, (low, high, unit) in PHYSICAL_RANGES.items():
        value = getattr(p, name)
        if not low <= value <= high:
            raise ValueError(
                f"{source}: key {keys.get(name, name)!r} = {value!r}: must be from "
                f"{low:g} to {high:g} {unit} for a physically possible robot"
            )
    A, B = assemble_state_space(p)
    eigenvalues = np.linalg.eigvals(A) if np.all(np.isfinite(A)) else np.array([np.nan])
    worst = float(np.max(eigenvalues.real))
    if not (np.all(np.isfinite(eigenvalues)) and worst < 0.0):
        raise ValueError(
            f"{source}: these parameters make an unstable plant (largest real part of an "
            f"eigenvalue of A: {worst!r} 1/s); every eigenvalue must have a negative real part"
        )
    speed = float(np.linalg.solve(A, -(B[:, 0] + B[:, 1]) * 12.0)[_V_MH])
    if not abs(speed) <= MAX_STEADY_SPEED_MPS:
        raise ValueError(
            f"{source}: these parameters drive the robot at {speed:.4g} m/s at 12 V "
            f"(at most {MAX_STEADY_SPEED_MPS:g} m/s for a ground robot): check "
            f"torque_constant_nm_per_a, gear_ratio and the dampings"
        )


def _check_positive_finite(value: object, what: str) -> float:
    """Return ``value`` as a float or raise ``ValueError`` naming ``what`` and it."""
    # bool is a Real in Python; `true` in a TOML file is a typo, not 1.0.
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{what} = {shown(value)}: must be a number")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond any float
        number = math.inf
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{what} = {shown(value)}: must be finite and > 0")
    return number


@dataclass(frozen=True)
class HuskyParameters:
    r"""Physical parameters of the LG Husky model (paper Tables 2-3), SI units.

    Parameters
    ----------
    R_ohm : float
        Motor armature resistance :math:`R_1 = R_2` [ohm].
    L_henry : float
        Motor armature inductance :math:`L_1 = L_2` [H].
    torque_constant_nm_per_a : float
        Motor torque constant :math:`k_t` [N m/A], also the back-EMF constant [V s/rad].
    gear_ratio : float
        Gearbox ratio :math:`GR` [-].
    wheel_inertia_kg_m2 : float
        Drivetrain inertia of one side :math:`J_{LW} = J_{RW}` [kg m^2].
    hull_mass_kg : float
        Hull mass :math:`M_H` [kg].
    hull_inertia_kg_m2 : float
        Hull yaw inertia :math:`J_H` [kg m^2].
    wheel_radius_m : float
        Wheel radius :math:`r_w` [m].
    a_m, b_m : float
        Front and rear axle distances from the centre of gravity [m]. They cancel
        out of the LG model (:math:`\cos\theta_{oi}\, r_{ci} = c`) and are kept
        for completeness.
    c_m : float
        Lateral lever arm :math:`c` [m]. The paper calls it half the width, but its
        GA-fitted value (0.8961 m) is about three times the real half track: it is a
        fitted parameter standing for skid friction.
    wheel_damping_fl, wheel_damping_rl, wheel_damping_fr, wheel_damping_rr : float
        Wheel-ground dampers :math:`B_{FL}, B_{RL}, B_{FR}, B_{RR}` [N m s/rad].
    hull_yaw_damping : float
        Hull rotational damping :math:`B_H` [N m s/rad].
    footprint_length_m, footprint_width_m : float
        Real Husky A200 outline used for collisions [m]; not part of the dynamics.

    Raises
    ------
    ValueError
        If a value is not a finite number > 0 (the message names the field).
    """

    R_ohm: float
    L_henry: float
    torque_constant_nm_per_a: float
    gear_ratio: float
    wheel_inertia_kg_m2: float
    hull_mass_kg: float
    hull_inertia_kg_m2: float
    wheel_radius_m: float
    a_m: float
    b_m: float
    c_m: float
    wheel_damping_fl: float
    wheel_damping_rl: float
    wheel_damping_fr: float
    wheel_damping_rr: float
    hull_yaw_damping: float
    footprint_length_m: float
    footprint_width_m: float

    def __post_init__(self) -> None:
        for field in fields(self):
            number = _check_positive_finite(getattr(self, field.name), field.name)
            # Normalise ints (e.g. `gear_ratio = 78`) to float; frozen needs the detour.
            object.__setattr__(self, field.name, number)

    @property
    def motor_torque_ratio(self) -> float:
        r"""Motor transformer ratio :math:`T_M = k_t\, GR` [N m/A] (= [V s/rad])."""
        return self.torque_constant_nm_per_a * self.gear_ratio

    @classmethod
    def from_toml(cls, path: str | Path) -> HuskyParameters:
        """Read the parameters from a TOML file such as ``assets/husky.toml``.

        The top-level keys are the field names; the footprint is the table
        ``[footprint]`` with ``length_m`` and ``width_m``.

        Parameters
        ----------
        path : str or Path
            The TOML file.

        Returns
        -------
        HuskyParameters

        Raises
        ------
        ValueError
            On invalid TOML, an unknown key, a missing key, or a value that is not a
            finite number > 0; the message names the file, the key and the value.
        """
        path = Path(path)
        try:
            document = loads_user_toml(read_user_text(path, "husky parameter file"), str(path))
        except InputError as error:
            raise ValueError(str(error)) from None

        flat = _flatten_parameter_document(document, path)
        key_to_field = _toml_key_to_field()
        for key, value in flat.items():
            if key not in key_to_field:
                raise ValueError(f"{path}: unknown key {shown(key)} = {shown(value)}")
        missing = [key for key in key_to_field if key not in flat]
        if missing:
            raise ValueError(f"{path}: missing key(s) {', '.join(map(repr, missing))}")

        values = {}
        for key, field_name in key_to_field.items():
            try:
                values[field_name] = _check_positive_finite(flat[key], f"key {key!r}")
            except ValueError as error:
                raise ValueError(f"{path}: {error}") from None
        parameters = cls(**values)
        check_physical_plant(parameters, str(path))
        return parameters


def _toml_key_to_field() -> dict[str, str]:
    """Map each dotted TOML key to its ``HuskyParameters`` field name."""
    footprint_fields = set(_FOOTPRINT_KEYS.values())
    mapping = {
        field.name: field.name
        for field in fields(HuskyParameters)
        if field.name not in footprint_fields
    }
    for key, field_name in _FOOTPRINT_KEYS.items():
        mapping[f"{_FOOTPRINT_TABLE}.{key}"] = field_name
    return mapping


def _flatten_parameter_document(document: dict, path: Path) -> dict[str, object]:
    """Flatten the one table of the plant, ``[footprint]``, into dotted keys (the
    :data:`ROBOT_TABLES` are world/robot.py's)."""
    flat: dict[str, object] = {}
    for key, value in document.items():
        if key in ROBOT_TABLES:
            continue
        if key == _FOOTPRINT_TABLE:
            if not isinstance(value, dict):
                raise ValueError(f"{path}: key {key!r} = {shown(value)}: must be a table")
            for sub_key, sub_value in value.items():  # (names checked by the caller)
                flat[f"{key}.{sub_key}"] = sub_value
        else:
            flat[key] = value
    return flat


class Wheel(NamedTuple):
    r"""One wheel-ground contact of the LG model.

    Attributes
    ----------
    name : str
        ``"FL"``, ``"RL"``, ``"FR"`` or ``"RR"``.
    side_state : int
        Index of the drivetrain speed that drives it (0: left, 1: right).
    damping : float
        :math:`B_k` [N m s/rad].
    tf_odd : float
        :math:`TF_{odd} = 1/r_w` [1/m]: hull speed to wheel rate.
    tf_even : float
        :math:`TF_{even,k} = \mp c/r_w` [-]: hull yaw rate to wheel rate (minus on
        the left, plus on the right, with x forward, y left, yaw CCW positive).
    """

    name: str
    side_state: int
    damping: float
    tf_odd: float
    tf_even: float


def wheel_table(p: HuskyParameters) -> tuple[Wheel, ...]:
    """The four wheels FL, RL, FR, RR with their dampers and transformer ratios."""
    tf_odd = 1.0 / p.wheel_radius_m
    tf_even_right = p.c_m / p.wheel_radius_m
    return (
        Wheel("FL", _W_LW, p.wheel_damping_fl, tf_odd, -tf_even_right),
        Wheel("RL", _W_LW, p.wheel_damping_rl, tf_odd, -tf_even_right),
        Wheel("FR", _W_RW, p.wheel_damping_fr, tf_odd, +tf_even_right),
        Wheel("RR", _W_RW, p.wheel_damping_rr, tf_odd, +tf_even_right),
    )


def slip_matrix(p: HuskyParameters) -> np.ndarray:
    r"""Rows :math:`g_k^T` (4 x 6) such that the slip rates are :math:`s = G_s x`.

    .. math:: s_k = \omega_{side(k)} - TF_{odd} v_{MH} - TF_{even,k} \omega_{JH}
    """
    rows = np.zeros((4, N_STATES))
    for row, wheel in zip(rows, wheel_table(p)):
        row[wheel.side_state] = 1.0
        row[_V_MH] = -wheel.tf_odd
        row[_W_JH] = -wheel.tf_even
    return rows


def storage_matrix(p: HuskyParameters) -> np.ndarray:
    r""":math:`E = \mathrm{diag}(J_{LW}, J_{RW}, M_H, J_H, L_1, L_2)` (6 x 6).

    The stored energy is :math:`H = \tfrac12 x^T E x`.
    """
    return np.diag(
        [
            p.wheel_inertia_kg_m2,
            p.wheel_inertia_kg_m2,
            p.hull_mass_kg,
            p.hull_inertia_kg_m2,
            p.L_henry,
            p.L_henry,
        ]
    )


def dissipation_matrix(p: HuskyParameters) -> np.ndarray:
    r"""Symmetric dissipation matrix :math:`D` (6 x 6).

    .. math:: D = \sum_k B_k g_k g_k^T + B_H e_4 e_4^T + R\,(e_5 e_5^T + e_6 e_6^T)

    so that the dissipated power is :math:`x^T D x = \sum_k B_k s_k^2 +
    B_H \omega_{JH}^2 + R |i|^2`. Building it as a sum of dyads is what makes the
    wheel-hull couplings reciprocal.
    """
    slips = slip_matrix(p)
    dampings = np.array([wheel.damping for wheel in wheel_table(p)])
    dissipation = slips.T @ (dampings[:, None] * slips)
    dissipation[_W_JH, _W_JH] += p.hull_yaw_damping
    dissipation[_I_L1, _I_L1] += p.R_ohm
    dissipation[_I_L2, _I_L2] += p.R_ohm
    return dissipation


def gyrator_matrix(p: HuskyParameters) -> np.ndarray:
    r"""Skew-symmetric motor coupling :math:`G` (6 x 6).

    Torque :math:`T_M i` on each drivetrain and back-EMF :math:`-T_M \omega` in
    each armature; the skew form means the motor converts power without creating
    or destroying it.
    """
    torque_ratio = p.motor_torque_ratio
    gyrator = np.zeros((N_STATES, N_STATES))
    for speed, current in ((_W_LW, _I_L1), (_W_RW, _I_L2)):
        gyrator[speed, current] = torque_ratio
        gyrator[current, speed] = -torque_ratio
    return gyrator


def input_matrix() -> np.ndarray:
    """:math:`F` (6 x 2): the supply voltages act on the armature loops."""
    selector = np.zeros((N_STATES, N_INPUTS))
    selector[_I_L1, 0] = 1.0
    selector[_I_L2, 1] = 1.0
    return selector


def assemble_state_space(p: HuskyParameters) -> tuple[np.ndarray, np.ndarray]:
    r"""The sign-corrected :math:`A` (6 x 6) and :math:`B` (6 x 2) of Eq. 3-4.

    .. math:: A = E^{-1} (G - D), \qquad B = E^{-1} F

    Returns
    -------
    A, B : ndarray
    """
    inverse_storage = 1.0 / np.diag(storage_matrix(p))
    A = inverse_storage[:, None] * (gyrator_matrix(p) - dissipation_matrix(p))
    B = inverse_storage[:, None] * input_matrix()
    return A, B


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
    exponential = expm(augmented * dt_s)
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


_einsum = compat_numpy.einsum  # np.einsum's C function (world/compat_numpy.py)


def step_product(step_matrix: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The plant's step for rows of ``[x; u]``: ``z`` (n, 8) -> (n, 12), row ``i`` being
    ``step_matrix @ z[i]`` (the new state, then the step-mean state).

    Both engines step the plant through this one function (:meth:`HuskyModel.step`,
    :class:`world.simulation.Simulation`, :mod:`world.batch`), so they compute the same
    bits. It is an einsum, not a BLAS product: BLAS's result for a row depends on the
    rows around it (its kernels block them), einsum's does not, so a run gives the same
    numbers alone, in a batch of any size, and on the pymunk engine.
    """
    return _einsum("ij,kj->ik", z, step_matrix)


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
