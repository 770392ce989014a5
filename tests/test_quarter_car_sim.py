"""Time-domain quarter car: closed forms, exact sticking, lift-off, equilibrium."""
import numpy as np
import pytest

from linear_car import linear_car, transmissibility
from models import quarter_car as qcm
from models.quarter_car import sim as qs
from models.physics import simplified
from models.damper import load
from models.physics.simulate import C_to_K


@pytest.mark.parametrize("f", [1.5, 2.4, 6.0, 14.0])
def test_frictionless_linear_transmissibility_matches_closed_form(f):
    qc, c = linear_car(), 3000.0
    h = 1e-4
    t = np.arange(0, 6.0, h)
    A = 0.002  # small: the tire never leaves the road
    y_in = A * np.sin(2 * np.pi * f * t)
    r = qs.simulate(qc, lambda x, v: c * v, t, y_in, v_in=A * 2 * np.pi * f * np.cos(2 * np.pi * f * t))
    steady = t > 4.0
    amp = (r.y1[steady].max() - r.y1[steady].min()) / 2
    assert amp / A == pytest.approx(transmissibility(qc, c, f)[0], rel=0.02)
    assert r.tire_force.min() > 0


def test_rest_is_equilibrium_with_gas_force_and_friction():
    qc = qcm.load("simulator")
    t = np.arange(0, 1.0, 1e-4)
    r = qs.simulate(qc, lambda x, v: 500.0 + 2000.0 * v, t, np.zeros_like(t), F_static=500.0, x_install=0.03)
    assert np.max(np.abs(r.y1)) < 1e-9 and np.max(np.abs(r.y2)) < 1e-9
    assert r.tire_force[-1] == pytest.approx(r.static_tire_force)


def test_friction_sticks_exactly_without_chatter():
    # 65 N sprung-unsprung friction, no damper: a 0.05 mm, 1 Hz input cannot break it
    qc = qcm.QuarterCar("stick", m_s=252.5, m_u=45.4, k_s=70e3, k_t=350e3, c_tire=0.0, F_c1=65.0, F_c3=0.0)
    t = np.arange(0, 2.0, 1e-4)
    y_in = 5e-5 * np.sin(2 * np.pi * 1.0 * t)
    r = qs.simulate(qc, lambda x, v: 0.0, t, y_in)
    assert np.max(np.abs(r.y1 - r.y2)) < 1e-12  # the masses move as one
    assert np.max(np.abs(r.friction_su)) <= 65.0 + 1e-9
    # and once the input is large enough it slides, at exactly the friction force
    r = qs.simulate(qc, lambda x, v: 0.0, t, 0.01 * np.sin(2 * np.pi * 2.4 * t))
    sliding = np.abs(np.diff(r.y1 - r.y2)) > 1e-9
    assert sliding.any() and np.allclose(np.abs(r.friction_su[:-1][sliding]), 65.0)


def test_tire_lifts_off_and_never_pulls():
    qc = qcm.load("race-car")
    t = np.arange(0, 3.0, 1e-4)
    r = qs.simulate(qc, lambda x, v: 1500.0 * v, t, 0.0127 * np.sin(2 * np.pi * 14.0 * t))
    assert r.tire_force.min() == 0.0
    assert np.all(r.tire_force >= 0.0)
    assert np.mean(r.tire_force[t > 1.0] == 0.0) > 0.02  # wheel hop


def test_comprehensive_damper_step_response_settles():
    qc = qcm.load("race-car")
    t = np.arange(0, 1.5, 1e-4)
    y_in = np.where(t > 0.05, 0.0127, 0.0)  # 1.27 cm step up (6.2)
    r = qs.run(qc, "koni", t, y_in, T=C_to_K(95))
    stroke = load("koni").geometry.stroke
    # damper friction (about 100 N on a 70 kN/m spring) can hold the car ~1.5 mm short
    assert r.y1[-1] == pytest.approx(0.0127, abs=2e-3)
    # friction locks the suspension; the car then rocks on its lightly damped tire
    assert np.ptp(r.y1[-2000:] - r.y2[-2000:]) < 1e-9
    assert np.ptp(r.y1[-2000:]) < 1e-4
    assert 0.0 <= r.damper_x.min() and r.damper_x.max() <= stroke


def test_compiled_loop_matches_the_callable_loop():
    # the same simplified damper through run() (compiled, tabulated) and simulate()
    qc = qcm.load("simulator")
    d = load("simplified-II")
    t = np.arange(0, 1.0, 1e-4)
    y_in = 0.0127 * np.sin(2 * np.pi * 6.0 * t)
    a = qs.run(qc, d, t, y_in)
    b = qs.simulate(qc, lambda x, v: float(simplified.force(d, v)), t, y_in)
    assert np.allclose(a.y1, b.y1, rtol=0, atol=1e-9) and np.allclose(a.tire_force, b.tire_force, atol=1e-3)
    assert a.tire_force.min() == 0.0  # the case exercises lift-off too


def test_incompressible_and_compressible_cars_agree_at_low_speed():
    qc = qcm.load("simulator")
    t = np.arange(0, 2.0, 1e-4)
    y_in = 0.0032 * np.sin(2 * np.pi * 2.0 * t)
    a = qs.run(qc, "koni", t, y_in, compressible=True)
    b = qs.run(qc, "koni", t, y_in, compressible=False)
    assert np.max(np.abs(a.y1 - b.y1)) < 0.03 * np.ptp(a.y1)
    assert np.max(np.abs(a.damper_x - b.damper_x)) < 0.1 * np.ptp(a.damper_x)
