"""Unstated geometry in the presets is the documented calibration, reproducibly."""
import pytest

from models.validation.calibrate import rod_area_for_rise
from models.damper import load
from models.physics.simulate import C_to_K


@pytest.mark.parametrize("name, target, T1, T2", [
    ("koni", 250.0, 94.0, 149.0),  # section 2.2.2
    ("mechformance", 400.0, 38.0, 146.0),  # section 4.3 (gas part of the bias)
])
def test_rod_area_reproduces_calibration(name, target, T1, T2):
    d = load(name)
    g = d.gas_spring
    A = rod_area_for_rise(target, C_to_K(T1), C_to_K(T2), d.geometry.stroke, g.P0, g.V0, g.T0, g.K_voil, g.K_voint)
    assert d.geometry.A_r == pytest.approx(A, rel=1e-4)
