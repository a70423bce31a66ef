"""The Husky plant's parameters and the LG assembly of its matrices from them.

The state, input and output names in the paper's order (:data:`STATE_NAMES`, ...).
:class:`HuskyParameters` are the named numbers of ``assets/husky.toml`` (paper Tables
2-3), read and checked by :meth:`HuskyParameters.from_toml`: every value within
:data:`PHYSICAL_RANGES`, and the plant they make stable (:func:`check_physical_plant`).
From them the wheels (:func:`wheel_table`) and the matrices :math:`E, D, G, F` of
:mod:`world.husky`'s docstring assemble the sign-corrected :math:`A` and :math:`B`
(:func:`assemble_state_space`); the check needs that assembly, so both live here.
:mod:`world.husky` discretises them (:class:`world.husky.HuskyModel`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from numbers import Real
from pathlib import Path
from typing import NamedTuple

import numpy as np

from fuzzynav.resources import InputError, asset_path, loads_user_toml, read_user_text, shown

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
ROBOT_TABLES = ("sonar_beam", "sonars", "drive")


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
