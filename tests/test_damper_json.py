"""Damper descriptions as data: round trip, and clear errors for bad input."""
import json

import numpy as np
import pytest

from models.damper import DamperError, from_dict, load, preset_names, save, to_dict
from models.physics.simulate import simulate


@pytest.mark.parametrize("name", preset_names())
def test_presets_round_trip_through_json(name, tmp_path):
    d = load(name)
    save(d, tmp_path / "d.json")
    assert to_dict(load(str(tmp_path / "d.json"))) == to_dict(d)


def koni_dict():
    return to_dict(load("koni"))


def error_of(data):
    with pytest.raises(DamperError) as e:
        from_dict(data)
    return str(e.value)


def test_missing_field_is_named():
    d = koni_dict()
    del d["gas_spring"]["V0"]
    assert error_of(d) == "gas_spring.V0: missing"


def test_wrong_type_is_named():
    d = koni_dict()
    d["valves"]["piston"]["rebound"]["mid"]["C_linw"] = "fast"
    assert "valves.piston.rebound.mid.C_linw: expected a number" in error_of(d)


def test_unknown_field_and_layout():
    d = koni_dict()
    d["geometry"]["bore"] = 0.046
    assert error_of(d) == "geometry.bore: unknown field"
    d = koni_dict()
    d["layout"] = "twin-tube"
    assert "layout" in error_of(d)


def test_negative_volume():
    d = koni_dict()
    d["geometry"]["V20"] = -1e-6
    assert error_of(d) == "geometry.V20: -1e-06 m^3 is outside 1e-09..0.01 m^3"


def test_gas_volume_exhausted_by_stroke():
    d = koni_dict()
    d["gas_spring"]["V0"] = 1e-5  # the stroke sweeps 1.2e-5 m^3 of rod
    assert "exhausted by the stroke" in error_of(d)


def test_gas_volume_exhausted_by_temperature():
    d = koni_dict()
    d["gas_spring"]["K_voil"] = 4e-7  # 130 K of expansion eats 52 cc of 48.6
    assert "exhausted at full stroke and 150 C" in error_of(d)
    koni = load("koni")
    with pytest.raises(DamperError, match="exhausted"):
        simulate(koni, np.array([0.0, 0.1]), np.array([0.03, 0.03]), T=800.0)


def test_wrong_valve_sign_is_named():
    d = koni_dict()
    d["valves"]["piston"]["rebound"]["low"]["C_orrpw"] = 280441.0
    assert "valves.piston.rebound.low" in error_of(d)


def test_a_model_the_loader_refuses_is_not_written(tmp_path):
    d = load("fox-heavy")
    d.valves.piston.rebound.high.C_ilinw = 0.5 * d.valves.piston.rebound.mid.C_ilinw
    with pytest.raises(DamperError, match="wrong side of zero velocity"):
        save(d, tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()


def test_unknown_preset_and_bad_file(tmp_path):
    with pytest.raises(DamperError, match="unknown damper preset 'konni'"):
        load("konni")
    p = tmp_path / "broken.json"
    p.write_text("{ not json")
    with pytest.raises(DamperError, match="broken.json: not valid JSON"):
        load(str(p))
    with pytest.raises(DamperError, match="no such file"):
        load(str(tmp_path / "absent.json"))


def test_preset_files_are_plain_data():
    """Each preset is a JSON file any tool reads, named as it is called, holding the model."""
    for name in preset_names():
        doc = json.loads((load.__globals__["PRESET_DIR"] / f"{name}.json").read_text())
        assert doc["name"] == name
        assert to_dict(from_dict(doc)) == to_dict(load(name))
