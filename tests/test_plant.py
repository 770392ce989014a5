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


@pytest.mark.parametrize("c", [3e-5, 3e-7])
def test_free_play_reads_zero_while_the_mount_crosses_the_clearance(c):
    """The rod floats where the damper's force on it is zero while the mount, accelerating
    at a, moves c away from it: the load cell reads zero for sqrt(2 c / a) each time the
    force would change sign, however that compares with the step."""
    from sim_backend.options import plain_cell
    name, params, _ = plain_cell()
    h, f, A = 5e-4, 2.0, 0.0127
    p = Plant(name, params=params, effects={"free_play": c}, h=h)
    x0 = p.x_act
    F, v = [], []
    for k in range(int(1.2 / h)):
        p.command(MODE_FOLLOW, x0 + A * np.sin(2 * np.pi * f * k * h))
        p.advance(h)
        F.append(p.F)
        v.append(p.v_d)
    F, v = np.array(F), np.array(v)
    zero = F == 0.0
    starts = np.nonzero(zero[1:] & ~zero[:-1])[0] + 1
    ends = np.nonzero(~zero[1:] & zero[:-1])[0] + 1
    assert len(starts) >= 2 and len(ends) >= 2
    for s in starts[:2]:
        a = abs(v[s + 1] - v[s - 1]) / (2 * h)  # the mount's acceleration there [m/s^2]
        tau = np.sqrt(2 * c / a)
        e = ends[ends > s][0]
        n = e - s  # steps whose end fell inside the crossing
        assert n == pytest.approx(tau / h, abs=1.0)
    # without the clearance the force never reads exactly zero
    q = Plant(name, params=params, h=h)
    for k in range(int(1.2 / h)):
        q.command(MODE_FOLLOW, x0 + A * np.sin(2 * np.pi * f * k * h))
        q.advance(h)
        assert q.F != 0.0
