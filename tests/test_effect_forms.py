"""The plant's other forms of each hidden effect (sim_backend/effects/ FORMS): each is
wired into the physics, differs from the default form at the same VALUE, and its pieces do
what their descriptions say."""
import math

import numpy as np
import pytest

from models.physics.compressibility import AIR_P_MIN, pressure_air, strain_air
from sim_backend.effects import HIDDEN, FORMS
from sim_backend.options import plain_cell
from sim_backend.plant import MODE_FOLLOW, Plant
from sim_backend.effects.breakaway_friction import stribeck
from sim_backend.effects.cavitation import floored
from sim_backend.effects.presliding_friction import elastoplastic


def _force(effects, seconds=0.6, h=5e-4, channel=None):
    """Load-cell force [N] (noise-free) of the plain cell under a 4 Hz, 12.7 mm sine (or
    the reading of `channel`)."""
    name, params, _ = plain_cell()
    p = Plant(name, params=params, effects=effects, h=h)
    x0, out = p.x_act, []
    for k in range(int(seconds / h)):
        p.command(MODE_FOLLOW, x0 + 0.0127 * np.sin(2 * np.pi * 4.0 * k * h))
        p.advance(h)
        out.append(p.F if channel is None else p.readings()[channel])
    return np.array(out)


def test_every_effect_has_at_least_three_plant_forms():
    assert all(len(h.forms) >= 2 for h in HIDDEN.values())
    assert {f"{n}:{f}" for n, h in HIDDEN.items() for f in h.forms} == set(FORMS)


@pytest.mark.parametrize("key", [k for k in FORMS if not k.startswith(("sensor_delay", "gas_temperature",
                                                                       "damping_temperature", "gain_drift"))])
def test_each_form_changes_the_force_and_differs_from_the_default(key):
    name, form = key.split(":")
    value = {"cavitation": 2.5e6, "compressibility": 2e9, "breakaway_friction": 3.0,
             "presliding_friction": 1e-4}.get(name, 20 * HIDDEN[name].guess)
    null = _force({})
    default = _force({name: value})
    other = _force({name: value, "forms": {name: form}})
    assert np.all(np.isfinite(other))
    rms = (lambda a, b: float(np.sqrt(np.mean((a - b) ** 2))))
    assert rms(other, null) > 0.2, "the form does nothing"
    assert rms(other, default) > 0.005 * rms(default, null), "the form is the default's"


def test_each_gain_drift_scales_the_load_cells_reading_as_its_form_says():
    """The load cell's reading, not the force: the default drifts at VALUE per second, the
    settling form starts at that rate and levels off at VALUE GAIN_TAU_S, the stepped form
    moves every GAIN_STEP_S."""
    from sim_backend.effects.gain_drift import GAIN_STEP_S, GAIN_TAU_S, gain_drift
    r = 1e-3
    assert gain_drift(r, None, 10.0) == pytest.approx(1e-2)
    assert gain_drift(r, "settling", 1e-3) == pytest.approx(1e-6, rel=1e-3)
    assert gain_drift(r, "settling", 50 * GAIN_TAU_S) == pytest.approx(r * GAIN_TAU_S)
    assert gain_drift(r, "stepped", 0.99 * GAIN_STEP_S) == 0.0
    assert gain_drift(r, "stepped", 2.5 * GAIN_STEP_S) == pytest.approx(2 * r * GAIN_STEP_S)
    h, F = 5e-4, _force({})
    t = h * np.arange(1, len(F) + 1)
    null = _force({}, channel="force")
    for form in (None, "settling", "stepped"):
        fx = {"gain_drift": 0.5, **({"forms": {"gain_drift": form}} if form else {})}
        read = _force(fx, channel="force")  # the same noise: the difference is the gain's
        want = F * np.array([gain_drift(0.5, form, u) for u in t])
        assert np.allclose(read - null, want, atol=1e-6 * np.max(np.abs(F))), form
    assert np.allclose(_force({"gain_drift": 0.5}), F)  # the damper's force itself unchanged


def test_temperature_forms_follow_their_own_temperature():
    """The gas follows the reservoir or the lagged body; damping temperature acts in one
    direction only."""
    from sim_backend.plant import thermal
    name, params, _ = plain_cell()
    for form, T_of in (("reservoir", lambda p: p.T_res), ("lagged", lambda p: p.hidden[0].T_lag)):
        p = Plant(name, params=params, effects={"gas_temperature": 0.5, "forms": {"gas_temperature": form}})
        p.T, p.T_res, p.hidden[0].T_lag = 320.0, 300.0, 310.0
        assert thermal.gas_temperature(p) == pytest.approx(p.T_cell + 0.5 * (T_of(p) - p.T_cell))
    for form, (kc, kr) in (("compression", (2e-3, 0.0)), ("rebound", (0.0, 2e-3))):
        p = Plant(name, params=params, effects={"damping_temperature": 1e-3, "forms": {"damping_temperature": form}})
        ts = p.damper.temperature
        assert (ts.compression.K_effoil, ts.rebound.K_effoil) == (kc, kr)


def test_sensor_lag_forms_delay_the_displacement_by_about_their_value():
    x = _force({}, channel="x")
    for form in (None, "transport", "second_order"):
        y = _force({"sensor_delay": 2e-3, **({"forms": {"sensor_delay": form}} if form else {})}, channel="x")
        lags = np.arange(0, 12)  # steps of 0.5 ms
        err = [np.mean((y[400 + k:1000 + k] - x[400:1000]) ** 2) for k in lags]
        assert lags[int(np.argmin(err))] == 4, form


def test_entrained_air_softens_the_oil_below_its_reference_pressure():
    K, A, P_ref = 1.5e9, 150.0, 2e6
    for P in (1e5, 3e5, 2e6, 8e6):  # the inverse is exact, and dP / d(strain) is 1 / (1/K + A/P^2)
        assert pressure_air(strain_air(P, P_ref, K, A), P_ref, K, A) == pytest.approx(P, rel=1e-9)
        dP = P * 1e-6
        K_eff = 2 * dP / (strain_air(P + dP, P_ref, K, A) - strain_air(P - dP, P_ref, K, A))
        assert K_eff == pytest.approx(1 / (1 / K + A / max(P, AIR_P_MIN) ** 2), rel=1e-6)


def test_elastoplastic_elements_follow_then_slide():
    z = [0.0, 0.0]
    z = elastoplastic(z, 5e-6, [1e-5, 2e-5])
    assert z == pytest.approx([0.5, 0.25])
    z = elastoplastic(z, 1e-4, [1e-5, 2e-5])
    assert z == [1.0, 1.0]
    assert elastoplastic(z, -1e-5, [1e-5, 2e-5]) == pytest.approx([0.0, 0.5])


def test_stribeck_shapes_and_the_soft_floor():
    for shape in ("gaussian", "exponential", "lorentzian", "power"):
        assert stribeck(0.0, shape) == 1.0 and stribeck(50.0, shape) < 1e-3
    assert stribeck(1.0, "power") == 0.25
    floor = 1e5  # continuous with slope one at twice the floor, the floor far below
    assert floored(2 * floor, floor, "soft") == pytest.approx(2 * floor)
    assert floored(2 * floor - 1.0, floor, "soft") == pytest.approx(2 * floor - 1.0, abs=1e-4)
    assert floored(-1e6, floor, "soft") == pytest.approx(floor, rel=1e-4)
    assert floored(5e4, floor) == floor and not math.isnan(floored(-1e9, floor, "soft"))
