"""The virtual cell's physics: actuator limits and lags, the thermal model's energy
balance, the actuator's own command watchdog."""
import numpy as np
import pytest

from sim_backend.plant import MODE_FOLLOW, MODE_HOLD, Plant

MID = 0.0381


def test_actuator_velocity_limit_and_internal_lvdt_lag():
    p = Plant("koni")
    p.command(MODE_FOLLOW, MID + 0.02)  # a 20 mm step: the servo saturates at 1.5 m/s
    x = []
    for _ in range(40):
        p.command(MODE_FOLLOW, MID + 0.02)
        p.advance(5e-4)
        x.append(p.x_act)
    v = np.diff(x) / 5e-4
    assert v.max() == pytest.approx(1.5, rel=1e-6)
    # the internal LVDT reports where the piston was 4 ms ago
    lagged = p.readings()["x_internal"]
    assert lagged == pytest.approx(x[-1 - 8], abs=1e-9)


def test_damping_power_heats_the_damper_by_its_energy_over_heat_capacity():
    p = Plant("koni", T0=293.15)
    f, A = 8.0, 0.0127
    dt = 1e-3
    for k in range(int(30 / dt)):  # 30 s of 12.7 mm at 8 Hz, ramped in over a second
        t = k * dt
        p.command(MODE_FOLLOW, MID + min(t, 1.0) * A * np.sin(2 * np.pi * f * t))
        p.advance(dt)
    th = p.p["thermal"]
    rise = p.T - 293.15
    assert rise > 5.0  # cycling warms it: what the temperature sweep relies on
    # energy balance: heat in minus the little convection lost
    lost = th["conductance"] * rise / 2 * 30.0
    assert rise == pytest.approx((p.energy - lost) / th["heat_capacity"], rel=0.03)
    assert p.T_res < p.T  # the reservoir thermocouple lags the body


def test_the_actuator_holds_when_setpoints_stop():
    p = Plant("koni")
    for _ in range(100):
        p.command(MODE_FOLLOW, MID + 0.001)
        p.advance(1e-3)
    p.advance(0.2)  # no frames for 200 ms
    assert p.mode == MODE_HOLD and abs(p.v_act) < 1e-9
