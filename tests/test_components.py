"""Each component equation against a value computed by hand from the thesis equation."""
import numpy as np
import pytest

from models.physics import compressibility, friction, gas_spring, simplified, temperature, valves
from models.damper import load
from models.physics.kernel import pack

K = 273.15


# --- gas spring, eqs 3.4-3.19, 4.3-4.6 ---------------------------------------------------

def test_eq_3_4_gas_force_from_pressure():
    assert gas_spring.force_from_pressure(2.51e6, 1.6e-4) == pytest.approx((2.51e6 - 101325) * 1.6e-4)


def test_eq_3_5_to_3_7_isothermal_pressure():
    # V = 50 cc - 50 mm * 1 cm^2 = 45 cc -> P = 2 MPa * 50/45
    assert gas_spring.isothermal_pressure(0.05, 2e6, 50e-6, 1e-4) == pytest.approx(2.2222222e6)


def test_eq_3_7_regression_recovers_charge():
    x = np.linspace(0, 0.06, 8)
    F = gas_spring.force_from_pressure(gas_spring.isothermal_pressure(x, 2.07e6, 155e-6, 2e-4), 2e-4)
    P0, V0, r2 = gas_spring.fit_charge(x, F, 2e-4)
    assert P0 == pytest.approx(2.07e6, rel=1e-9)
    assert V0 == pytest.approx(155e-6, rel=1e-9)
    assert r2 == pytest.approx(1.0)


def test_eq_3_8_and_3_15_thermal_volume():
    # 100 C above 20 C: 100 * 1.04e-7 - 1.05e-6 = 9.35 cc
    assert gas_spring.thermal_volume_change(120 + K, 1.04e-7, -1.05e-6) == pytest.approx(9.35e-6)


def test_eq_3_16_and_4_5_static_force_with_temperature():
    # hand: V = 48.6 - 3.8*1.6 - (74*0.104 - 1.05) cc = 35.874 cc; P = 2.51 MPa*48.6/35.874*367.15/293.15
    F = gas_spring.static_force(0.038, 94 + K, 2.51e6, 48.6e-6, 20 + K, 1.6e-4, 1.04e-7, -1.05e-6)
    assert F == pytest.approx(665.19, abs=0.01)


def test_eq_3_17_polytropic_pressure_rises_in_compression():
    # thesis prints (x_e - x); the physical sign makes compression raise the pressure
    P = gas_spring.polytropic_pressure(0.03, 0.02, 40e-6, 3e6, 1.6e-4, 1.38)
    assert P == pytest.approx(3173854.06, rel=1e-8)
    assert gas_spring.polytropic_pressure(0.02, 0.02, 40e-6, 3e6, 1.6e-4, 1.38) == pytest.approx(3e6)


def test_eq_4_6_regression_recovers_thermal_expansion():
    T = np.linspace(20, 150, 9) + K
    F = gas_spring.static_force(0.03, T, 2.12e6, 151.2e-6, 20 + K, 2.5e-4, 2.42e-7, -3.17e-6)
    K_voil, K_voint = gas_spring.fit_thermal_expansion(T, F, 0.03, 2.12e6, 151.2e-6, 20 + K, 2.5e-4)
    assert K_voil == pytest.approx(2.42e-7, rel=1e-6)
    assert K_voint == pytest.approx(-3.17e-6, rel=1e-5)


# --- friction, eqs 3.1-3.3, 4.1-4.2 -------------------------------------------------------

def test_eq_3_1_lookup_interpolates_and_extrapolates():
    X, F = [0.01, 0.02, 0.03], [40.0, 80.0, 60.0]
    assert friction.static_friction(0.015, X, F) == pytest.approx(60.0)
    assert friction.static_friction(0.005, X, F) == pytest.approx(20.0)  # first segment extended
    assert friction.static_friction(0.05, X, F) == pytest.approx(20.0)  # last segment extended
    assert friction.static_friction(0.08, X, F) == 0.0  # never negative


def test_eq_3_3_koni_friction_at_94C():
    # 80 N static, Table 4.2 combined: 80 * (-5.289e-3 * 74 + 1.709) = 105.41 N
    F = friction.friction_force(0.02, 0.1, 94 + K, [0.0, 0.04], [80.0, 80.0], -5.289e-3, 1.709)
    assert F == pytest.approx(105.409, abs=1e-3)
    assert friction.friction_force(0.02, -0.1, 94 + K, [0.0, 0.04], [80.0, 80.0], -5.289e-3, 1.709) < 0


def test_eq_4_2_mean_ratio():
    assert friction.mean_ratio([1.4, 1.6, 1.56]) == pytest.approx(1.52)


# --- valves, eqs 3.20-3.30, 4.9-4.16 -------------------------------------------------------

def test_eq_3_22_orifice():
    C = valves.orifice_coefficient(0.7, 1e-5, 870.0)
    assert C == pytest.approx(8.8775510e12)
    assert valves.orifice_dp(1e-4, C, 0.0) == pytest.approx(88775.51)


def test_eq_3_25_and_3_28_flow_compensating_is_linear():
    C = valves.flow_compensating_coefficient(0.7, 1e-3, 870.0)
    assert valves.flow_compensating_dp(2e-4, C, 5e4) == pytest.approx(2 * valves.flow_compensating_dp(1e-4, C, 0) + 5e4)


def test_eq_3_29_polynomial():
    assert valves.polynomial_dp(0.1, 100.0, 10.0, 1.0) == pytest.approx(3.0)


def test_eq_4_14_koni_low_speed_inverse():
    # Table 4.5: F = 199028 v^2 + 3160.5 v -> 655.595 N at 0.05 m/s; rebound -1045.58 N
    assert valves.branch_velocity(655.595, 199028.0, 3160.5, 0.0) == pytest.approx(0.05)
    assert valves.branch_velocity(-1045.5775, -280441.0, 6889.5, 0.0) == pytest.approx(-0.05)


def test_mid_valve_passes_nothing_below_cracking_force():
    assert valves.branch_velocity(700.0, 0.0, 1727.0, 770.0) == 0.0
    assert valves.branch_velocity(770.0 + 1727.0 * 0.1, 0.0, 1727.0, 770.0) == pytest.approx(0.1)


def test_eq_3_30_koni_parallel_low_and_mid_at_0_3_mps():
    prm, vp, vh = pack(load("koni"), load("koni").temperature.T_ref, 0.038)
    vp[:, valves.FT] = 1.0
    F = valves.path_force(0.3, vp, 0.0, True)
    # hand (thesis-notes): about 1.17 kN; v_L(F) + v_M(F) must give back 0.3 m/s
    v_L = valves.branch_velocity(F, 199028.0, 3160.5, 0.0)
    v_M = (F - 770.0) / 1727.0
    assert v_L + v_M == pytest.approx(0.3, rel=1e-9)
    assert F == pytest.approx(1170, rel=0.02)


def test_temperature_factor_scales_valve_force():
    prm, vp, vh = pack(load("koni"), 366.65, 0.038)
    vp[:, valves.FT] = 1.0
    F1 = valves.path_force(0.2, vp, 0.0, True)
    vp[:, valves.FT] = 0.5
    assert valves.path_force(0.2, vp, 0.0, True) == pytest.approx(0.5 * F1, rel=1e-9)


def test_fox_heavy_high_speed_branch_replaces_mid_beyond_crossover():
    d = load("fox-heavy")
    prm, vp, vh = pack(d, d.temperature.T_ref, 0.03)
    vp[:, valves.FT] = 1.0
    # mid 20000 v - 1300 and high 6500 v - 1900 cross at v = -600/13500, F = -2188.9 N
    vx = -600.0 / 13500.0
    Fx = 20000.0 * vx - 1300.0
    low = Fx / 83000.0
    assert valves.path_velocity(Fx, vp, 0.0, True) == pytest.approx(low + vx)
    F = -5000.0
    assert valves.path_velocity(F, vp, 0.0, True) == pytest.approx(F / 83000.0 + (F + 1900.0) / 6500.0)


def test_eq_4_15_4_16_mechformance_bypass():
    d = load("mechformance")
    prm, vp, vh = pack(d, d.temperature.T_ref, 0.03)
    vp[:, valves.FT] = 1.0
    # compression: low speed 56700 in parallel with the open bypass 1800 -> 1745.6 N s/m
    assert valves.path_force(0.1, vp, 1800.0, True) == pytest.approx(0.1 / (1 / 56700 + 1 / 1800))
    # slow rebound: bypass open (force above -50 N)
    F = [valves.path_force(v, vp, 1800.0, valves.bypass_open_at(v, vp, 1800.0, -50.0)) for v in (-0.02, -0.05)]
    assert F[0] == pytest.approx(-0.02 / (1 / 56700 + 1 / 1800))
    # faster rebound: seated; low 56700 in parallel with mid 17000 v - 2400: F = -2500.4 N
    assert F[1] == pytest.approx(-(0.05 + 2400 / 17000) / (1 / 56700 + 1 / 17000))


# --- compressibility, eq 3.32 -------------------------------------------------------------

def test_eq_3_32_bulk_modulus():
    assert compressibility.bulk_modulus(5e6, 100e6, 0.0, 0.0, 0.0) == 100e6
    # Mechformance: 66 MPa + 81.25 * 2 MPa = 228.5 MPa, capped at 500 MPa
    assert compressibility.bulk_modulus(2e6, 0.0, 66e6, 81.25, 500e6) == pytest.approx(228.5e6)
    assert compressibility.bulk_modulus(6e6, 0.0, 66e6, 81.25, 500e6) == pytest.approx(500e6)


@pytest.mark.parametrize("P", [0.5e6, 2e6, 5e6, 8e6])
def test_strain_integrates_eq_3_32(P):
    # the chamber kernels use strain = integral dP/K(P); its slope must be 1/K (eq 3.31)
    args = (2.7e6, 0.0, 66e6, 81.25, 500e6)  # P_ref, then Mechformance Table 4.6
    dP = 10.0
    slope = (compressibility.strain(P + dP, *args) - compressibility.strain(P - dP, *args)) / (2 * dP)
    assert slope == pytest.approx(1 / compressibility.bulk_modulus(P, 0.0, 66e6, 81.25, 500e6), rel=1e-6)
    Pc, Gc = compressibility.cap_point(*args)
    assert compressibility.pressure(compressibility.strain(P, *args), *args, Pc, Gc) == pytest.approx(P, rel=1e-9)


# --- temperature sensitivity, eqs 3.57-3.62, 4.17 ------------------------------------------

def test_eq_3_60_oil_volume_ratio():
    assert temperature.oil_volume_ratio(393.15, 293.15, 7.2e-4) == pytest.approx(1 / 1.072)


def test_eq_4_17_koni_compression_at_149C():
    f = temperature.damping_factor(149 + K, 93.5 + K, 0.56e-3, 10.7e-3)
    assert f == pytest.approx(0.959896, abs=1e-6)


# --- simplified models, eqs 6.1-6.2 ---------------------------------------------------------

def test_eq_6_1_model_I():
    d = load("simplified-I")
    assert simplified.force(d, [0.1, -0.1]) == pytest.approx([342.1, -643.4])


def test_eq_6_2_model_II():
    d = load("simplified-II")
    F = simplified.force(d, [0.05, 0.2, -0.2])
    assert F[0] == pytest.approx(525.5)
    assert F[1] == pytest.approx(10510 * 0.0727 + 1777 * (0.2 - 0.0727))
    assert F[2] == pytest.approx(11661 * -0.1129 + 4369 * (-0.2 + 0.1129))
