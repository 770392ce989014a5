"""Metrics and road inputs on cases with known answers."""
import numpy as np
import pytest

from models.quarter_car import metrics, road


def second_order_step(zeta, wn, t):
    wd = wn * np.sqrt(1 - zeta**2)
    return 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))


def test_overshoot_of_second_order_step_matches_closed_form():
    zeta, wn = 0.3, 2 * np.pi * 2.4
    t = np.linspace(0, 10, 200001)
    y = 0.025 * second_order_step(zeta, wn, t)
    expected = 100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    assert metrics.overshoot_percent(t, y) == pytest.approx(expected, rel=1e-3)


def test_settling_time_to_90_percent():
    tau = 0.05  # first order: 90 % at tau ln 10
    t = np.linspace(0, 2, 200001)
    y = -0.025 * (1 - np.exp(-t / tau))  # a negative step works the same
    assert metrics.settling_time(t, y) == pytest.approx(tau * np.log(10), rel=1e-3)
    assert metrics.overshoot_percent(t, y) == pytest.approx(0.0, abs=1e-6)


def test_settling_time_of_an_overshooting_response_waits_for_the_band():
    # second order, zeta 0.3: the envelope exp(-zeta wn t) sqrt(1/(1-zeta^2)) bounds the
    # error; the settling time is the last exit from the +-10 % band, found on a fine grid
    zeta, wn = 0.3, 2 * np.pi * 2.4
    t = np.linspace(0, 5, 500001)
    y = second_order_step(zeta, wn, t)
    ts = metrics.settling_time(t, y)
    first_90 = t[np.argmax(y >= 0.9)]
    assert ts > 2 * first_90  # the overshoot of 37 % keeps it outside the band longer
    after = t >= ts
    assert np.all(np.abs(y[after] - 1) <= 0.1 + 1e-6) and abs(abs(y[~after][-1] - 1) - 0.1) < 1e-3
    # and it lies within one half period of the envelope estimate ln(10 / sqrt(1-zeta^2)) / (zeta wn)
    estimate = np.log(10 / np.sqrt(1 - zeta**2)) / (zeta * wn)
    assert abs(ts - estimate) < np.pi / (wn * np.sqrt(1 - zeta**2))


def test_velocity_ratio_peaks_ride_height_and_tire():
    t = np.linspace(0, 1, 10001)[:-1]
    v_in = np.cos(2 * np.pi * 5 * t)
    assert metrics.rms_velocity_ratio(2.0 * v_in, v_in) == pytest.approx(2.0)
    assert metrics.peak_velocities(2.0 * v_in) == pytest.approx((2.0, -2.0), abs=1e-3)
    assert metrics.average_ride_height_change(np.full(10, -0.001), np.zeros(10)) == pytest.approx(-0.001)
    Ft = np.maximum(1000 + 2000 * np.sin(2 * np.pi * 5 * t), 0.0)
    # contact lost while sin < -1/2: one third of each period
    assert metrics.lift_off_fraction(Ft) == pytest.approx(1 / 3, abs=1e-3)
    assert metrics.min_tire_load_ratio(Ft, 1000.0) == 0.0


def test_iso8608_road_has_its_class_variance():
    t = np.arange(0, 200.0, 0.005)
    y, v = road.iso8608(t, speed=20.0, road_class="C", seed=3)
    assert np.var(y) == pytest.approx(road.iso8608_variance("C"), rel=0.25)
    tf = np.arange(0, 0.5, 1e-5)  # the road reaches 200 Hz at 20 m/s: check v finely sampled
    yf, vf = road.iso8608(tf, speed=20.0, road_class="C", seed=3)
    assert np.allclose(np.gradient(yf, tf)[1:-1], vf[1:-1], atol=0.01 * np.abs(vf).max())
    with pytest.raises(ValueError, match="road class"):
        road.iso8608(t, 20.0, "Z")


def test_step_and_harmonic():
    t = np.array([0.0, 0.5, 1.0])
    assert road.step(t, 0.025, 0.5).tolist() == [0.0, 0.025, 0.025]
    y, v = road.harmonic(np.array([0.0]), 0.0127, 4.0)
    assert y[0] == 0.0 and v[0] == pytest.approx(0.0127 * 2 * np.pi * 4)
