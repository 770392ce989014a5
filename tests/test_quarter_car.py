"""Quarter-car parameters, static equilibrium and linear modes (thesis chapter 5)."""
import json

import numpy as np
import pytest

from models import quarter_car as qcm
from models.damper import DamperError


def test_linear_modes_match_closed_form():
    qc = qcm.QuarterCar("unit", m_s=1.0, m_u=1.0, k_s=1.0, k_t=1.0, c_tire=0.0, F_c1=0.0, F_c3=0.0)
    # M^-1 K = [[1, -1], [-1, 2]]: eigenvalues (3 -+ sqrt 5) / 2
    expected = np.sqrt([(3 - 5**0.5) / 2, (3 + 5**0.5) / 2]) / (2 * np.pi)
    assert qcm.natural_frequencies(qc) == pytest.approx(tuple(expected))


def test_eq_5_1_and_5_2_static_deflections():
    qc = qcm.load("simulator")
    z1, z2 = qcm.static_deflections(qc, F_gas=500.0)
    assert z1 == pytest.approx((252.5 * 9.81 - 500.0) / 70e3)
    assert z2 == pytest.approx((252.5 + 45.4) * 9.81 / 350e3)


def test_table_5_3_and_tire_mode():
    b, w = qcm.natural_frequencies(qcm.load("simulator-9kg"))
    assert b == pytest.approx(2.41, abs=0.01)
    assert w == pytest.approx(14.10, rel=0.02)
    assert qcm.tire_mode_frequency(qcm.load("simulator")) == pytest.approx(5.46, abs=0.01)


def test_race_car_tire_damping_gives_five_percent():
    qc = qcm.load("race-car")
    zeta = qc.c_tire / (2 * np.sqrt((qc.k_s + qc.k_t) * qc.m_u))
    assert zeta == pytest.approx(0.05, rel=1e-3)
    assert qc.F_c1 == 15.0 and qc.F_c3 == 0.0


def test_gas_spring_rate_raises_bounce_frequency():
    qc = qcm.load("simulator")
    assert qcm.natural_frequencies(qc, k_damper=5e3)[0] > qcm.natural_frequencies(qc)[0]


def test_bad_quarter_car_input(tmp_path):
    with pytest.raises(DamperError, match="unknown quarter-car 'sedan'"):
        qcm.load("sedan")
    data = qcm.to_dict(qcm.load("simulator"))
    data["m_s"] = -10.0
    p = tmp_path / "qc.json"
    p.write_text(json.dumps(data))
    with pytest.raises(DamperError, match="qc.json: m_s: must be positive"):
        qcm.load(str(p))
    del data["k_t"]
    p.write_text(json.dumps(data))
    with pytest.raises(DamperError, match="k_t: missing"):
        qcm.load(str(p))
