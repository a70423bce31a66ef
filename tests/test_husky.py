"""Tests of the linear-graph Husky model (world/husky.py).

The references are independent of the implementation: scipy's Radau integrator, the
closed-form steady states and eigenvalues of the project notes (section 1), the
paper's Eq. 3 written out entry by entry, and the energy balance of the physics.
"""

from __future__ import annotations

import math
import re
from dataclasses import fields

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from fuzzynav.world.husky import (
    DEFAULT_PARAMETER_FILE,
    HuskyModel,
    HuskyParameters,
    paper_printed_A,
)

PAPER_VALUES = {
    "R_ohm": 0.46,
    "L_henry": 0.22e-3,
    "torque_constant_nm_per_a": 0.044488,
    "gear_ratio": 78.71,
    "wheel_inertia_kg_m2": 0.08,
    "hull_mass_kg": 48.39,
    "hull_inertia_kg_m2": 3.0556,
    "wheel_radius_m": 0.18,
    "a_m": 0.27,
    "b_m": 0.27,
    "c_m": 0.8961,
    "wheel_damping_fl": 1.3016,
    "wheel_damping_rl": 1.3016,
    "wheel_damping_fr": 1.3016,
    "wheel_damping_rr": 1.3016,
    "hull_yaw_damping": 12.865,
    "footprint_length_m": 0.99,
    "footprint_width_m": 0.67,
}

# Eigenvalues of the corrected model quoted in the notes [1/s].
NOTES_EIGENVALUES = np.array([-1664.0, -1664.0, -464.0, -460.0, -42.0, -3.0])

W_LW, W_RW, V_MH, W_JH, I_L1, I_L2 = range(6)


@pytest.fixture(scope="module")
def model() -> HuskyModel:
    return HuskyModel.default()


@pytest.fixture(scope="module")
def uneven_model(model: HuskyModel) -> HuskyModel:
    """Four different wheel dampers and another c, so no term cancels by symmetry."""
    return model.with_parameters(
        wheel_damping_fl=1.1,
        wheel_damping_rl=1.7,
        wheel_damping_fr=0.9,
        wheel_damping_rr=2.3,
        c_m=0.61,
        hull_yaw_damping=9.5,
    )


# ---------------------------------------------------------------------------------
# Parameters and the data file
# ---------------------------------------------------------------------------------


def test_default_file_holds_the_paper_values(model: HuskyModel) -> None:
    p = model.parameters
    assert {f.name for f in fields(p)} == set(PAPER_VALUES)
    for name, value in PAPER_VALUES.items():
        assert getattr(p, name) == pytest.approx(value, rel=1e-12), name
    assert p.motor_torque_ratio == pytest.approx(3.5017, abs=1e-4)
    assert DEFAULT_PARAMETER_FILE.is_file()


def _write_default_with(tmp_path, old: str, new: str):
    text = DEFAULT_PARAMETER_FILE.read_text()
    assert re.search(old, text, flags=re.M), old
    path = tmp_path / "husky.toml"
    path.write_text(re.sub(old, new, text, count=1, flags=re.M))
    return path


@pytest.mark.parametrize(
    ("old", "new", "key", "value"),
    [
        (r"^c_m = 0\.8961", "c_m = -0.8961", "c_m", "-0.8961"),
        (r"^c_m = 0\.8961", "c_m = 0.0", "c_m", "0.0"),
        (r"^R_ohm = 0\.46", "R_ohm = nan", "R_ohm", "nan"),
        (r"^R_ohm = 0\.46", "R_ohm = inf", "R_ohm", "inf"),
        (r"^gear_ratio = 78\.71", 'gear_ratio = "78.71"', "gear_ratio", "'78.71'"),
        (r"^gear_ratio = 78\.71", "gear_ratio = true", "gear_ratio", "True"),
        (r"^width_m = 0\.67", "width_m = -1", "footprint.width_m", "-1"),
        (r"^hull_mass_kg = 48\.39", "hull_mass_kg = 48.39\nhull_colour = 7",
         "hull_colour", "7"),
        (r"^\[footprint\]", "[footprint]\nheight_m = 0.39", "footprint.height_m",
         "0.39"),
        (r"^\[footprint\]", "[paint]\nred = 1.0\n[footprint]", "paint", "'red'"),
    ],
)  # fmt: skip
def test_bad_values_and_unknown_keys_are_named(tmp_path, old, new, key, value) -> None:
    path = _write_default_with(tmp_path, old, new)
    with pytest.raises(ValueError) as raised:
        HuskyParameters.from_toml(path)
    message = str(raised.value)
    assert str(path) in message
    assert key in message
    assert value in message


@pytest.mark.parametrize(
    ("old", "key"),
    [(r"^c_m = .*$", "c_m"), (r"^width_m = .*$", "footprint.width_m")],
)
def test_missing_keys_are_named(tmp_path, old, key) -> None:
    path = _write_default_with(tmp_path, old, "")
    with pytest.raises(ValueError, match=re.escape(key)) as raised:
        HuskyParameters.from_toml(path)
    assert str(path) in str(raised.value)
    assert "missing" in str(raised.value)


def test_invalid_toml_names_the_file(tmp_path) -> None:
    path = _write_default_with(tmp_path, r"^c_m = 0\.8961", "c_m = = 0.8961")
    with pytest.raises(ValueError, match=re.escape(str(path))):
        HuskyParameters.from_toml(path)


def test_from_toml_accepts_integers_and_round_trips(tmp_path) -> None:
    path = _write_default_with(tmp_path, r"^c_m = 0\.8961", "c_m = 1")
    model = HuskyModel.from_toml(path)
    assert model.parameters.c_m == 1.0
    assert isinstance(model.parameters.c_m, float)


# ---------------------------------------------------------------------------------
# Structure of A, B, C, D
# ---------------------------------------------------------------------------------


def test_shapes_and_output_equation(model: HuskyModel) -> None:
    assert model.A.shape == (6, 6)
    assert model.B.shape == (6, 2)
    assert_allclose(model.C, np.hstack([np.eye(4), np.zeros((4, 2))]))
    assert_allclose(model.D, np.zeros((4, 2)))
    p = model.parameters
    expected_B = np.zeros((6, 2))
    expected_B[I_L1, 0] = expected_B[I_L2, 1] = 1.0 / p.L_henry  # v_s1 -> left motor
    assert_allclose(model.B, expected_B)
    with pytest.raises(ValueError):
        model.A[0, 0] = 1.0  # read-only: the ZOH cache depends on it


def test_reciprocal_and_skew_couplings(uneven_model: HuskyModel) -> None:
    A, p = uneven_model.A, uneven_model.parameters
    J_w, M_H, J_H, L = (p.wheel_inertia_kg_m2, p.hull_mass_kg, p.hull_inertia_kg_m2,
                        p.L_henry)  # fmt: skip
    inertia = [J_w, J_w, M_H, J_H]
    for row in range(4):
        for col in range(4):
            assert inertia[row] * A[row, col] == pytest.approx(
                inertia[col] * A[col, row], rel=1e-12, abs=1e-12
            ), (row, col)
    assert J_w * A[W_LW, I_L1] == pytest.approx(-L * A[I_L1, W_LW], rel=1e-12)
    assert J_w * A[W_RW, I_L2] == pytest.approx(-L * A[I_L2, W_RW], rel=1e-12)
    # The sides are not coupled directly, nor the motors to the hull.
    assert A[W_LW, W_RW] == A[W_RW, W_LW] == 0.0
    assert not A[V_MH : W_JH + 1, I_L1:].any()
    assert not A[I_L1:, V_MH : W_JH + 1].any()


def test_corrected_A_against_paper_eq3_with_the_notes_sign_fixes(
    uneven_model: HuskyModel,
) -> None:
    """Eq. 3 written out by hand with the paper's TF numbering and the corrections."""
    p = uneven_model.parameters
    rw, c = p.wheel_radius_m, p.c_m
    TF1, TF2 = 1 / rw, -c / rw  # rear left
    TF3, TF4 = 1 / rw, -c / rw  # front left
    TF5, TF6 = 1 / rw, +c / rw  # front right
    TF7, TF8 = 1 / rw, +c / rw  # rear right
    B_FL, B_RL = p.wheel_damping_fl, p.wheel_damping_rl
    B_FR, B_RR = p.wheel_damping_fr, p.wheel_damping_rr
    J_L = J_R = p.wheel_inertia_kg_m2
    M_H, J_H, B_H = p.hull_mass_kg, p.hull_inertia_kg_m2, p.hull_yaw_damping
    T_M = p.torque_constant_nm_per_a * p.gear_ratio
    L, R = p.L_henry, p.R_ohm
    cross = -B_FL * TF3 * TF4 - B_FR * TF5 * TF6 - B_RL * TF1 * TF2 - B_RR * TF7 * TF8
    expected = np.array([
        [(-B_FL - B_RL) / J_L, 0, (B_FL * TF3 + B_RL * TF1) / J_L,
         (B_FL * TF4 + B_RL * TF2) / J_L, T_M / J_L, 0],
        [0, (-B_FR - B_RR) / J_R, (B_FR * TF5 + B_RR * TF7) / J_R,
         (B_FR * TF6 + B_RR * TF8) / J_R, 0, T_M / J_R],
        [(B_FL * TF3 + B_RL * TF1) / M_H, (B_FR * TF5 + B_RR * TF7) / M_H,
         (-B_RL * TF1**2 - B_FL * TF3**2 - B_FR * TF5**2 - B_RR * TF7**2) / M_H,
         cross / M_H, 0, 0],
        [(B_FL * TF4 + B_RL * TF2) / J_H, (B_FR * TF6 + B_RR * TF8) / J_H, cross / J_H,
         (-B_RL * TF2**2 - B_FL * TF4**2 - B_FR * TF6**2 - B_RR * TF8**2 - B_H) / J_H,
         0, 0],
        [-T_M / L, 0, 0, 0, -R / L, 0],
        [0, -T_M / L, 0, 0, 0, -R / L],
    ])  # fmt: skip
    assert_allclose(uneven_model.A, expected, rtol=1e-12, atol=1e-12)

    # The printed matrix differs from the corrected one exactly at the fixed entries.
    printed = paper_printed_A(p)
    differs = ~np.isclose(printed, expected, rtol=1e-12, atol=1e-12)
    fixed = {(W_LW, V_MH), (W_LW, W_JH), (W_RW, V_MH), (W_RW, W_JH), (I_L2, W_RW)}
    assert set(zip(*np.nonzero(differs))) == fixed
    assert printed[I_L2, W_RW] == pytest.approx(+T_M / L)
    assert printed[W_LW, V_MH] == pytest.approx((B_FL * TF3 - B_RL * TF1) / J_L)


def test_changing_a_parameter_changes_the_model(model: HuskyModel) -> None:
    p = model.parameters
    narrow = model.with_parameters(c_m=0.3)
    B_sum = (p.wheel_damping_fl + p.wheel_damping_rl
             + p.wheel_damping_fr + p.wheel_damping_rr)  # fmt: skip
    expected_A33 = -(B_sum * (0.3 / p.wheel_radius_m) ** 2 + p.hull_yaw_damping) / (
        p.hull_inertia_kg_m2
    )
    assert narrow.A[W_JH, W_JH] == pytest.approx(expected_A33, rel=1e-12)
    assert narrow.A[W_JH, W_JH] != model.A[W_JH, W_JH]
    assert model.parameters.c_m == 0.8961  # the original is untouched
    heavier = model.with_parameters(hull_mass_kg=96.78)
    assert heavier.A[V_MH, V_MH] == pytest.approx(model.A[V_MH, V_MH] / 2, rel=1e-12)
    with pytest.raises(TypeError, match="c_meters"):
        model.with_parameters(c_meters=0.3)
    with pytest.raises(ValueError, match="c_m"):
        model.with_parameters(c_m=-0.3)


# ---------------------------------------------------------------------------------
# Stability, eigenvalues and reference responses of the notes
# ---------------------------------------------------------------------------------


def test_eigenvalues_match_the_notes(model: HuskyModel) -> None:
    eigenvalues = model.eigenvalues()
    assert np.all(eigenvalues.real < 0)
    assert_allclose(eigenvalues.imag, 0.0, atol=1e-9)
    assert_allclose(eigenvalues.real, NOTES_EIGENVALUES, rtol=0.02)
    slowest = eigenvalues.real.max()
    assert slowest == pytest.approx(-3.0, rel=0.02)
    assert -1.0 / slowest == pytest.approx(0.33, abs=0.01)  # velocity time constant [s]


def test_printed_signs_are_unstable(model: HuskyModel) -> None:
    eigenvalues = np.linalg.eigvals(paper_printed_A(model.parameters))
    assert eigenvalues.real.max() == pytest.approx(263.0, rel=0.01)


@pytest.mark.parametrize("seed", range(3))
def test_corrected_model_stable_for_other_parameters(model: HuskyModel, seed) -> None:
    rng = np.random.default_rng(seed)
    changed = model.with_parameters(
        c_m=rng.uniform(0.2, 1.0),
        wheel_damping_fl=rng.uniform(0.5, 5),
        wheel_damping_rr=rng.uniform(0.5, 5),
        hull_yaw_damping=rng.uniform(1, 30),
    )
    assert np.all(changed.eigenvalues().real < 0)


def test_straight_line_steady_state_closed_form(model: HuskyModel) -> None:
    p = model.parameters
    x = model.steady_state(np.array([12.0, 12.0]))
    v_expected = p.wheel_radius_m * 12.0 / p.motor_torque_ratio  # no rolling resistance
    assert v_expected == pytest.approx(0.617, abs=5e-4)
    assert x[V_MH] == pytest.approx(v_expected, rel=1e-10)
    assert x[W_LW] == pytest.approx(12.0 / p.motor_torque_ratio, rel=1e-10)
    assert x[W_JH] == pytest.approx(0.0, abs=1e-12)
    assert_allclose(x[I_L1:], 0.0, atol=1e-10)


def test_spin_in_place_and_one_sided_steady_states(model: HuskyModel) -> None:
    spin = model.steady_state(np.array([-12.0, 12.0]))
    assert spin[V_MH] == pytest.approx(0.0, abs=1e-12)
    assert spin[W_JH] == pytest.approx(0.62, abs=0.005)  # CCW for a faster right side
    one_side = model.steady_state(np.array([0.0, 12.0]))
    assert one_side[V_MH] == pytest.approx(0.31, abs=0.005)
    assert one_side[W_JH] == pytest.approx(0.31, abs=0.005)
    # Linear: the one-sided response is the mean of the straight and spin ones.
    straight = model.steady_state(np.array([12.0, 12.0]))
    assert_allclose(one_side, (straight + spin) / 2, atol=1e-12)


def test_simulated_step_response_settles_to_the_steady_state(model: HuskyModel) -> None:
    u = np.array([0.0, 12.0])
    x = np.zeros(6)
    speeds = []
    for _ in range(250):  # 5 s, about 15 slowest time constants
        x, x_mean = model.step(x, u, 0.02)
        speeds.append(x[V_MH])
    assert_allclose(x, model.steady_state(u), rtol=1e-5, atol=1e-6)
    assert_allclose(x_mean, x, rtol=1e-5, atol=1e-6)
    # First-order-like rise: about 63 % after one time constant (0.33 s ~ 17 steps).
    assert 0.5 < speeds[16] / speeds[-1] < 0.75


# ---------------------------------------------------------------------------------
# Exact ZOH against an independent stiff integrator
# ---------------------------------------------------------------------------------


def _radau_segment(model: HuskyModel, x0: np.ndarray, u: np.ndarray, dt_s: float):
    A, B = np.array(model.A), np.array(model.B)
    forcing = B @ u
    return solve_ivp(
        lambda t, x: A @ x + forcing,
        (0.0, dt_s),
        x0,
        method="Radau",
        jac=A,
        rtol=1e-10,
        atol=1e-12,
        dense_output=True,
    )


def _integrate_dense_output(dense) -> np.ndarray:
    """Integral of solve_ivp's dense output over its whole span.

    Radau's dense output is a cubic per internal step, so a 4-point Gauss-Legendre
    rule on each internal step integrates it exactly (and fast, unlike quad_vec).
    """
    nodes, weights = np.polynomial.legendre.leggauss(4)
    starts, ends = dense.ts[:-1], dense.ts[1:]
    half = (ends - starts) / 2
    times = ((starts + ends) / 2)[:, None] + half[:, None] * nodes[None, :]
    values = dense(times.ravel()).reshape(-1, *times.shape)
    return np.einsum("sij,i,j->s", values, half, weights)


# Few steps: Radau at these tolerances needs ~800 internal steps per 20 ms.
@pytest.mark.parametrize(("dt_s", "n_steps"), [(0.02, 12), (0.001, 10), (0.1, 2)])
def test_zoh_step_matches_radau(model: HuskyModel, dt_s: float, n_steps: int) -> None:
    rng = np.random.default_rng(20240607)
    x_zoh = np.array([1.0, -2.0, 0.3, 0.5, 4.0, -6.0])
    x_ref = x_zoh.copy()
    for _ in range(n_steps):
        u = rng.uniform(-12.0, 12.0, size=2)
        x_next, x_mean = model.step(x_zoh, u, dt_s)
        solution = _radau_segment(model, x_ref, u, dt_s)
        assert solution.success
        x_ref_next = solution.y[:, -1]
        integral = _integrate_dense_output(solution.sol)
        # Observed errors are ~1e-14: these bounds leave a 1000x margin.
        assert_allclose(x_next, x_ref_next, rtol=1e-9, atol=1e-10)
        assert_allclose(x_mean, integral / dt_s, rtol=1e-9, atol=1e-10)
        x_zoh, x_ref = x_next, x_ref_next


def test_step_results_are_independent_arrays_and_cached(model: HuskyModel) -> None:
    x = np.ones(6)
    u = np.array([3.0, -4.0])
    first_next, first_mean = model.step(x, u, 0.02)
    kept_next, kept_mean = first_next.copy(), first_mean.copy()
    model.step(2 * x, -u, 0.02)
    assert_allclose(first_next, kept_next)
    assert_allclose(first_mean, kept_mean)
    assert model.discrete(0.02) is model.discrete(0.02)
    d = model.discrete(0.02)
    assert_allclose(first_next, d.Ad @ x + d.Bd @ u, rtol=1e-14)
    assert_allclose(first_mean, d.Ad_mean @ x + d.Bd_mean @ u, rtol=1e-14)
    assert_allclose(x, np.ones(6))  # inputs untouched
    with pytest.raises(ValueError, match="dt_s"):
        model.step(x, u, 0.0)


# ---------------------------------------------------------------------------------
# Energy balance (what the sign corrections buy)
# ---------------------------------------------------------------------------------


def _power_terms(p: HuskyParameters, x: np.ndarray, u: np.ndarray):
    """Independent physics: stored-energy matrix, supplied and dissipated power."""
    w_l, w_r, v, w, i_1, i_2 = x
    rw, c = p.wheel_radius_m, p.c_m
    slips = {
        "FL": (p.wheel_damping_fl, w_l - v / rw + c / rw * w),
        "RL": (p.wheel_damping_rl, w_l - v / rw + c / rw * w),
        "FR": (p.wheel_damping_fr, w_r - v / rw - c / rw * w),
        "RR": (p.wheel_damping_rr, w_r - v / rw - c / rw * w),
    }
    dissipated = (
        p.R_ohm * (i_1**2 + i_2**2)
        + sum(b * s**2 for b, s in slips.values())
        + p.hull_yaw_damping * w**2
    )
    supplied = u[0] * i_1 + u[1] * i_2
    storage = np.diag([p.wheel_inertia_kg_m2, p.wheel_inertia_kg_m2, p.hull_mass_kg,
                       p.hull_inertia_kg_m2, p.L_henry, p.L_henry])  # fmt: skip
    return storage, supplied, dissipated


@pytest.mark.parametrize("which", ["paper", "uneven"])
def test_energy_balance_at_random_states(model, uneven_model, which) -> None:
    chosen = model if which == "paper" else uneven_model
    rng = np.random.default_rng(7)
    for _ in range(200):
        x = rng.normal(scale=[3, 3, 0.6, 0.6, 10, 10])
        u = rng.uniform(-12, 12, size=2)
        storage, supplied, dissipated = _power_terms(chosen.parameters, x, u)
        dE_dt = x @ storage @ (chosen.A @ x + chosen.B @ u)
        scale = abs(supplied) + dissipated + 1e-300
        assert dE_dt == pytest.approx(supplied - dissipated, abs=1e-9 * scale)


def test_printed_signs_break_the_energy_balance(model: HuskyModel) -> None:
    rng = np.random.default_rng(8)
    printed = paper_printed_A(model.parameters)
    errors = []
    for _ in range(20):
        x = rng.normal(scale=[3, 3, 0.6, 0.6, 10, 10])
        u = rng.uniform(-12, 12, size=2)
        storage, supplied, dissipated = _power_terms(model.parameters, x, u)
        dE_dt = x @ storage @ (printed @ x + model.B @ u)
        errors.append(abs(dE_dt - (supplied - dissipated)) / (abs(supplied) + dissipated))
    assert max(errors) > 1e-2


def test_energy_decays_with_zero_input(model: HuskyModel) -> None:
    x = np.array([2.0, -1.0, 0.4, -0.3, 5.0, 1.0])
    storage = _power_terms(model.parameters, x, np.zeros(2))[0]
    energy = [0.5 * x @ storage @ x]
    for _ in range(100):
        x, _ = model.step(x, np.zeros(2), 0.02)
        energy.append(0.5 * x @ storage @ x)
    assert np.all(np.diff(energy) < 0)
    assert math.isclose(energy[-1], 0.0, abs_tol=1e-3 * energy[0])


@pytest.mark.parametrize(
    "dt_s, tolerance", [(1e-4, 1e-13), (0.02, 1e-13), (0.05, 1e-13), (1.0, 1e-11)]
)
def test_the_matrix_exponential_is_scipys(dt_s, tolerance):
    """The ZOH's matrix exponential (numpy alone, so that a first run does not load
    scipy.linalg) agrees with scipy.linalg.expm on the plant's augmented matrix to 1e-13
    of its largest entry at the steps runs take (up to 0.05 s; at 1 s, twelve squarings,
    to 1e-11: both methods' rounding grows with the squarings), and on random and zero
    matrices."""
    from scipy.linalg import expm

    from fuzzynav.world.husky import assemble_state_space, matrix_exponential

    A, B = assemble_state_space(HuskyParameters.from_toml(DEFAULT_PARAMETER_FILE))
    n, m = B.shape
    k = n + m
    augmented = np.zeros((2 * k, 2 * k))
    augmented[:n, :n], augmented[:n, n:k], augmented[:k, k:] = A, B, np.eye(k)
    want = expm(augmented * dt_s)
    got = matrix_exponential(augmented * dt_s)
    assert_allclose(got, want, rtol=0, atol=tolerance * abs(want).max())
    rng = np.random.default_rng(int(dt_s * 1e4))
    for scale in (1e-3, 1.0, 30.0):
        M = rng.normal(size=(5, 5)) * scale
        want = expm(M)
        assert_allclose(matrix_exponential(M), want, rtol=0, atol=1e-12 * abs(want).max())
    assert_allclose(matrix_exponential(np.zeros((3, 3))), np.eye(3), rtol=0, atol=0)
    with pytest.raises(ValueError, match="NaN"):
        matrix_exponential(np.full((2, 2), np.nan))


def test_a_first_run_does_not_load_scipy():
    """A run of a shipped scenario needs numpy and pymunk, not scipy (a first call waits
    for every module it loads)."""
    import subprocess
    import sys

    code = (
        "import sys, fuzzynav; fuzzynav.simulate('s1', 'paper');"
        "print(sorted({m.split('.')[0] + '.' + m.split('.')[1] for m in sys.modules"
        " if m.startswith('scipy.')}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout
    assert out.strip() == "[]", out
